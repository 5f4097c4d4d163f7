//! Laws of the structured update kernels (unit tests: the kernels are crate-private), against the textbook dense products:
//!
//! - the multiplied-out Joseph form equals `(I − KH) P (I − KH)ᵀ + K R Kᵀ` for *any*
//!   gain `K` (not only the optimal one), on all three back-ends, and is exactly symmetric;
//! - the block reset `G P Gᵀ` (only the rows and columns of `G`'s non-identity diagonal
//!   blocks touched) equals the dense product, for small blocks and for one block
//!   spanning the whole state;
//! - `P Hᵀ` over the non-zero entries of `H` equals the dense product;
//! - the dense `Φ P Φᵀ + Q` kernel equals nalgebra's products.

use crate::kernels::{dense_sandwich, right_solve_cholesky};
use crate::{CovBackend, DynamicCov, FaerCov, StaticCov, UpdateForm};
use nalgebra::{Const, SMatrix};
use proptest::prelude::*;

const N: usize = 15;
const M: usize = 6;

type MatN = SMatrix<f64, N, N>;

fn spd(a: &MatN, diag: f64) -> MatN {
    a * a.transpose() * 0.1 + MatN::identity() * diag
}

/// A measurement noise (or innovation) covariance from any `r`: `r rᵀ + 0.1 I`.
fn noise(r: &SMatrix<f64, M, M>) -> SMatrix<f64, M, M> {
    r * r.transpose() + SMatrix::<f64, M, M>::identity() * 0.1
}

fn rel(a: &MatN, b: &MatN) -> f64 {
    (a - b).abs().max() / b.abs().max()
}

fn dense_joseph(
    P: &MatN,
    K: &SMatrix<f64, N, M>,
    H: &SMatrix<f64, M, N>,
    R: &SMatrix<f64, M, M>,
) -> MatN {
    let IKH = MatN::identity() - K * H;
    IKH * P * IKH.transpose() + K * R * K.transpose()
}

fn update_on<B: CovBackend<Const<N>>>(
    P: &MatN,
    K: &SMatrix<f64, N, M>,
    H: &SMatrix<f64, M, N>,
    R: &SMatrix<f64, M, M>,
    form: UpdateForm,
) -> MatN {
    let mut backend = B::default();
    let Pb = B::from_static(P);
    let PHt = backend.p_times_ht(H, &Pb);
    let S = H * PHt + R;
    let S = (S + S.transpose()) * 0.5;
    let mut out = B::from_static(&MatN::zeros());
    backend.update(&Pb, K, H, &PHt, R, &S, form, &mut out);
    B::as_static(&out).into_owned()
}

fn matrix<const R: usize, const C: usize>() -> impl Strategy<Value = SMatrix<f64, R, C>> {
    proptest::collection::vec(-1.0..1.0f64, R * C).prop_map(|v| SMatrix::from_column_slice(&v))
}

