//! The public law harness (feature `testing`): checks the ⊕/⊖ identities and every
//! provided Jacobian of any [`Manifold`] against central differences through ⊕/⊖, plus
//! samplers (proptest strategies) for the built-in types.
//!
//! A type is sampled by a [`Sampler`]: points, tangents inside the chart, and tangents at
//! the chart's boundary. Built-in types (and tuples of up to six of them) implement
//! [`LawSampler`], so `Sampler::of()` serves them; for any other type (your own, or a type
//! from a crate you depend on) pass a sampler in — no trait to implement, so the orphan
//! rule never gets in the way. Named composite states ([`composite_state!`]
//! (crate::composite_state)) get a `law_sampler` constructor that takes one sampler per
//! field.
//!
//! ```
//! use manifolds::testing::{arb_rn, Sampler};
//! use manifolds::{composite_state, So3, R3};
//!
//! composite_state! {
//!     /// A pose with a velocity.
//!     pub struct Body { pub att: So3 => ATT, pub pos: R3 => POS, pub vel: R3 => VEL }
//! }
//!
//! // Built-in parts: `Sampler::of()`; a custom range for the velocity.
//! fn body_sampler() -> Sampler<Body> {
//!     Body::law_sampler(Sampler::of(), Sampler::of(), Sampler::new(arb_rn(50.0), arb_rn(5.0)))
//! }
//!
//! // In a test file this is one line that generates the four tests:
//! // manifolds::manifold_law_tests!(body_laws, Body, sampler = body_sampler());
//! // Here, one of them by hand:
//! manifolds::testing::check_at_identity::<Body>(Default::default()).unwrap();
//! manifolds::testing::check_boundary(&body_sampler(), Default::default()).unwrap();
//! ```
//!
//! [`manifold_law_tests!`](crate::manifold_law_tests) generates four tests: at the
//! origin, near the origin (|δ| ≈ 1e-8), at random points (proptest) and at the chart
//! boundary (|δ| near π for rotations).

use core::f64::consts::PI;
use core::fmt;

use nalgebra::allocator::Allocator;
use nalgebra::{DMatrixView, DefaultAllocator, DimName, OMatrix, SVector, Vector1, Vector3};
use proptest::prelude::*;
use proptest::strategy::BoxedStrategy;

use crate::blocks::set_block;
use crate::numdiff;
use crate::scalar::Real;
use crate::traits::{DimAlloc, Manifold, Tangent};
use crate::{So2, So3};

mod samplers;

pub use samplers::*;

/// Tolerances of the law checks.
#[derive(Clone, Copy, Debug)]
pub struct LawTolerance {
    /// Identities, relative to `max(1, |δ|)`.
    pub law: f64,
    /// Jacobians, max-abs difference relative to `max(1, max|J|)`.
    pub jacobian: f64,
    /// Central-difference step.
    pub step: f64,
}

impl Default for LawTolerance {
    /// The `f64` tolerances: [`for_scalar::<f64>`](Self::for_scalar).
    fn default() -> Self {
        Self::for_scalar::<f64>()
    }
}

impl LawTolerance {
    /// The tolerances for states over the scalar `T`: in `f64` law 1e-9, Jacobian 1e-6,
    /// step 1e-6; for a coarser scalar they scale with its epsilon `ε`: law `100 ε`,
    /// Jacobian `100 ε^(2/3)` (the floor of a central difference), step
    /// [`T::DIFF_STEP`](Real::DIFF_STEP) — in `f32` 1.2e-5, 2.4e-3 and 1e-3.
    pub fn for_scalar<T: Real>() -> Self {
        let eps = T::EPS_F64;
        Self {
            law: (100.0 * eps).max(1e-9),
            jacobian: (100.0 * eps.powf(2.0 / 3.0)).max(1e-6),
            step: T::DIFF_STEP.to_f64(),
        }
    }
}

