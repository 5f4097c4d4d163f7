//! Which reset handling is right for a smoother on a manifold state, decided against an
//! independent reference: the batch Gauss–Newton MAP of the whole trajectory on
//! SO(3) × R³ (attitude and gyro bias) and its Laplace covariance, at decreasing noise,
//! and the NEES of the smoothed estimates over 200 Monte Carlo runs drawn from the
//! models' own noise. Both library smoothers (`RtsSmoother`, `SegmentSmoother`) are
//! compared with the reference and with each other.
//!
//! The backward recursion combines the smoothed error at `k + 1` with the forward
//! records at `k`, which are expressed in the frames of the forward nominals: `P⁺_k` at
//! `x̂⁺_k`, `Φ_k` from `x̂⁺_k` to `x̂⁻_{k+1}`, `P⁻_{k+1}` at `x̂⁻_{k+1}`. The smoothed
//! covariance at `k + 1` is carried at `x̂ˢ_{k+1}`, so it must be taken into the frame of
//! `x̂⁻_{k+1}` (by `G(x̂⁻_{k+1}, d)⁻¹`, `d = x̂ˢ_{k+1} ⊖ x̂⁻_{k+1}`) before it meets
//! `P⁻_{k+1}`, and the result, formed at `x̂⁺_k`, is taken to `x̂ˢ_k` by
//! `G(x̂⁺_k, δ_k)`. The test's own `in_out` recursion does both.

#![allow(non_snake_case)]

use std::io::Cursor;

use estimator_core::{
    ErrorStateFilter, FixedNoise, Manifold, MeasurementJacobians, MeasurementModel,
    ProcessJacobians, ProcessModel, RtsSmoother, RtsStep, SegmentSmoother, SmoothedRow,
    StepRecorder, Tangent,
};
use manifolds::numdiff::jacobian;
use manifolds::{composite_state, hat, right_jacobian, So3, R3};
use nalgebra::{DMatrix, DVector, Matrix3, Matrix6, SMatrix, SVector, Vector3, Vector6, U6};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;

composite_state! {
    /// Attitude and gyro bias.
    pub struct AttBias {
        /// Body to world.
        pub att: So3 => ATT,
        /// Gyro bias, rad/s.
        pub bias: R3 => BIAS,
    }
}

/// Gyro integration: `R ← R Exp((ω − b) dt)`, `b` a random walk.
struct Gyro {
    /// Angle random walk, rad/√s.
    arw: f64,
    /// Bias random walk, rad/s/√s.
    brw: f64,
}

impl ProcessModel for Gyro {
    type State = AttBias;
    type Input = Vector3<f64>;
    fn propagate(&self, x: &AttBias, w: &Vector3<f64>, dt: f64) -> AttBias {
        AttBias { att: x.att.oplus(&((w - x.bias) * dt)), bias: x.bias }
    }
    fn jacobians(&self, x: &AttBias, w: &Vector3<f64>, dt: f64) -> ProcessJacobians<U6> {
        let th = (w - x.bias) * dt;
        let mut Phi = Matrix6::identity();
        Phi.fixed_view_mut::<3, 3>(0, 0).copy_from(&So3::exp(&th).matrix().transpose());
        Phi.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-right_jacobian(&th) * dt));
        let mut Q = Matrix6::zeros();
        Q.fixed_view_mut::<3, 3>(0, 0).fill_diagonal(self.arw * self.arw * dt);
        Q.fixed_view_mut::<3, 3>(3, 3).fill_diagonal(self.brw * self.brw * dt);
        ProcessJacobians { Phi, Q }
    }
}

/// Reference directions seen in the body frame, `z = Rᵀ v` (gravity alone, or gravity and
/// a magnetic field).
struct Directions<const M: usize> {
    refs: [Vector3<f64>; 2],
}

