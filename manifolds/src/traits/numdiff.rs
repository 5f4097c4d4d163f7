//! Central-difference Jacobians taken through ⊕/⊖.
//!
//! A Jacobian of a map between manifolds is defined at zero perturbation in both tangent
//! spaces: column `j` of `∂f/∂x` is the derivative of `f(x ⊕ t eⱼ) ⊖ f(x)` at `t = 0`.
//! These helpers compute it by central differences and are the reference that every
//! analytic Jacobian in the project is checked against.

use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, DimName, OMatrix, OVector};

use super::{DimAlloc, Manifold, Tangent};
use crate::scalar::Real;

/// Default step in `f64`: balances truncation (`h²`) against rounding (`ε/h`) for
/// unit-scale maps. Generic code takes [`Real::DIFF_STEP`] (the same in `f64`).
pub const DEFAULT_STEP: f64 = 1e-6;

/// Jacobian of a tangent-valued map `g` at the point `x`, through `⊕` on the input side:
/// column `j` is `(g(x ⊕ h eⱼ) − g(x ⊕ −h eⱼ)) / 2h`.
///
/// Use it for maps whose output is already a tangent (or Euclidean) vector, e.g.
/// `|x| f(x).ominus(&f(x0))`.
pub fn jacobian<X, R, T>(x: &X, g: impl Fn(&X) -> OVector<T, R>, h: T) -> OMatrix<T, R, X::Dim>
where
    X: Manifold<T>,
    R: DimName,
    T: Real,
    DefaultAllocator: DimAlloc<X::Dim> + Allocator<R> + Allocator<R, X::Dim>,
{
    let mut J = OMatrix::<T, R, X::Dim>::zeros();
    let mut e = Tangent::<X, T>::zeros();
    for j in 0..X::DIM {
        e[j] = h;
        let plus = g(&x.oplus(&e));
        e[j] = -h;
        let minus = g(&x.oplus(&e));
        e[j] = T::zero();
        J.set_column(j, &((plus - minus) / (T::lit(2.0) * h)));
    }
    J
}

/// Jacobian of a map between manifolds, `∂(f(x ⊕ ε) ⊖ f(x))/∂ε` at `ε = 0`.
pub fn jacobian_between<X, Y, T>(x: &X, f: impl Fn(&X) -> Y, h: T) -> OMatrix<T, Y::Dim, X::Dim>
where
    X: Manifold<T>,
    Y: Manifold<T>,
    T: Real,
    DefaultAllocator: DimAlloc<X::Dim> + DimAlloc<Y::Dim> + Allocator<Y::Dim, X::Dim>,
{
    let y0 = f(x);
    jacobian::<X, Y::Dim, T>(x, |xp| f(xp).ominus(&y0), h)
}

/// Jacobian of a tangent-valued map of a tangent vector of `M` (a flat space, so plain
/// central differences): column `j` is `(g(d + h eⱼ) − g(d − h eⱼ)) / 2h`.
pub fn jacobian_of_tangent<M, R, T>(
    d: &Tangent<M, T>,
    g: impl Fn(&Tangent<M, T>) -> OVector<T, R>,
    h: T,
) -> OMatrix<T, R, M::Dim>
where
    M: Manifold<T>,
    R: DimName,
    T: Real,
    DefaultAllocator: DimAlloc<M::Dim> + Allocator<R> + Allocator<R, M::Dim>,
{
    let mut J = OMatrix::<T, R, M::Dim>::zeros();
    let mut p = d.clone();
    for j in 0..M::DIM {
        p[j] = d[j] + h;
        let plus = g(&p);
        p[j] = d[j] - h;
        let minus = g(&p);
        p[j] = d[j];
        J.set_column(j, &((plus - minus) / (T::lit(2.0) * h)));
    }
    J
}