/// A violated law: which one, by how much, where.
#[derive(Clone, Debug)]
pub struct LawViolation {
    /// The law, e.g. `"x ⊕ (y ⊖ x) = y"`.
    pub law: &'static str,
    /// The measured error.
    pub error: f64,
    /// The tolerance it exceeded.
    pub tolerance: f64,
    /// The point, the other point and the tangent, printed.
    pub at: String,
}

impl fmt::Display for LawViolation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "law `{}` violated: error {:.3e} > tolerance {:.3e} at {}",
            self.law, self.error, self.tolerance, self.at
        )
    }
}

impl std::error::Error for LawViolation {}

fn max_abs<T: Real, R: DimName, C: DimName>(m: &OMatrix<T, R, C>) -> f64
where
    DefaultAllocator: Allocator<R, C>,
{
    m.iter().fold(0.0_f64, |a, v| a.max(v.to_f64().abs()))
}

/// Run `report` (a call that reports reset blocks, `Manifold::reset_blocks` or
/// `oplus_reset`) and write its blocks over the identity: its result, `G`, and whether the
/// blocks came in increasing order, square, in range and disjoint.
fn assembled_blocks<M: Manifold<T>, T: Real, Out>(
    report: impl FnOnce(&mut dyn FnMut(usize, DMatrixView<'_, T>)) -> Out,
) -> (Out, OMatrix<T, M::Dim, M::Dim>, bool)
where
    DefaultAllocator: DimAlloc<M::Dim>,
{
    let mut g = OMatrix::<T, M::Dim, M::Dim>::identity();
    let mut next_free = 0usize;
    let mut well_formed = true;
    let out = report(&mut |o, b| {
        let d = b.nrows();
        if o < next_free || b.ncols() != d || o + d > M::DIM {
            well_formed = false;
            return;
        }
        next_free = o + d;
        g.view_mut((o, o), (d, d)).copy_from(&b);
    });
    (out, g, well_formed)
}

/// Check every ⊕/⊖ law and every Jacobian of `M` at `x`, another point `y` and a
/// tangent `delta` inside the chart. Returns the first violation found.
///
/// Laws: `x ⊕ 0 = x`, `x ⊕ (y ⊖ x) = y`, `(x ⊕ δ) ⊖ x = δ`; Jacobians of
/// `x ⊕ δ` (w.r.t. `x` and `δ`) and of `(x ⊕ δ) ⊖ x` (w.r.t. both points) against
/// central differences through ⊕/⊖. Points are compared through ⊖, never with `==`.
/// Over any scalar (`M: Manifold<T>`; give `f32` states
/// [`LawTolerance::for_scalar`]`::<f32>()`).
pub fn check_laws<M: Manifold<T>, T: Real>(
    x: &M,
    y: &M,
    delta: &Tangent<M, T>,
    tol: LawTolerance,
) -> Result<(), LawViolation>
where
    DefaultAllocator: DimAlloc<M::Dim>,
{
    let at = || format!("x = {x:?}, y = {y:?}, δ = {:?}", delta.as_slice());
    let check = |law: &'static str, error: f64, tolerance: f64| {
        if error.is_finite() && error <= tolerance {
            Ok(())
        } else {
            Err(LawViolation { law, error, tolerance, at: at() })
        }
    };
    let norm = |v: Tangent<M, T>| v.norm().to_f64();
    let scale = delta.norm().to_f64().max(1.0);

    let zero = Tangent::<M, T>::zeros();
    check("x ⊕ 0 = x", norm(x.oplus(&zero).ominus(x)), tol.law)?;
    check("x ⊖ x = 0", norm(x.ominus(x)), tol.law)?;
    let y_minus_x = y.ominus(x);
    check(
        "x ⊕ (y ⊖ x) = y",
        norm(x.oplus(&y_minus_x).ominus(y)),
        tol.law * y_minus_x.norm().to_f64().max(1.0),
    )?;
    let x_plus_d = x.oplus(delta);
    check("(x ⊕ δ) ⊖ x = δ", norm(x_plus_d.ominus(x) - delta), tol.law * scale)?;

    // An analytic Jacobian is compared with central differences at `tol.step`; when they
    // disagree, differences at ten times the step decide whom to blame: if the two
    // numerical estimates disagree with each other as much, the map loses precision at
    // this point (cancellation, a discontinuity) and the check says so instead.
    let jac = |law: &'static str,
               analytic: &OMatrix<T, M::Dim, M::Dim>,
               numeric: &dyn Fn(T) -> OMatrix<T, M::Dim, M::Dim>| {
        let tolerance = tol.jacobian * max_abs(analytic).max(1.0);
        let fine = numeric(T::lit(tol.step));
        let err = max_abs(&(analytic - &fine));
        if err.is_finite() && err <= tolerance {
            return Ok(());
        }
        let coarse = numeric(T::lit(10.0 * tol.step));
        let spread = max_abs(&(&coarse - &fine));
        if spread.is_nan() || spread > tolerance {
            return Err(LawViolation {
                law: "numerical Jacobian unreliable: steps h and 10h disagree (cancellation \
                      or a discontinuity in ⊕/⊖ here; change the step or the point)",
                error: spread,
                tolerance,
                at: format!("{} (analytic vs step h: {err:.3e}), {}", law, at()),
            });
        }
        check(law, err, tolerance)
    };
    let exact =
        |law: &'static str, a: &OMatrix<T, M::Dim, M::Dim>, b: &OMatrix<T, M::Dim, M::Dim>| {
            check(law, max_abs(&(a - b)), tol.jacobian * max_abs(b).max(1.0))
        };
    let op = x.oplus_jacobians(delta);
    let n_x = |h| numdiff::jacobian(x, |xp| xp.oplus(delta).ominus(&x_plus_d), h);
    jac("J of x ⊕ δ w.r.t. x", &op.J_y_x, &n_x)?;
    let n_d = |h| {
        numdiff::jacobian_of_tangent::<M, M::Dim, T>(delta, |d| x.oplus(d).ominus(&x_plus_d), h)
    };
    jac("J of x ⊕ δ w.r.t. δ", &op.J_y_delta, &n_d)?;
    exact("oplus_jacobian_delta = J_y_delta", &x.oplus_jacobian_delta(delta), &op.J_y_delta)?;
    // The reset blocks, written over the identity, are the same Jacobian; they must be in
    // increasing order, square, in range and disjoint.
    let ((), g, well_formed) = assembled_blocks::<M, T, _>(|visit| x.reset_blocks(delta, visit));
    check("reset blocks ordered, square, in range", if well_formed { 0.0 } else { 1.0 }, 0.0)?;
    exact("reset_blocks assemble to J_y_delta", &g, &op.J_y_delta)?;
    // oplus_reset gives the same point and the same blocks as oplus and reset_blocks.
    let (y_fused, g_fused, well_formed) =
        assembled_blocks::<M, T, _>(|visit| x.oplus_reset(delta, visit));
    let what = "oplus_reset's blocks ordered, square, in range";
    check(what, if well_formed { 0.0 } else { 1.0 }, 0.0)?;
    check("oplus_reset's point = x ⊕ δ", norm(y_fused.ominus(&x_plus_d)), tol.law * scale)?;
    exact("oplus_reset's blocks = reset_blocks'", &g_fused, &g)?;

    // ⊖ Jacobians at a pair whose difference is δ (inside the chart by construction).
    let om = x_plus_d.ominus_jacobians(x);
    let n_y = |h| numdiff::jacobian(&x_plus_d, |yp| yp.ominus(x), h);
    jac("J of y ⊖ x w.r.t. y", &om.J_d_y, &n_y)?;
    let n_xo = |h| numdiff::jacobian(x, |xp| x_plus_d.ominus(xp), h);
    jac("J of y ⊖ x w.r.t. x", &om.J_d_x, &n_xo)?;
    // (x ⊕ δ) ⊖ x = δ for every δ in the chart, so ∂/∂δ: J⊖ (w.r.t. y) · J⊕ (w.r.t. δ) = I
    let chain = &om.J_d_y * &op.J_y_delta;
    exact("J⊖ · J⊕ = I", &chain, &OMatrix::<T, M::Dim, M::Dim>::identity())?;
    Ok(())
}