impl<const M: usize> MeasurementModel for Directions<M>
where
    nalgebra::Const<M>: nalgebra::DimName,
{
    type State = AttBias;
    type Measurement = SVector<f64, M>;
    fn predict(&self, x: &AttBias) -> SVector<f64, M> {
        let mut z = SVector::<f64, M>::zeros();
        for (i, v) in self.refs.iter().take(M / 3).enumerate() {
            z.fixed_rows_mut::<3>(3 * i).copy_from(&x.att.inverse().rotate(v));
        }
        z
    }
    fn jacobian(&self, x: &AttBias) -> MeasurementJacobians<nalgebra::Const<M>, U6> {
        let mut H = SMatrix::<f64, M, 6>::zeros();
        for (i, v) in self.refs.iter().take(M / 3).enumerate() {
            H.fixed_view_mut::<3, 3>(3 * i, 0).copy_from(&hat(&x.att.inverse().rotate(v)));
        }
        MeasurementJacobians { H }
    }
}

/// One simulated run: inputs, measurements (gravity every step, the magnetic field only
/// in the first and last tenth), the truth.
struct Run {
    x0: AttBias,
    P0: Matrix6<f64>,
    w: Vec<Vector3<f64>>,
    /// `(k, z)`: measurement after prediction `k`; 3-D (gravity) or 6-D (both).
    z3: Vec<Option<SVector<f64, 3>>>,
    z6: Vec<Option<SVector<f64, 6>>>,
    truth: Vec<AttBias>,
    model: Gyro,
    r: f64,
    dt: f64,
}

const STEPS: usize = 120;
const REFS: [Vector3<f64>; 2] = [Vector3::new(0.0, 0.0, 9.81), Vector3::new(0.3, 0.1, 0.45)];

/// A run at noise scale `s` (every σ times `s`) from `seed`.
fn simulate(s: f64, seed: u64) -> Run {
    let sig0 = [0.05 * s, 0.05 * s, 0.6 * s, 0.02 * s, 0.02 * s, 0.02 * s];
    simulate_with(sig0, Gyro { arw: 0.05 * s, brw: 0.005 * s }, 0.02 * s, seed)
}

/// A run with initial σ `sig0` (attitude, bias), the gyro model and the measurement σ.
fn simulate_with(sig0: [f64; 6], model: Gyro, r: f64, seed: u64) -> Run {
    let mut rng = StdRng::seed_from_u64(seed);
    let mut n3 = || Vector3::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal));
    let dt = 0.1;
    let P0 = Matrix6::from_diagonal(&Vector6::from_fn(|i, _| sig0[i] * sig0[i]));
    let x0 =
        AttBias { att: So3::from_euler(0.1, -0.2, 1.0), bias: Vector3::new(0.01, -0.02, 0.005) };
    let e0 = Vector6::from_fn(|i, _| sig0[i]).component_mul(&{
        let (a, b) = (n3(), n3());
        Vector6::new(a[0], a[1], a[2], b[0], b[1], b[2])
    });
    let mut truth = vec![x0.oplus(&e0)];
    let (mut w, mut z3, mut z6) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..STEPS {
        let t = k as f64 * dt;
        let rate = Vector3::new(0.3 * (0.5 * t).sin(), 0.2 * (0.3 * t).cos(), 0.4);
        let x = truth.last().unwrap();
        let noisy = rate - n3() * (model.arw / dt.sqrt());
        let mut next = model.propagate(x, &noisy, dt);
        next.bias += n3() * (model.brw * dt.sqrt());
        truth.push(next);
        w.push(rate);
        let x = truth.last().unwrap();
        let both = !(STEPS / 10..STEPS - STEPS / 10).contains(&k);
        if both {
            let z = Directions::<6> { refs: REFS }.predict(x);
            let (a, b) = (n3(), n3());
            z6.push(Some(z + Vector6::new(a[0], a[1], a[2], b[0], b[1], b[2]) * r));
            z3.push(None);
        } else {
            z3.push(Some(Directions::<3> { refs: REFS }.predict(x) + n3() * r));
            z6.push(None);
        }
    }
    Run { x0, P0, w, z3, z6, truth, model, r, dt }
}