/// A measurement matrix with some zero entries (like a GNSS `H`).
fn sparse_h() -> impl Strategy<Value = SMatrix<f64, M, N>> {
    (matrix::<M, N>(), proptest::collection::vec(any::<bool>(), M * N)).prop_map(|(h, keep)| {
        SMatrix::from_fn(|i, j| if keep[j * M + i] { h[(i, j)] } else { 0.0 })
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn joseph_multiplied_out_equals_factored_for_any_gain(
        a in matrix::<N, N>(),
        K in matrix::<N, M>(),
        H in sparse_h(),
        r in matrix::<M, M>(),
    ) {
        let P = spd(&a, 0.5);
        let R = noise(&r);
        let reference = dense_joseph(&P, &K, &H, &R);
        let outs = [
            update_on::<StaticCov>(&P, &K, &H, &R, UpdateForm::Joseph),
            update_on::<DynamicCov>(&P, &K, &H, &R, UpdateForm::Joseph),
            update_on::<FaerCov>(&P, &K, &H, &R, UpdateForm::Joseph),
            update_on::<StaticCov>(&P, &K, &H, &R, UpdateForm::JosephFactored),
            update_on::<DynamicCov>(&P, &K, &H, &R, UpdateForm::JosephFactored),
            update_on::<FaerCov>(&P, &K, &H, &R, UpdateForm::JosephFactored),
        ];
        for (i, out) in outs.iter().enumerate() {
            prop_assert!(rel(out, &reference) < 1e-12, "variant {i}: {:e}", rel(out, &reference));
            // exactly symmetric
            prop_assert_eq!((out - out.transpose()).abs().max(), 0.0, "variant {}", i);
        }
    }

    #[test]
    fn short_form_equals_joseph_for_the_optimal_gain(
        a in matrix::<N, N>(),
        H in sparse_h(),
        r in matrix::<M, M>(),
    ) {
        let P = spd(&a, 0.5);
        let R = noise(&r);
        let S = H * P * H.transpose() + R;
        let K = P * H.transpose() * S.try_inverse().unwrap();
        let joseph = update_on::<StaticCov>(&P, &K, &H, &R, UpdateForm::Joseph);
        for out in [
            update_on::<StaticCov>(&P, &K, &H, &R, UpdateForm::Short),
            update_on::<DynamicCov>(&P, &K, &H, &R, UpdateForm::Short),
            update_on::<FaerCov>(&P, &K, &H, &R, UpdateForm::Short),
        ] {
            prop_assert!(rel(&out, &joseph) < 1e-10, "{:e}", rel(&out, &joseph));
        }
    }

    #[test]
    fn gain_by_column_substitution_equals_cholesky_solve(u in matrix::<N, M>(), r in matrix::<M, M>()) {
        let S = noise(&r);
        let chol = S.cholesky().unwrap();
        let reference = chol.solve(&u.transpose()).transpose();
        let mut K = u;
        right_solve_cholesky(chol.l_dirty(), &mut K);
        let scale = reference.abs().max().max(1.0);
        prop_assert!((K - reference).abs().max() <= 1e-12 * scale);
        // and K S = U
        prop_assert!((K * S - u).abs().max() <= 1e-12 * scale * S.abs().max());
    }

    #[test]
    fn dense_sandwich_kernel_equals_nalgebra(f in matrix::<N, N>(), a in matrix::<N, N>(), b in matrix::<N, N>()) {
        let (P, Q) = (spd(&a, 0.5), spd(&b, 0.1));
        let reference = f * P * f.transpose() + Q;
        let mut out = MatN::zeros();
        dense_sandwich(&f, &P, &Q, &mut out);
        prop_assert!(rel(&out, &reference) < 1e-13, "{:e}", rel(&out, &reference));
        // exact symmetry is the kernel's contract (lower triangle mirrored)
        prop_assert_eq!((out - out.transpose()).abs().max(), 0.0);
    }

    /// The dispatched kernels (AVX2/FMA on this machine when the CPU has them, the
    /// Joseph update with AVX-512VL when it has that too) and the portable ones agree to
    /// rounding; the Joseph update's two fused paths run the same multiply-adds.
    #[test]
    fn fma_and_portable_paths_agree(
        a in matrix::<N, N>(),
        f in matrix::<N, N>(),
        K in matrix::<N, M>(),
        H in sparse_h(),
        r in matrix::<M, M>(),
    ) {
        use crate::kernels;
        let P = spd(&a, 0.5);
        let S = noise(&r);
        let U = P * H.transpose();
        let (mut x, mut y) = (MatN::zeros(), MatN::zeros());
        kernels::joseph_update(&P, &K, &S, &U, &mut x);
        kernels::joseph_update_portable(&P, &K, &S, &U, &mut y);
        prop_assert!(rel(&x, &y) < 1e-13, "joseph {:e}", rel(&x, &y));
        kernels::joseph_update_avx2(&P, &K, &S, &U, &mut y);
        prop_assert!(rel(&x, &y) <= 1e-15, "joseph avx2 path {:e}", rel(&x, &y));
        kernels::dense_sandwich(&f, &P, &P, &mut x);
        kernels::dense_sandwich_portable(&f, &P, &P, &mut y);
        prop_assert!(rel(&x, &y) < 1e-13, "sandwich {:e}", rel(&x, &y));
        let l = S.cholesky().unwrap().l();
        let (mut k1, mut k2) = (U, U);
        kernels::right_solve_cholesky(&l, &mut k1);
        kernels::right_solve_cholesky_portable(&l, &mut k2);
        prop_assert!((k1 - k2).abs().max() <= 1e-13 * k2.abs().max());
        let (mut u1, mut u2) = (SMatrix::<f64, N, M>::zeros(), SMatrix::<f64, N, M>::zeros());
        kernels::p_times_ht(&P, &H, u1.as_mut_slice());
        kernels::p_times_ht_portable(&P, &H, u2.as_mut_slice());
        prop_assert!((u1 - u2).abs().max() <= 1e-13 * u2.abs().max().max(1.0));
        let (mut s1, mut s2) = (SMatrix::<f64, M, M>::zeros(), SMatrix::<f64, M, M>::zeros());
        kernels::mat_mul(&H, &u1, &mut s1);
        kernels::mat_mul_portable(&H, &u1, &mut s2);
        prop_assert!((s1 - s2).abs().max() <= 1e-13 * s2.abs().max().max(1.0));
    }

    #[test]
    fn p_times_ht_skipping_zeros_equals_dense(a in matrix::<N, N>(), H in sparse_h()) {
        let P = spd(&a, 0.5);
        let dense = P * H.transpose();
        let scale = dense.abs().max().max(1.0);
        let s = StaticCov.p_times_ht(&H, &P);
        let d = DynamicCov::default().p_times_ht(&H, &<DynamicCov as CovBackend<Const<N>>>::from_static(&P));
        let f = FaerCov::default().p_times_ht(&H, &<FaerCov as CovBackend<Const<N>>>::from_static(&P));
        for (name, x) in [("static", s), ("dynamic", d), ("faer", f)] {
            prop_assert!((x - dense).abs().max() <= 1e-14 * scale, "{name}");
        }
    }

    /// `G` = identity with one or two random blocks (1 to 8 dimensions, disjoint): the
    /// blocks applied one after the other on each back-end equal `G P Gᵀ` (blocks of up
    /// to 6 dimensions and larger ones take different code).
    #[test]
    fn block_reset_equals_dense_sandwich(
        a in matrix::<N, N>(),
        first in (0usize..N, 1usize..9, matrix::<8, 8>()),
        second in proptest::option::of((1usize..5, matrix::<4, 4>())),
    ) {
        let P = spd(&a, 0.5);
        let mut blocks = Vec::new();
        let (o, d, m) = first;
        let d = d.min(N - o);
        blocks.push((o, SMatrix::<f64, 8, 8>::identity().view((0, 0), (d, d)) + m.view((0, 0), (d, d)) * 0.1));
        if let Some((d2, m2)) = second {
            let o2 = o + d;
            if o2 + d2 <= N {
                blocks.push((o2, m2.view((0, 0), (d2, d2)).into_owned()));
            }
        }
        let mut G = MatN::identity();
        for (o, b) in &blocks {
            G.view_mut((*o, *o), b.shape()).copy_from(b);
        }
        let dense = G * P * G.transpose();
        prop_assert!(rel(&reset_on::<StaticCov>(&P, &blocks), &dense) < 1e-13, "static");
        prop_assert!(rel(&reset_on::<DynamicCov>(&P, &blocks), &dense) < 1e-13, "dynamic");
        prop_assert!(rel(&reset_on::<FaerCov>(&P, &blocks), &dense) < 1e-13, "faer");
        // the kernel's path without AVX2/FMA (the back-ends above take the fused one on
        // CPUs that have it)
        let mut p = P;
        let (mut corner, mut row) = ([0.0; 64], [0.0; 8]);
        for (o, b) in &blocks {
            crate::kernels::block_reset_portable(&mut p, N, *o, b.as_view(), &mut corner, &mut row);
        }
        prop_assert!(rel(&p, &dense) < 1e-13, "portable");
        prop_assert_eq!((p - p.transpose()).abs().max(), 0.0);
    }
}

/// The reset on back-end `B`, block by block; asserts exact symmetry.
fn reset_on<B: CovBackend<Const<N>>>(P: &MatN, blocks: &[(usize, nalgebra::DMatrix<f64>)]) -> MatN {
    let mut backend = B::default();
    let mut p = B::from_static(P);
    for (o, b) in blocks {
        backend.reset_block(&mut p, *o, b.as_view());
    }
    let out = B::as_static(&p).into_owned();
    assert_eq!((out - out.transpose()).abs().max(), 0.0, "{} reset not exactly symmetric", B::NAME);
    out
}

/// One block spanning the whole state (what a custom manifold without its own
/// `reset_blocks` reports), at 40 dimensions: the static back-end's heap scratch path.
#[test]
fn whole_state_block_reset_equals_dense_sandwich() {
    const D: usize = 40;
    let a = SMatrix::<f64, D, D>::from_fn(|i, j| (((i * 7 + j * 3) % 11) as f64 - 5.0) * 0.1);
    let P = a * a.transpose() + SMatrix::<f64, D, D>::identity();
    let G = SMatrix::<f64, D, D>::identity()
        + SMatrix::<f64, D, D>::from_fn(|i, j| (((i * 5 + j) % 7) as f64 - 3.0) * 1e-2);
    let dense = G * P * G.transpose();
    let mut p = P;
    <StaticCov as CovBackend<Const<D>>>::reset_block(&mut StaticCov, &mut p, 0, G.as_view());
    assert!((p - dense).abs().max() / dense.abs().max() < 1e-14);
    assert_eq!((p - p.transpose()).abs().max(), 0.0);
    let mut backend = FaerCov::default();
    let mut q = <FaerCov as CovBackend<Const<D>>>::from_static(&P);
    <FaerCov as CovBackend<Const<D>>>::reset_block(&mut backend, &mut q, 0, G.as_view());
    let q = <FaerCov as CovBackend<Const<D>>>::as_static(&q).into_owned();
    assert!((q - dense).abs().max() / dense.abs().max() < 1e-14);
}

/// A hard case for the multiplied-out form: measurements up to twelve orders of magnitude
/// more precise than the prior (`P₀ = 1e4 I`, `R` from `1e-2` down to `1e-8`), 200
/// cycles with an unobserved, growing direction. Both Joseph variants keep `P` positive
/// definite (every Cholesky of `S` succeeds, and `P`'s own at the end) and agree to
/// 1e-12 relative over the whole matrix (measured: ≤ 6e-15). Quantities in the measured
/// subspace, such as `H P Hᵀ ≈ R`, are sums of entries of order `‖P‖` and carry a
/// cancellation error of order `ε‖P‖` whichever form produced `P`, so they are not
/// compared (they differ by 5e-6 relative at `R = 1e-2` and 7e-2 at `R = 1e-8`).
#[test]
fn joseph_variants_stay_positive_definite_with_very_precise_measurements() {
    use crate::linear::{LinearMeasurement, LinearProcess};
    use crate::{ErrorStateFilter, FixedNoise};
    use nalgebra::{SVector, Vector2};

    const S: usize = 6;
    let F = SMatrix::<f64, S, S>::from_fn(|i, j| {
        if i == j {
            1.0
        } else if j == i + 3 {
            0.1
        } else {
            0.0
        }
    });
    let process = LinearProcess { F, Q: SMatrix::<f64, S, S>::identity() * 1e-6 };
    let H = SMatrix::<f64, 2, S>::from_fn(|i, j| if j == i || j == i + 1 { 1.0 } else { 0.0 });
    let sensor = LinearMeasurement::new(H);
    let P0 = SMatrix::<f64, S, S>::identity() * 1e4;
    for r in [1e-2, 1e-4, 1e-6, 1e-8] {
        let R = SMatrix::<f64, 2, 2>::identity() * r;
        let run = |form: UpdateForm| {
            let mut f = ErrorStateFilter::new(SVector::<f64, S>::zeros(), P0, FixedNoise)
                .unwrap()
                .with_update_form(form);
            for k in 0..200 {
                f.predict(&process, &(), 0.1).unwrap();
                let z = Vector2::new((k as f64 * 0.3).sin(), (k as f64 * 0.2).cos());
                f.update(&sensor, &z, &R).unwrap();
            }
            *f.covariance()
        };
        let (expanded, factored) = (run(UpdateForm::Joseph), run(UpdateForm::JosephFactored));
        for (name, p) in [("Joseph", &expanded), ("JosephFactored", &factored)] {
            assert!(p.cholesky().is_some(), "R = {r:e}, {name}: P not positive definite");
        }
        let whole = (expanded - factored).abs().max() / factored.abs().max();
        assert!(whole < 1e-12, "R = {r:e}: P differs by {whole:e} (relative)");
    }
}