/// Deterministic near-identity tangents: `|δ| = 1e-8` along each axis and one diagonal.
pub fn near_identity_tangents<M: Manifold>() -> Vec<Tangent<M>>
where
    DefaultAllocator: DimAlloc<M::Dim>,
{
    near_identity_tangents_in::<M, f64>()
}

/// [`near_identity_tangents`] over any scalar.
pub fn near_identity_tangents_in<M: Manifold<T>, T: Real>() -> Vec<Tangent<M, T>>
where
    DefaultAllocator: DimAlloc<M::Dim>,
{
    let mut out = Vec::new();
    for i in 0..M::DIM {
        let mut e = Tangent::<M, T>::zeros();
        e[i] = T::lit(1e-8);
        out.push(e.clone());
        out.push(-e);
    }
    let diag = Tangent::<M, T>::from_element(T::one());
    out.push(scaled_in::<M, T>(&diag, 1e-8));
    out
}

/// Run the laws at the origin (δ = 0 and a unit-ish δ).
pub fn check_at_identity<M: Manifold>(tol: LawTolerance) -> Result<(), LawViolation>
where
    DefaultAllocator: DimAlloc<M::Dim>,
{
    check_at_identity_in::<M, f64>(tol)
}

/// [`check_at_identity`] over any scalar.
pub fn check_at_identity_in<M: Manifold<T>, T: Real>(tol: LawTolerance) -> Result<(), LawViolation>
where
    DefaultAllocator: DimAlloc<M::Dim>,
{
    let o = M::origin();
    check_laws(&o, &o, &Tangent::<M, T>::zeros(), tol)?;
    let unit = scaled_in::<M, T>(&Tangent::<M, T>::from_element(T::one()), 0.5);
    check_laws(&o, &o.oplus(&unit), &unit, tol)
}