type Filter = ErrorStateFilter<AttBias, FixedNoise>;

/// Smoothed means and covariances, in time order.
type Estimates = Vec<(AttBias, Matrix6<f64>)>;

/// The forward pass feeding both library smoothers; the RTS records, the smoothed
/// estimates of both, and the final filter.
fn forward(run: &Run) -> (RtsSmoother<AttBias>, Estimates, Vec<SmoothedRow<AttBias>>) {
    let mut f: Filter = ErrorStateFilter::new(run.x0.clone(), run.P0, FixedNoise).unwrap();
    let mut rts = RtsSmoother::new();
    let mut seg = SegmentSmoother::new(Cursor::new(Vec::new()), 7);
    let (r3, r6) = (
        SMatrix::<f64, 3, 3>::identity() * run.r * run.r,
        SMatrix::<f64, 6, 6>::identity() * run.r * run.r,
    );
    for k in 0..STEPS {
        seg.before_predict(&f, &run.w[k], run.dt, true);
        rts.predict(&mut f, &run.model, &run.w[k], run.dt).unwrap();
        seg.before_update(&f);
        if let Some(z) = &run.z3[k] {
            f.update(&Directions::<3> { refs: REFS }, z, &r3).unwrap();
        }
        if let Some(z) = &run.z6[k] {
            f.update(&Directions::<6> { refs: REFS }, z, &r6).unwrap();
        }
        // the variances at every other step (each asks its segment to end there)
        if k % 2 == 1 {
            seg.mark_variances();
        }
    }
    let smoothed = rts.smooth(&f).unwrap().into_iter().map(|s| (s.x, s.p)).collect::<Vec<_>>();
    let mut rows = Vec::new();
    seg.smooth(&f, &run.model, |r| {
        rows.splice(0..0, r.iter().cloned());
        Ok(())
    })
    .unwrap();
    (rts, smoothed, rows)
}

/// Which transports of the smoothed covariance a backward recursion makes.
#[derive(Clone, Copy, Debug)]
enum Transport {
    /// Into the prior's frame and out to the smoothed estimate's (derived above).
    InOut,
    /// Out only (the reset of the forward filter's update, applied at every step).
    Out,
    /// None (every covariance taken as if at the forward nominal).
    Neither,
}

/// The RTS recursion over the records with the given transports.
fn backward(
    steps: &[RtsStep<AttBias>],
    last: &(AttBias, Matrix6<f64>),
    t: Transport,
) -> Vec<(AttBias, Matrix6<f64>)> {
    let (mut x, mut p) = last.clone();
    let mut out = vec![(x.clone(), p)];
    for s in steps.iter().rev() {
        let d = x.ominus(&s.x_prior);
        if let Transport::InOut = t {
            let g = s.x_prior.oplus_jacobians(&d).J_y_delta.try_inverse().unwrap();
            p = g * p * g.transpose();
        }
        let c = s.p_prior.cholesky().unwrap().solve(&(s.phi * s.p_post)).transpose();
        let delta = c * d;
        let x_s = s.x_post.oplus(&delta);
        let mut p_s = s.p_post + c * (p - s.p_prior) * c.transpose();
        if !matches!(t, Transport::Neither) {
            let g = s.x_post.oplus_jacobians(&delta).J_y_delta;
            p_s = g * p_s * g.transpose();
        }
        x = x_s;
        p = (p_s + p_s.transpose()) * 0.5;
        out.push((x.clone(), p));
    }
    out.reverse();
    out
}

