//! The estimation core: model traits, the error-state Kalman filter, the
//! noise-adaptation hook, reports and observers, consistency statistics and Jacobian
//! harnesses.
//!
//! | item | what |
//! |---|---|
//! | [`ProcessModel`], [`MeasurementModel`] | what users implement; Jacobians in named structs |
//! | [`ErrorStateFilter`] | predict / update (Cholesky, Joseph) / inject and reset on any [`Manifold`] state |
//! | [`RtsSmoother`] | the fixed-interval (RTS) smoother on manifolds: records the forward pass, runs the backward one |
//! | [`SigmaPoints`], [`manifold_mean`] | the unscented (sigma-point) filter on manifolds: `predict_unscented` / `update_unscented` on the same filter, models, strategies and reports |
//! | [`FixedLagSmoother`] | the same recursion over the last lag only (steps or seconds), bounded memory |
//! | [`Replay`] | delayed measurements applied at their own time, by replay of a bounded history |
//! | [`SegmentSmoother`] | the same smoother for long high-rate runs: one record per update on disk, steps rebuilt by replay |
//! | [`NoiseStrategy`], [`FixedNoise`], [`Adaptation`] | the adaptation hook and its zero-sized default |
//! | [`StreamId`], [`StreamMap`] | named measurement streams and per-stream strategy state |
//! | [`UpdateReport`], [`Observer`], [`UpdateLog`] | per-update telemetry |
//! | [`FilterError`] | typed failures; the filter (state, covariance, strategy) is unchanged after any of them |
//! | [`CovBackend`]: [`StaticCov`], [`DynamicCov`], `FaerCov` | covariance back-ends: nalgebra static (default), nalgebra dynamic, faer (feature `faer`) |
//! | [`consistency`] | NEES / NIS and χ² bands |
//! | `harness` (feature `testing`) | analytic vs numerical Jacobians through ⊕/⊖ for any model |
//! | [`fixed_from_dynamic`], [`symmetrize`] | a runtime-sized matrix into a typed one (typed error); exact symmetry for a custom strategy's covariances |
//! | [`linear`] | linear-Gaussian models (the plain Kalman filter as a special case) |
//! | [`FilterScalar`] | the scalar: `f64` (the default of every type, the AVX2/FMA kernels) or `f32` (plain loops; a microcontroller's FPU) |
//!
//! Every type and function is reachable by one path: the crate's root, except the
//! namespaces [`consistency`], [`discretize`], [`linear`] and `harness`, whose items are
//! theirs alone (the modules behind the root are private, as nalgebra's `geometry` is).
//!
//! # Features
//!
//! - `faer` (opt-in): the `FaerCov` back-end on faer's products. Without it the
//!   crate depends on nalgebra and statrs only.
//! - `std` (default): everything below the error-state filter itself. Without it the crate
//!   is `no_std` with no allocator: [`ErrorStateFilter`] on [`StaticCov`] with
//!   [`FixedNoise`] (or any strategy that needs no heap), the model traits, [`linear`],
//!   [`discretize`] and the reports, for a microcontroller
//!   (`cargo build -p estimator-core --no-default-features --target thumbv7em-none-eabihf`).
//!   The smoothers, [`Replay`], the sigma-point and iterated updates, the heap back-ends,
//!   [`consistency`] (χ² quantiles from statrs), [`UpdateLog`] and [`StreamMap`] need it;
//!   [`ErrorStateFilter::covariance`] too (a `Cow`): use
//!   [`covariance_raw`](ErrorStateFilter::covariance_raw) there.
//! - `testing`: the Jacobian harness (`harness`) and the manifold law harness of
//!   `manifolds` (`manifolds/testing`), with proptest.
//!
//! # Scalar
//!
//! The filter, the model traits, the back-end trait, the strategies' hook and the reports
//! take their scalar as a last type parameter that defaults to `f64` (`ErrorStateFilter<X>`,
//! `impl ProcessModel for M`, `impl NoiseStrategy for S` are the `f64` ones, as before).
//! `f32` is named: `ErrorStateFilter<X, FixedNoise, StaticCov, f32>` on a state `X:
//! Manifold<f32>`, models implementing `ProcessModel<f32>`. The heap back-ends, the
//! smoothers and the strategies of `adaptive` are `f64`.
//!
//! Convention: right (body-frame) perturbation, `true = nominal ⊕ δx`
//! (see [`manifolds::Manifold`]).
#![cfg_attr(not(feature = "std"), no_std)]
#![deny(missing_docs)]
#![allow(non_snake_case)]

mod adapt;
mod backend;
#[cfg(feature = "bench")]
pub mod bench;
#[cfg(feature = "std")]
pub mod consistency;
#[cfg(feature = "std")]
mod delayed;
mod dims;
pub mod discretize;
mod entries;
mod error;
mod filter;
#[cfg(feature = "testing")]
pub mod harness;
#[cfg(feature = "std")]
mod iterated;
mod kernels;
mod linalg;
pub mod linear;
mod report;
mod scalar;
#[cfg(feature = "std")]
mod segments;
pub mod simd;
#[cfg(feature = "std")]
mod smoother;
mod stream;
mod traits;
#[cfg(feature = "std")]
mod unscented;

pub use adapt::{
    Adaptation, CovView, Factors, FixedNoise, NisGate, NoiseStrategy, PostUpdate, PriorScaling,
    QAdjust, Verdict,
};
#[cfg(feature = "faer")]
pub use backend::FaerCov;
pub use backend::{CovBackend, StaticCov, UpdateForm};
#[cfg(feature = "std")]
pub use backend::{DenseCov, DynamicCov};
#[cfg(feature = "std")]
pub use delayed::{Replay, ReplayCheckpoint, ReplaySmoother, STAMP_TOLERANCE};
pub use dims::{Cov, FilterAlloc, StateDim};
pub use error::FilterError;
pub use filter::{ErrorStateFilter, ResetMode};
#[cfg(feature = "std")]
pub use iterated::IteratedReport;
#[cfg(feature = "std")]
pub use linalg::fixed_from_dynamic;
pub use linalg::symmetrize;
#[cfg(feature = "std")]
pub use report::UpdateLog;
pub use report::{NoObserver, Observer, UpdateReport, UpdateSummary};
pub use scalar::FilterScalar;
#[cfg(feature = "std")]
pub use segments::{
    AdjointForm, SegmentSmoother, SmoothedRow, SmootherError, Spill, StepRecorder, AFTER_FORMS,
};
#[cfg(feature = "std")]
pub use smoother::{FixedLagSmoother, Lag, RtsSmoother, RtsStep, Smoothed};
pub use stream::StreamId;
#[cfg(feature = "std")]
pub use stream::StreamMap;
pub use traits::{
    JacobiansOf, MeasurementJacobians, MeasurementModel, ProcessJacobians, ProcessJacobiansOf,
    ProcessModel,
};
#[cfg(feature = "std")]
pub use unscented::{manifold_mean, SigmaPoints, SigmaWeights};

pub use manifolds::{self, DimAlloc, Manifold, Tangent, TangentMatrix};
pub use nalgebra;

/// What the workspace's other crates share with this one and users do not call (not an
/// API: it may change at any release).
#[doc(hidden)]
#[cfg(feature = "std")]
pub mod __private {
    pub use crate::stream::clone_entries_from;
}