/// Run the laws near the origin: every tangent of `|δ| = 1e-8`, at the origin and at a
/// point `1e-8` away from it.
pub fn check_near_identity<M: Manifold>(tol: LawTolerance) -> Result<(), LawViolation>
where
    DefaultAllocator: DimAlloc<M::Dim>,
{
    check_near_identity_in::<M, f64>(tol)
}

/// [`check_near_identity`] over any scalar.
pub fn check_near_identity_in<M: Manifold<T>, T: Real>(
    tol: LawTolerance,
) -> Result<(), LawViolation>
where
    DefaultAllocator: DimAlloc<M::Dim>,
{
    let o = M::origin();
    for d in near_identity_tangents_in::<M, T>() {
        let near = o.oplus(&d);
        check_laws(&o, &near, &d, tol)?;
        check_laws(&near, &o, &(-d.clone()), tol)?;
    }
    Ok(())
}

/// Run the laws at the chart boundary tangents of `sampler` (none for flat spaces), from
/// the origin and from a generic point.
pub fn check_boundary<M: Manifold<T>, T: Real>(
    sampler: &Sampler<M, T>,
    tol: LawTolerance,
) -> Result<(), LawViolation>
where
    DefaultAllocator: DimAlloc<M::Dim>,
{
    let o = M::origin();
    let dir = Tangent::<M, T>::from_fn(|i, _| T::lit(0.3 + 0.1 * i as f64));
    let generic = o.oplus(&scaled_in::<M, T>(&dir, 0.7));
    for b in &sampler.boundary {
        for x in [&o, &generic] {
            let y = x.oplus(b);
            check_laws(x, &y, b, tol)?;
        }
    }
    Ok(())
}

