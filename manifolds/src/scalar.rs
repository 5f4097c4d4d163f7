//! The scalar of a state: `f64` (the default everywhere) or `f32` (a microcontroller's
//! single-precision FPU).
//!
//! Every type of the crate takes its scalar as a parameter that defaults to `f64`:
//! `So3` is `So3<f64>`, `R3` is `R3<f64>`, `Tangent<M>` is `Tangent<M, f64>`, and a
//! `Manifold` bound is `Manifold<f64>`. Code written for `f64` reads as before; code for
//! `f32` names it: `So3<f32>`, `Manifold<f32>`.
//!
//! The numerical thresholds that depend on the precision (where a closed form gives way
//! to its series, the central-difference step) are constants of the scalar, so the `f64`
//! numbers are exactly those of the code before the scalar became a parameter.

use nalgebra::RealField;

/// A floating-point scalar the crate's states are built on: `f64` or `f32`.
///
/// Sealed in practice (the constants below are tuned for IEEE binary64 and binary32); it
/// is implemented for those two types only.
pub trait Real: RealField + Copy + Default + core::fmt::Display {
    /// Machine epsilon.
    const EPS: Self;
    /// `ε` as an `f64`, for tolerances computed in double precision.
    const EPS_F64: f64;
    /// Below this rotation angle the SO(3) closed forms (`Exp`, `Jr`, `Jr⁻¹`) lose digits to
    /// cancellation and their Taylor series are used instead: `1e-2` in `f64`; `0.1` in
    /// `f32`, where the series' first omitted term (`θ⁶/5040`, 2e-10 at 0.1) is still far
    /// below `ε` and the coefficients of `Jr` and `Jr⁻¹` keep every digit (the closed forms'
    /// cancellation costs them `ε/θ²` relative, 1e-3 at 1e-2, though it reaches the
    /// matrices' entries only multiplied by `θ²`: the test `single_precision_agrees_with_double`
    /// measures ≤ 1.8 ε against `f64` with either threshold).
    const SMALL_ANGLE: Self;
    /// Central-difference step for Jacobians of unit-scale maps, about `ε^(1/3)` (`1e-6`
    /// in `f64`, `1e-3` in `f32`).
    const DIFF_STEP: Self;
    /// A constant of the source, converted (exact for `f64`, rounded to nearest for `f32`).
    fn lit(x: f64) -> Self;
    /// The value as an `f64` (exact for both scalars).
    fn to_f64(self) -> f64;
}

impl Real for f64 {
    const EPS: f64 = f64::EPSILON;
    const EPS_F64: f64 = f64::EPSILON;
    const SMALL_ANGLE: f64 = 1e-2;
    const DIFF_STEP: f64 = 1e-6;
    #[inline(always)]
    fn lit(x: f64) -> f64 {
        x
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
}

impl Real for f32 {
    const EPS: f32 = f32::EPSILON;
    const EPS_F64: f64 = f32::EPSILON as f64;
    const SMALL_ANGLE: f32 = 0.1;
    const DIFF_STEP: f32 = 1e-3;
    #[inline(always)]
    fn lit(x: f64) -> f32 {
        x as f32
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
}