/// The batch MAP of the whole trajectory by Gauss–Newton on the manifold (numerical
/// Jacobians through ⊕/⊖), started from `init`, and its Laplace covariance blocks (the
/// inverse of the Gauss–Newton information, at the MAP, in each estimate's own frame).
fn batch_map(run: &Run, init: &[AttBias]) -> Vec<(AttBias, Matrix6<f64>)> {
    let n = init.len();
    let dim = 6 * n;
    let mut xs = init.to_vec();
    let h = 1e-6;
    let r_inv = 1.0 / (run.r * run.r);
    let p0_inv = run.P0.try_inverse().unwrap();
    let mut info = DMatrix::<f64>::zeros(dim, dim);
    for iter in 0..30 {
        info.fill(0.0);
        let mut grad = DVector::<f64>::zeros(dim);
        // prior
        let r0 = xs[0].ominus(&run.x0);
        let j0 = jacobian(&xs[0], |x| x.ominus(&run.x0), h);
        add_block(&mut info, &mut grad, &[(0, j0)], &r0, &p0_inv);
        for k in 0..n - 1 {
            let jac = run.model.jacobians(&xs[k], &run.w[k], run.dt);
            let q_inv = jac.Q.try_inverse().unwrap();
            let pred = |x: &AttBias| run.model.propagate(x, &run.w[k], run.dt);
            let r = xs[k + 1].ominus(&pred(&xs[k]));
            let next = xs[k + 1].clone();
            let ja = jacobian(&xs[k], |x| next.ominus(&pred(x)), h);
            let p = pred(&xs[k]);
            let jb = jacobian(&xs[k + 1], |x| x.ominus(&p), h);
            add_block(&mut info, &mut grad, &[(k, ja), (k + 1, jb)], &r, &q_inv);
            if let Some(z) = &run.z3[k] {
                let m = Directions::<3> { refs: REFS };
                let r = z - m.predict(&xs[k + 1]);
                let j = jacobian(&xs[k + 1], |x| z - m.predict(x), h);
                add_block(&mut info, &mut grad, &[(k + 1, j)], &r, &(Matrix3::identity() * r_inv));
            }
            if let Some(z) = &run.z6[k] {
                let m = Directions::<6> { refs: REFS };
                let r = z - m.predict(&xs[k + 1]);
                let j = jacobian(&xs[k + 1], |x| z - m.predict(x), h);
                add_block(&mut info, &mut grad, &[(k + 1, j)], &r, &(Matrix6::identity() * r_inv));
            }
        }
        let step = info.clone().cholesky().unwrap().solve(&(-&grad));
        for (k, x) in xs.iter_mut().enumerate() {
            *x =
                x.oplus(&Tangent::<AttBias>::from_column_slice(&step.as_slice()[6 * k..6 * k + 6]));
        }
        if step.amax() < 1e-13 && iter > 2 {
            break;
        }
    }
    let cov = info.cholesky().unwrap().inverse();
    xs.into_iter()
        .enumerate()
        .map(|(k, x)| (x, Matrix6::from_fn(|r, c| cov[(6 * k + r, 6 * k + c)])))
        .collect()
}

/// Add a residual `r` with information `w` and Jacobian blocks `(state, J)` to the normal
/// equations (`info += JᵀWJ`, `grad += JᵀWr`).
fn add_block<const M: usize>(
    info: &mut DMatrix<f64>,
    grad: &mut DVector<f64>,
    blocks: &[(usize, SMatrix<f64, M, 6>)],
    r: &SVector<f64, M>,
    w: &SMatrix<f64, M, M>,
) {
    for (a, ja) in blocks {
        let g = ja.transpose() * w * r;
        for i in 0..6 {
            grad[6 * a + i] += g[i];
        }
        for (b, jb) in blocks {
            let m = ja.transpose() * w * jb;
            for i in 0..6 {
                for j in 0..6 {
                    info[(6 * a + i, 6 * b + j)] += m[(i, j)];
                }
            }
        }
    }
}

/// Largest difference of means (tangent, rad) and largest relative difference of
/// standard deviations between two smoothed trajectories.
fn worst(a: &[(AttBias, Matrix6<f64>)], b: &[(AttBias, Matrix6<f64>)]) -> (f64, f64) {
    let mut out = (0.0f64, 0.0f64);
    for ((xa, pa), (xb, pb)) in a.iter().zip(b) {
        out.0 = out.0.max(xa.ominus(xb).amax());
        for i in 0..6 {
            out.1 = out.1.max((pa[(i, i)].sqrt() / pb[(i, i)].sqrt() - 1.0).abs());
        }
    }
    out
}

