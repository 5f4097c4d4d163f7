//! The fixed-interval smoother against an independent path: on a linear-Gaussian problem
//! the smoothed means and covariances are the batch weighted-least-squares solution of the
//! whole interval (normal equations of all states at once), to 1e-9, on every covariance
//! back-end; and under random problems the smoothed covariances stay symmetric positive
//! definite and never above the filtered ones.

#![allow(non_snake_case)]

use estimator_core::linear::{LinearMeasurement, LinearProcess};
use estimator_core::{CovBackend, DynamicCov, ErrorStateFilter, FixedNoise, RtsSmoother, Smoothed};
use nalgebra::{DMatrix, DVector, Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};
use proptest::prelude::*;

struct Problem {
    F: Matrix2<f64>,
    Q: Matrix2<f64>,
    H: Matrix1x2<f64>,
    R: Matrix1<f64>,
    m0: Vector2<f64>,
    P0: Matrix2<f64>,
    /// `z[k]`: the measurement after prediction `k + 1`, when there is one.
    z: Vec<Option<f64>>,
    dt: f64,
}

fn problem(q: f64, r: f64, n: usize, seed: u64) -> Problem {
    let dt = 0.5;
    let mut z = Vec::with_capacity(n);
    for k in 0..n {
        // a deterministic but irregular signal; every fifth step without a measurement
        let t = (k + 1) as f64 * dt;
        let v = 0.3 * t + (t * 0.7 + seed as f64).sin() * 2.0;
        z.push((k % 5 != 3).then_some(v));
    }
    Problem {
        F: Matrix2::new(1.0, dt, 0.0, 1.0),
        Q: Matrix2::new(dt.powi(3) / 3.0, dt * dt / 2.0, dt * dt / 2.0, dt) * q,
        H: Matrix1x2::new(1.0, 0.0),
        R: Matrix1::new(r),
        m0: Vector2::new(0.5, -0.2),
        P0: Matrix2::new(4.0, 0.5, 0.5, 1.0),
        z,
        dt,
    }
}

fn run<B: CovBackend<nalgebra::U2>>(
    p: &Problem,
    backend: B,
) -> (Vec<Smoothed<Vector2<f64>>>, Vec<Matrix2<f64>>) {
    let mut f = ErrorStateFilter::with_backend(p.m0, p.P0, FixedNoise, backend).unwrap();
    let mut s = RtsSmoother::new();
    let process = LinearProcess { F: p.F, Q: p.Q };
    let sensor = LinearMeasurement::new(p.H);
    let mut filtered = vec![p.P0];
    for z in &p.z {
        s.predict(&mut f, &process, &(), p.dt).unwrap();
        if let Some(z) = z {
            f.update(&sensor, &Vector1::new(*z), &p.R).unwrap();
        }
        filtered.push(f.covariance().into_owned());
    }
    (s.smooth(&f).unwrap(), filtered)
}

/// Minimise over all states x_0..x_n at once:
/// (x_0 − m_0)ᵀ P_0⁻¹ (…) + Σ (x_{k+1} − F x_k)ᵀ Q⁻¹ (…) + Σ (z_k − H x_k)ᵀ R⁻¹ (…).
/// The solution of the normal equations is the mean, the inverse of their matrix the
/// joint covariance.
fn batch(p: &Problem) -> (Vec<Vector2<f64>>, Vec<Matrix2<f64>>) {
    let n = p.z.len() + 1;
    let mut A = DMatrix::<f64>::zeros(2 * n, 2 * n);
    let mut b = DVector::<f64>::zeros(2 * n);
    let add = |A: &mut DMatrix<f64>, i: usize, j: usize, m: &Matrix2<f64>| {
        let mut v = A.view_mut((2 * i, 2 * j), (2, 2));
        v += m;
    };
    let p0i = p.P0.try_inverse().unwrap();
    add(&mut A, 0, 0, &p0i);
    b.rows_mut(0, 2).copy_from(&(p0i * p.m0));
    let qi = p.Q.try_inverse().unwrap();
    for k in 0..n - 1 {
        // residual x_{k+1} − F x_k: blocks [−F, I]
        add(&mut A, k, k, &(p.F.transpose() * qi * p.F));
        add(&mut A, k, k + 1, &(-p.F.transpose() * qi));
        add(&mut A, k + 1, k, &(-qi * p.F));
        add(&mut A, k + 1, k + 1, &qi);
        if let Some(z) = p.z[k] {
            let ri = 1.0 / p.R[0];
            let ht = p.H.transpose();
            add(&mut A, k + 1, k + 1, &(ht * p.H * ri));
            let mut rows = b.rows_mut(2 * (k + 1), 2);
            rows += ht * (z * ri);
        }
    }
    let cov = A.clone().try_inverse().unwrap();
    let mean = cov.clone() * b;
    let means = (0..n).map(|k| Vector2::new(mean[2 * k], mean[2 * k + 1])).collect();
    let covs = (0..n).map(|k| Matrix2::from_fn(|i, j| cov[(2 * k + i, 2 * k + j)])).collect();
    (means, covs)
}

fn close(a: f64, b: f64, scale: f64) -> bool {
    (a - b).abs() <= 1e-9 * scale.max(1.0)
}

#[test]
fn smoothed_estimates_are_the_batch_least_squares_solution_on_every_backend() {
    let p = problem(0.05, 0.4, 60, 1);
    let (means, covs) = batch(&p);
    let check = |name: &str, smoothed: &[Smoothed<Vector2<f64>>]| {
        assert_eq!(smoothed.len(), means.len());
        for (k, s) in smoothed.iter().enumerate() {
            let scale = means[k].abs().max();
            for i in 0..2 {
                assert!(
                    close(s.x[i], means[k][i], scale),
                    "{name}: x[{k}] {} vs {}",
                    s.x,
                    means[k]
                );
                for j in 0..2 {
                    let c = covs[k].abs().max();
                    assert!(
                        close(s.p[(i, j)], covs[k][(i, j)], c),
                        "{name}: P[{k}] {} vs {}",
                        s.p,
                        covs[k]
                    );
                }
            }
            assert!((s.time - k as f64 * p.dt).abs() < 1e-12, "{name}: time {}", s.time);
        }
    };
    check("static", &run(&p, estimator_core::StaticCov).0);
    check("dynamic", &run(&p, DynamicCov::default()).0);
    // (the faer back-end is opt-in; `cargo test --workspace` enables it)
    #[cfg(feature = "faer")]
    check("faer", &run(&p, estimator_core::FaerCov::default()).0);
    // the smoother is not the filter: the estimates differ where later data tells more
    let (smoothed, filtered) = run(&p, estimator_core::StaticCov);
    assert!(smoothed[10].p[(0, 0)] < 0.9 * filtered[10][(0, 0)]);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn smoothed_covariances_are_spd_and_below_the_filtered(
        q in 1e-4f64..10.0, r in 1e-3f64..10.0, n in 2usize..40, seed in 0u64..1000
    ) {
        let p = problem(q, r, n, seed);
        let (smoothed, filtered) = run(&p, estimator_core::StaticCov);
        for (s, f) in smoothed.iter().zip(&filtered) {
            prop_assert_eq!(s.p, s.p.transpose());
            let e = s.p.symmetric_eigenvalues();
            prop_assert!(e.min() > 0.0, "not positive definite: {}", s.p);
            // Pˢ ≤ P⁺: the filtered minus the smoothed is positive semi-definite
            let d = (f - s.p).symmetric_eigenvalues();
            prop_assert!(d.min() > -1e-9 * f.abs().max(), "smoothed above filtered: {}", d);
        }
    }
}
