//! Xia's AFKF (`afkf-xia`): the fading factor scales the propagated part `Φ_Σ P Φ_Σᵀ`
//! only and leaves out the process noise added since the previous update
//! (ALGORITHMS.md §2.3). Checked against the recursion written out here, with several
//! predictions per update, and across the covariance back-ends.

#![allow(non_snake_case)]

use std::collections::VecDeque;

use adaptive::Afkf;
use estimator_core::linear::{LinearMeasurement, LinearProcess};
use estimator_core::{DynamicCov, ErrorStateFilter, NoiseStrategy, PriorScaling};
use nalgebra::{Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};

const STEPS_PER_UPDATE: usize = 5;

fn setup() -> (LinearProcess<2>, Matrix1x2<f64>, Matrix1<f64>, Vector2<f64>, Matrix2<f64>) {
    let dt: f64 = 0.1;
    let F = Matrix2::new(1.0, dt, 0.0, 1.0);
    let Q = Matrix2::new(dt.powi(3) / 3.0, dt * dt / 2.0, dt * dt / 2.0, dt) * 0.02;
    (
        LinearProcess { F, Q },
        Matrix1x2::new(1.0, 0.0),
        Matrix1::new(0.25),
        Vector2::new(0.0, 1.0),
        Matrix2::identity(),
    )
}

/// A measurement sequence whose noise jumps ×6 in the middle (so λ > 1 there).
fn z(k: usize) -> Vector1<f64> {
    let t = (k * STEPS_PER_UPDATE) as f64 * 0.1;
    let noise = (k as f64 * 1.37).sin() * if (40..80).contains(&k) { 3.0 } else { 0.5 };
    Vector1::new(t + noise)
}

#[test]
fn xia_factor_scales_the_propagated_part_only() {
    let (process, H, R, x0, P0) = setup();
    let (F, Q) = (process.F, process.Q);
    // Xia's formula as written (the guard would hold λ off on part of this sequence)
    let strategy = Afkf::windowed(10).xia().faithful().with_scaling(PriorScaling::Full);
    assert_eq!(strategy.name(), "afkf-xia-faithful");
    assert!(strategy.tracks_process_noise());
    let mut f = ErrorStateFilter::new(x0, P0, strategy).unwrap();
    let sensor = LinearMeasurement::new(H);

    // Reference: A = Φ_Σ P Φ_Σᵀ and Q_Σ kept apart between updates, P⁻ = A + Q_Σ;
    // λ = clamp(tr(Ĉ − H Q_Σ Hᵀ − R) / tr(H A Hᵀ), 1, 100), P⁻* = λ A + Q_Σ; Joseph update.
    let (mut x, mut A, mut Qs) = (x0, P0, Matrix2::zeros());
    let mut window: VecDeque<f64> = VecDeque::new();
    let mut inflated = 0;
    for k in 0..120 {
        for _ in 0..STEPS_PER_UPDATE {
            x = F * x;
            A = F * A * F.transpose();
            Qs = F * Qs * F.transpose() + Q;
            f.predict(&process, &(), 0.1).unwrap();
        }
        let zk = z(k);
        let y = zk - H * x;
        window.push_back(y[0] * y[0]);
        if window.len() > 10 {
            window.pop_front();
        }
        let c = window.iter().sum::<f64>() / window.len() as f64;
        let hah = (H * A * H.transpose())[0];
        let hqh = (H * Qs * H.transpose())[0];
        let lambda = ((c - hqh - R[0]) / hah).clamp(1.0, 100.0);
        let P = A * lambda + Qs;
        let S = H * P * H.transpose() + R;
        let K = P * H.transpose() / S[0];
        x += K * y;
        let IKH = Matrix2::identity() - K * H;
        A = IKH * P * IKH.transpose() + K * R * K.transpose();
        Qs = Matrix2::zeros();

        let report = f.update(&sensor, &zk, &R).unwrap();
        inflated += usize::from(lambda > 1.0);
        assert!((report.factors.lambda_p - lambda).abs() <= 1e-9 * lambda, "λ at {k}");
        assert!((f.state() - x).abs().max() <= 1e-10 * x.abs().max().max(1.0), "x at {k}");
        assert!((*f.covariance() - A).abs().max() <= 1e-10 * A.abs().max().max(1.0), "P at {k}");
    }
    assert!(inflated >= 10, "the noisy stretch must inflate: {inflated} updates did");

    // The plain AFKF scales Q_Σ too: its covariance differs while it inflates.
    let plain = Afkf::windowed(10).faithful().with_scaling(PriorScaling::Full);
    let mut plain = ErrorStateFilter::new(x0, P0, plain).unwrap();
    let mut xia = ErrorStateFilter::new(
        x0,
        P0,
        Afkf::windowed(10).xia().faithful().with_scaling(PriorScaling::Full),
    )
    .unwrap();
    let mut largest = 0.0f64;
    for k in 0..120 {
        for _ in 0..STEPS_PER_UPDATE {
            plain.predict(&process, &(), 0.1).unwrap();
            xia.predict(&process, &(), 0.1).unwrap();
        }
        plain.update(&sensor, &z(k), &R).unwrap();
        xia.update(&sensor, &z(k), &R).unwrap();
        let (pp, px) = (plain.covariance().into_owned(), xia.covariance().into_owned());
        largest = largest.max((pp - px).abs().max() / px.abs().max());
    }
    assert!(largest > 1e-3, "relative difference {largest}");
}

#[test]
fn xia_subspace_scaling_agrees_across_backends() {
    let (process, H, R, x0, P0) = setup();
    let sensor = LinearMeasurement::new(H);
    let mut a = ErrorStateFilter::new(x0, P0, Afkf::windowed(10).xia()).unwrap();
    let mut b =
        ErrorStateFilter::with_backend(x0, P0, Afkf::windowed(10).xia(), DynamicCov::default())
            .unwrap();
    for k in 0..120 {
        for _ in 0..STEPS_PER_UPDATE {
            a.predict(&process, &(), 0.1).unwrap();
            b.predict(&process, &(), 0.1).unwrap();
        }
        let ra = a.update(&sensor, &z(k), &R).unwrap();
        let rb = b.update(&sensor, &z(k), &R).unwrap();
        assert!((ra.factors.lambda_p - rb.factors.lambda_p).abs() <= 1e-9 * ra.factors.lambda_p);
        let (pa, pb) = (a.covariance().into_owned(), b.covariance().into_owned());
        assert!((pa - pb).abs().max() <= 1e-10 * pa.abs().max(), "P at {k}");
        assert!(pa.symmetric_eigenvalues().min() > 0.0, "P positive definite at {k}");
    }
}