fn rows_as_pairs(
    rows: &[SmoothedRow<AttBias>],
    first: &(AttBias, Matrix6<f64>),
) -> Vec<(AttBias, Option<Matrix6<f64>>)> {
    std::iter::once((first.0.clone(), Some(first.1)))
        .chain(rows.iter().map(|r| (r.x.clone(), r.var.as_ref().map(Matrix6::from_diagonal))))
        .collect()
}

/// The library's two smoothers on one run: the step-by-step one and the segment one
/// (every step an output, the variances at every other step), which must
/// agree to `tol` (means in rad, variances relative).
fn library(run: &Run, tol: f64) -> (RtsSmoother<AttBias>, Vec<(AttBias, Matrix6<f64>)>) {
    let (rts, lib_rts, rows) = forward(run);
    let seg = rows_as_pairs(&rows, &lib_rts[0]);
    assert_eq!(seg.len(), lib_rts.len());
    let (mut dm, mut dv, mut compared) = (0.0f64, 0.0f64, 0);
    for (k, ((xa, pa), (xb, pb))) in lib_rts[1..].iter().zip(&seg[1..]).enumerate() {
        dm = dm.max(xa.ominus(xb).amax());
        assert_eq!(pb.is_some(), k % 2 == 1, "variances at step {k}");
        if let Some(pb) = pb {
            compared += 1;
            for i in 0..6 {
                dv = dv.max((pa[(i, i)] / pb[(i, i)] - 1.0).abs());
            }
        }
    }
    assert!(compared > 10);
    println!("RtsSmoother against SegmentSmoother: means {dm:.1e} rad, variances {dv:.1e}");
    assert!(
        dm < tol && dv < tol,
        "RtsSmoother against SegmentSmoother: means {dm:e}, variances {dv:e}"
    );
    (rts, lib_rts)
}

/// Without process noise the trajectory is a deterministic function of its final state,
/// so the smoothed estimate at `k` is the final posterior carried back through the
/// dynamics: `x̂ˢ_k = F⁻¹(x̂_T)`, `Pˢ_k = J P_T Jᵀ` with `J` the Jacobian of the backward
/// flow through ⊕/⊖ (numerical). The attitude starts 0.3–0.5 rad uncertain and ends known
/// to 3e-4, so the smoothing corrections are large while the final σ is small: the
/// reference is exact to first order in the final σ, whatever the corrections. Returns
/// the worst mean (rad) and relative σ differences of the library and of the three
/// recursions.
fn against_pushforward(bias_sigma: f64) -> [(f64, f64); 4] {
    let b = bias_sigma;
    let run = simulate_with([0.3, 0.3, 0.5, b, b, b], Gyro { arw: 0.0, brw: 0.0 }, 1e-3, 11);
    let (rts, lib_rts) = library(&run, 1e-7);
    let last = lib_rts.last().unwrap().clone();
    let back = |x: &AttBias, k: usize| {
        let mut x = x.clone();
        for j in (k..STEPS).rev() {
            x.att = x.att.oplus(&(-(run.w[j] - x.bias) * run.dt));
        }
        x
    };
    let reference: Vec<_> = (0..=STEPS)
        .map(|k| {
            let mean = back(&last.0, k);
            let J = manifolds::numdiff::jacobian_between(&last.0, |x| back(x, k), 1e-6);
            (mean, J * last.1 * J.transpose())
        })
        .collect();
    let correction = lib_rts[0].0.ominus(&rts.steps()[0].x_post).amax();
    assert!(correction > 0.2, "the test needs large smoothing corrections: {correction}");
    let mut out = [worst(&lib_rts, &reference); 4];
    for (i, t) in [Transport::InOut, Transport::Out, Transport::Neither].into_iter().enumerate() {
        out[i + 1] = worst(&backward(rts.steps(), &last, t), &reference);
    }
    println!("bias σ {b:e}, largest correction {correction:.3} rad");
    for (name, (m, v)) in ["library", "in+out", "out only", "neither"].iter().zip(out) {
        println!("  {name:9} mean {m:.2e} rad, σ {v:.2e} relative");
    }
    out
}