/// Generate the four law tests of a manifold type in a module named `$name`:
///
/// ```text
/// manifold_law_tests!(name, Type);                                  // Type: LawSampler
/// manifold_law_tests!(name, Type, tolerance);                       // LawTolerance
/// manifold_law_tests!(name, Type, sampler = expr);                  // any Manifold
/// manifold_law_tests!(name, Type, sampler = expr, tol = tolerance);
/// manifold_law_tests!(name, Type, scalar = f32);                   // Type: LawSampler<f32>
/// manifold_law_tests!(name, Type, sampler = expr, scalar = f32);   // any Manifold<f32>
/// ```
///
/// `sampler` is a [`Sampler<Type>`](Sampler) expression: no trait to implement, so a
/// type of another crate is tested as it is. In a test file (a doctest cannot hold
/// `#[test]` functions, so this one only shows the expansion compiles):
///
/// ```
/// use manifolds::testing::{arb_rn, Sampler};
/// use manifolds::{So3, R2};
///
/// manifolds::manifold_law_tests!(so3_laws, So3);
/// manifolds::manifold_law_tests!(
///     plane_laws,
///     (So3, R2),
///     sampler = Sampler::new(Sampler::<(So3, R2)>::of().points, arb_rn::<5>(0.1)),
/// );
/// # fn main() {}
/// ```
#[macro_export]
macro_rules! manifold_law_tests {
    ($name:ident, $T:ty $(,)?) => {
        $crate::manifold_law_tests!(
            @full $name, $T, f64,
            $crate::testing::Sampler::<$T>::of(),
            $crate::testing::LawTolerance::default()
        );
    };
    ($name:ident, $T:ty, scalar = $S:ty $(,)?) => {
        $crate::manifold_law_tests!(
            @full $name, $T, $S,
            $crate::testing::Sampler::<$T, $S>::of(),
            $crate::testing::LawTolerance::for_scalar::<$S>()
        );
    };
    ($name:ident, $T:ty, sampler = $s:expr $(,)?) => {
        $crate::manifold_law_tests!(
            @full $name, $T, f64, $s, $crate::testing::LawTolerance::default()
        );
    };
    ($name:ident, $T:ty, sampler = $s:expr, scalar = $S:ty $(,)?) => {
        $crate::manifold_law_tests!(
            @full $name, $T, $S, $s, $crate::testing::LawTolerance::for_scalar::<$S>()
        );
    };
    ($name:ident, $T:ty, sampler = $s:expr, tol = $tol:expr $(,)?) => {
        $crate::manifold_law_tests!(@full $name, $T, f64, $s, $tol);
    };
    ($name:ident, $T:ty, $tol:expr $(,)?) => {
        $crate::manifold_law_tests!(
            @full $name, $T, f64, $crate::testing::Sampler::<$T>::of(), $tol
        );
    };
    (@full $name:ident, $T:ty, $S:ty, $s:expr, $tol:expr) => {
        mod $name {
            #[allow(unused_imports)]
            use super::*;
            use $crate::testing::proptest::prelude::*;

            fn sampler() -> $crate::testing::Sampler<$T, $S> {
                $s
            }

            #[test]
            fn at_identity() {
                if let Err(e) = $crate::testing::check_at_identity_in::<$T, $S>($tol) {
                    panic!("{e}");
                }
            }

            #[test]
            fn near_identity() {
                if let Err(e) = $crate::testing::check_near_identity_in::<$T, $S>($tol) {
                    panic!("{e}");
                }
            }

            #[test]
            fn at_chart_boundary() {
                if let Err(e) = $crate::testing::check_boundary(&sampler(), $tol) {
                    panic!("{e}");
                }
            }

            $crate::testing::proptest::proptest! {
                #![proptest_config($crate::testing::proptest::prelude::ProptestConfig::with_cases(256))]
                #[test]
                fn at_random_points((x, y, d) in sampler().triples()) {
                    if let Err(e) = $crate::testing::check_laws(&x, &y, &d, $tol) {
                        return Err(TestCaseError::fail(e.to_string()));
                    }
                }
            }
        }
    };
}

pub use proptest;
