//! Manifold states with ⊕/⊖ whose dimensions are checked at compile time.
//!
//! | item | what |
//! |---|---|
//! | [`Manifold`] | the ⊕/⊖ contract (right perturbation), tangent dimension as a type |
//! | [`So3`] | rotations on a unit quaternion: `exp`, `log`, [`right_jacobian`], [`right_jacobian_inverse`] |
//! | [`So2`] | planar rotations (headings, bearings) |
//! | [`Rn`], [`R1`], [`R2`], [`R3`] | Euclidean blocks (`nalgebra::SVector<T, N>`) |
//! | [`Real`] | the scalar, `f64` (default) or `f32` |
//! | tuples `(A, B, …)` up to 6 parts | products whose dimension is the type-level sum of the parts |
//! | [`composite_state!`] | named product states with a typed [`Block`] constant per field |
//! | [`Coeffs`] | a point as the flat row of its representation's numbers (manif's `coeffs()`) |
//! | [`numdiff`] | central-difference Jacobians through ⊕/⊖ |
//! | `testing` (feature) | the public law harness and proptest strategies |
//!
//! # Convention
//!
//! Right (body-frame) perturbation everywhere: `R ⊕ δθ = R·Exp(δθ)`,
//! `S ⊖ R = Log(R⁻¹·S)`, Euclidean blocks additive, `true = nominal ⊕ δx`.
//!
//! # Products
//!
//! The tangent of a product (a tuple, or a [`composite_state!`]) is the concatenation of its
//! parts' tangents, in order, and its dimension is their type-level sum (`(So3, R3, R3, R3,
//! R3)` has `Dim = Const<15>`). ⊕ and ⊖ act block by block, so every Jacobian is block
//! diagonal; a composite names its blocks with [`Block`] constants.
//!
//! # Scalar
//!
//! Every type takes its scalar as a parameter that defaults to `f64`: `So3` is
//! `So3<f64>`, `Manifold` is `Manifold<f64>`, `Tangent<M>` is `Tangent<M, f64>`. Single
//! precision is named: `So3<f32>`, `R3<f32>`, `(So3<f32>, R3<f32>)`, all `Manifold<f32>`;
//! `cast` converts rotations. The `f64` numbers are those of the code before the scalar was
//! a parameter (bit for bit). A named composite state ([`composite_state!`]) takes a scalar
//! when declared `struct Name<T> { … }` (its fields then name their type without one:
//! `att: So3 => ATT`).
//!
//! ```
//! use manifolds::{Manifold, So3, R3};
//! use nalgebra::Vector3;
//!
//! let x: (So3<f32>, R3<f32>) = (So3::exp(&Vector3::new(0.1, -0.2, 0.3)), R3::zeros());
//! let d = nalgebra::SVector::<f32, 6>::from_element(0.01);
//! assert!((x.oplus(&d).ominus(&x) - d).norm() < 1e-6);
//! ```
//!
//! # Generic code
//!
//! Generic items carry one bound per dimension, `DefaultAllocator: DimAlloc<M::Dim>`;
//! concrete code never writes it.
//!
//! # Without the standard library
//!
//! With `default-features = false` (no feature `std`) the crate is `no_std` and needs no
//! allocator: the floats' functions come from libm through nalgebra, with `std` from the
//! standard library as before (the same numbers on the host).
#![cfg_attr(not(feature = "std"), no_std)]
#![deny(missing_docs)]
#![allow(non_snake_case)]

mod blocks;
mod coeffs;
mod euclid;
pub use traits::numdiff;
mod product;
mod scalar;
mod so2;
mod so3;
mod traits;

#[cfg(feature = "testing")]
pub mod testing;

#[cfg(feature = "serde")]
pub use coeffs::serde_coeffs;
pub use coeffs::Coeffs;
pub use euclid::{Rn, R1, R2, R3};
pub use product::Block;
pub use scalar::Real;
pub use so2::{wrap_angle, So2};
pub use so3::{
    hat, left_jacobian, left_jacobian_inverse, right_jacobian, right_jacobian_inverse, So3,
};
pub use traits::{DimAlloc, Manifold, OminusJacobians, OplusJacobians, Tangent, TangentMatrix};

/// nalgebra, re-exported so that macros and users agree on the version.
pub use nalgebra;
#[cfg(feature = "serde")]
#[doc(hidden)]
pub use serde as __serde;

/// What `composite_state!` expands to calls (not an API).
#[doc(hidden)]
pub mod __private {
    pub use crate::blocks::{set_block, set_diagonal_block};
}
