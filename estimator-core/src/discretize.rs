//! Continuous-time models to the discrete `Φ` and `Q_d` the filter propagates with.
//!
//! For `δẋ = F δx + G w`, `E[w(t) w(s)ᵀ] = Q_c δ(t − s)`, held over a step `dt`:
//! `Φ = exp(F dt)` and `Q_d = ∫₀^dt exp(F s) G Q_c Gᵀ exp(F s)ᵀ ds`.
//!
//! - [`van_loan`] computes both exactly (up to the matrix exponential's rounding) from
//!   one exponential of the `2N × 2N` block matrix `[[−F, G Q_c Gᵀ], [0, Fᵀ]] dt`
//!   (Van Loan 1978): its lower-right block is `Φᵀ`, its upper-right `Φ⁻¹ Q_d`.
//! - [`first_order`] is the usual `Φ ≈ I + F dt`, `Q_d ≈ G Q_c Gᵀ dt`, with errors
//!   `O(dt²)` in `Φ` — what most hand-written models use, and what the Jacobian
//!   harness's tolerance rejects at small steps when the model's own `propagate` is
//!   exact: check such a model against [`van_loan`] instead, or with a tolerance of order
//!   `(‖F‖ dt)²`.

#[cfg(feature = "std")]
use nalgebra::DMatrix;
use nalgebra::{DefaultAllocator, DimName, OMatrix};

/// `Φ` and `Q_d` exactly, by Van Loan's method (see the [module](self)); feature `std` (a
/// `2N × 2N` heap matrix).
#[cfg(feature = "std")]
#[allow(non_snake_case)]
pub fn van_loan<N: DimName, L: DimName>(
    F: &OMatrix<f64, N, N>,
    G: &OMatrix<f64, N, L>,
    Qc: &OMatrix<f64, L, L>,
    dt: f64,
) -> (OMatrix<f64, N, N>, OMatrix<f64, N, N>)
where
    DefaultAllocator: nalgebra::allocator::Allocator<N, N>
        + nalgebra::allocator::Allocator<N, L>
        + nalgebra::allocator::Allocator<L, L>
        + nalgebra::allocator::Allocator<L, N>,
{
    let n = N::DIM;
    let gqg = G * Qc * G.transpose();
    let mut m = DMatrix::<f64>::zeros(2 * n, 2 * n);
    for i in 0..n {
        for j in 0..n {
            m[(i, j)] = -F[(i, j)] * dt;
            m[(i, n + j)] = gqg[(i, j)] * dt;
            m[(n + i, n + j)] = F[(j, i)] * dt;
        }
    }
    let e = m.exp();
    let phi = OMatrix::<f64, N, N>::from_fn(|i, j| e[(n + j, n + i)]);
    let upper = OMatrix::<f64, N, N>::from_fn(|i, j| e[(i, n + j)]);
    let mut qd = &phi * upper;
    // symmetric by construction; rounding is made symmetric too
    qd = (&qd + qd.transpose()) * 0.5;
    (phi, qd)
}

/// `Φ ≈ I + F dt` and `Q_d ≈ G Q_c Gᵀ dt` (first order; see the [module](self)).
#[allow(non_snake_case)]
pub fn first_order<N: DimName, L: DimName>(
    F: &OMatrix<f64, N, N>,
    G: &OMatrix<f64, N, L>,
    Qc: &OMatrix<f64, L, L>,
    dt: f64,
) -> (OMatrix<f64, N, N>, OMatrix<f64, N, N>)
where
    DefaultAllocator: nalgebra::allocator::Allocator<N, N>
        + nalgebra::allocator::Allocator<N, L>
        + nalgebra::allocator::Allocator<L, L>
        + nalgebra::allocator::Allocator<L, N>,
{
    (OMatrix::<f64, N, N>::identity() + F * dt, G * Qc * G.transpose() * dt)
}