#[test]
fn both_smoothers_carry_the_final_posterior_back_exactly_without_process_noise() {
    // bias known: the dynamics are exactly linear in the error; only the frames matter
    let [lib, in_out, out_only, neither] = against_pushforward(1e-7);
    assert!(lib.0 < 1e-7 && lib.1 < 5e-5, "library {lib:?}");
    assert!((lib.1 - in_out.1).abs() < 1e-9);
    assert!(out_only.1 > 0.5, "the out-transport alone must miss: {out_only:?}");
    assert!(neither.1 < 5e-5, "{neither:?}");
    // bias uncertain: the error dynamics are linear only to first order (the smoothed
    // mean's own error is 7e-5 rad), and the in+out recursion is still the closest
    let [lib, _, out_only, neither] = against_pushforward(1e-4);
    assert!(lib.0 < 1e-4 && lib.1 < 0.03, "library {lib:?}");
    assert!(lib.1 < 0.6 * neither.1 && lib.1 < 0.1 * out_only.1, "{lib:?} {neither:?}");
}

/// The batch MAP (Gauss–Newton, Laplace covariance) at decreasing noise: the smoothed
/// means approach it at second order in the noise scale, the σ at first order (the
/// filter linearises at its own estimates, the MAP at itself).
#[test]
fn the_smoothed_estimates_approach_the_batch_map_as_the_noise_shrinks() {
    let mut rows = Vec::new();
    for s in [1.0, 0.5, 0.25, 0.125] {
        let run = simulate(s, 7);
        let (_, lib) = library(&run, 1e-9);
        let reference = batch_map(&run, &lib.iter().map(|p| p.0.clone()).collect::<Vec<_>>());
        let (m, v) = worst(&lib, &reference);
        println!("scale {s:5}: mean {m:.2e} rad, σ {v:.2e} relative");
        rows.push((m, v));
    }
    for w in rows.windows(2) {
        assert!(w[1].0 < 0.35 * w[0].0, "means: {rows:?}");
        assert!(w[1].1 < 0.85 * w[0].1, "σ: {rows:?}");
    }
    assert!(rows[3].0 < 2e-4 && rows[3].1 < 0.06, "{rows:?}");
}

/// 200 Monte Carlo runs from the models' own noise: the smoothed NEES per degree of
/// freedom, averaged over runs and epochs, in its band.
#[test]
fn smoothed_nees_over_monte_carlo_runs() {
    let runs = 200;
    let mut sums = [0.0f64; 3];
    let mut count = 0usize;
    for seed in 0..runs {
        let run = simulate(0.1, 1000 + seed);
        let (rts, lib) = library(&run, 1e-9);
        let last = lib.last().unwrap().clone();
        let variants = [
            lib,
            backward(rts.steps(), &last, Transport::Out),
            backward(rts.steps(), &last, Transport::Neither),
        ];
        for (k, truth) in run.truth.iter().enumerate() {
            for (v, est) in variants.iter().enumerate() {
                let e = truth.ominus(&est[k].0);
                sums[v] += (e.transpose() * est[k].1.try_inverse().unwrap() * e)[0];
            }
            count += 1;
        }
    }
    let nees = sums.map(|s| s / count as f64 / 6.0);
    println!(
        "smoothed NEES/dof over {runs} runs: library {:.4}, out only {:.4}, neither {:.4}",
        nees[0], nees[1], nees[2]
    );
    assert!((0.9..1.1).contains(&nees[0]), "{nees:?}");
}
