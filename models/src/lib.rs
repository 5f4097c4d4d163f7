//! Reusable models for the error-state filter.
//!
//! | item | what |
//! |---|---|
//! | [`kinematic::ConstantVelocity`], [`kinematic::ConstantAcceleration`] | linear kinematics on any number of axes |
//! | [`kinematic::Singer`] | first-order Markov acceleration (Singer 1970) |
//! | [`kinematic::CurrentStatistical`], [`cs::CsVariance`] | the current statistical model with membership-adapted limits |
//! | [`ahrs`] | the 9-state AHRS: CS-MAEKF, the "modified" and the "conventional" 9-state EKF, and the loitering-flight simulator |
//! | [`planar::Unicycle`], [`planar::RangeBearing`] | planar robot on `(R², SO(2))` with landmark range-bearing |
//!
//! # How to write your own model
//!
//! A model is a stateless value that says how the state moves and what it returns in
//! named structs. Take the constant-velocity model of this crate on `D` axes, state
//! `(p, v)`:
//!
//! 1. **Choose the state manifold.** A tuple of Euclidean blocks,
//!    `(SVector<f64, D>, SVector<f64, D>)`; its tangent dimension `2D` is a type, so the
//!    covariance is a stack matrix. Rotations, headings and geodetic positions are
//!    manifolds too (`So3`, `So2`, `ins_gnss::GeoPos`); name the blocks with
//!    `manifolds::composite_state!` when there are several.
//! 2. **Propagate the nominal state**: `propagate(x, u, dt)` returns `(p + v·dt, v)`.
//! 3. **Give the Jacobians at zero error**: `Φ = ∂(f(x ⊕ δ) ⊖ f(x))/∂δ` — here
//!    `[[I, dt·I], [0, I]]` — and the discrete noise `Q` (white acceleration:
//!    `q·[[dt³/3, dt²/2], [dt²/2, dt]] ⊗ I`). Return them in `ProcessJacobians { Phi, Q }`.
//! 4. **Measurements** implement `MeasurementModel`: `predict(x)` and
//!    `H = ∂(h(x ⊕ δ) ⊖ h(x))/∂δ`; a measurement on a manifold (a bearing) gets its
//!    residual through `⊖` automatically.
//! 5. **Test it like a law**: `estimator_core::harness::check_process_model(&m, &x, &u,
//!    dt, tol)` and `check_measurement_model(&h, &x, tol)` compare your Jacobians with
//!    central differences through ⊕/⊖; a proptest that runs random predict/update
//!    sequences and checks that `P` stays symmetric positive definite catches the rest.
//!
//! ```
//! use estimator_core::harness::check_process_model;
//! use estimator_core::{ErrorStateFilter, FixedNoise};
//! use models::kinematic::ConstantVelocity;
//! use nalgebra::{SMatrix, Vector2};
//!
//! let cv = ConstantVelocity::<2> { q: Vector2::repeat(0.5) };
//! let x0 = (Vector2::zeros(), Vector2::new(1.0, 0.0));
//! check_process_model(&cv, &x0, &(), 0.1, 1e-8).unwrap(); // Φ matches ⊕/⊖ differences
//! let mut f = ErrorStateFilter::new(x0, SMatrix::<f64, 4, 4>::identity(), FixedNoise).unwrap();
//! f.predict(&cv, &(), 0.1).unwrap();
//! assert!((f.state().0.x - 0.1).abs() < 1e-12);
//! ```
//!
//! # Without the standard library
//!
//! With `default-features = false` the crate is `no_std` with no allocator and keeps the
//! AHRS state, process and measurement models and the CS variance law ([`ahrs`], [`cs`]):
//! what a flight controller runs. The AHRS simulator and experiment (rand), the kinematic
//! and planar models need `std` (feature, default).
#![cfg_attr(not(feature = "std"), no_std)]
#![deny(missing_docs)]
#![allow(non_snake_case)]

pub mod ahrs;
pub mod cs;
#[cfg(feature = "std")]
pub mod kinematic;
#[cfg(feature = "std")]
pub mod planar;
