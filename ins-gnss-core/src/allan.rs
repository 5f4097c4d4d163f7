//! IMU noise from a static record by the overlapping Allan deviation (IEEE Std 952-1997,
//! annex C; El-Sheimy, Hou & Niu 2008).
//!
//! The record's increments (angle or velocity, one axis) are integrated once, their
//! mean removed first (a constant rate does not change the Allan variance and the sums
//! stay small over a day); then for a cluster of `m` samples, `τ = m τ₀`,
//!
//! `σ²(τ) = Σₖ (θₖ₊₂ₘ − 2 θₖ₊ₘ + θₖ)² / (2 τ² (N − 2m))`, `k = 0 … N − 2m − 1`,
//!
//! every overlapping cluster, `O(N)` per `τ`. Its percentage error is
//! `δ = 1 / √(2 (N/m − 1))` (IEEE 952, C.2). The standard terms are fitted together, by
//! weighted least squares on `σ²` with the terms' coefficients kept non-negative:
//!
//! `σ²(τ) = N²/τ + (2 ln 2 / π) B² + K² τ / 3`,
//!
//! `N` the white noise (angle / velocity random walk, per √s), `B` the bias instability
//! (the flat floor, `σ = 0.664 B`), `K` the rate random walk (per s √s). Each term comes
//! with its 1σ from the fit; a term the record cannot resolve (its coefficient below
//! twice its σ) is reported as not observable, with the span the record would need.

/// `2 ln 2 / π`: the Allan variance of flicker (bias-instability) noise is this times B².
pub const FLICKER_FLOOR: f64 = 0.441_271_200_305_303_1;

/// One point of the curve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdevPoint {
    /// Cluster time, s.
    pub tau: f64,
    /// Overlapping Allan deviation, in the increments' unit per second (rad/s, m/s²).
    pub adev: f64,
    /// Its percentage error `δ` (1σ, relative).
    pub error: f64,
}

/// A fitted term: its value and 1σ, or `None` when the record does not resolve it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Term {
    /// Value (SI: per √s for white noise, per s for bias instability, per s√s for rate
    /// random walk).
    pub value: f64,
    /// 1σ of the value from the fit.
    pub sigma: f64,
}

/// The fit of one axis.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisNoise {
    /// The curve.
    pub curve: Vec<AdevPoint>,
    /// White noise `N` (angle or velocity random walk), per √s.
    pub white: Option<Term>,
    /// Bias instability `B`, per s (gyro rad/s, accelerometer m/s²).
    pub instability: Option<Term>,
    /// Rate random walk `K`, per s √s.
    pub rate_random_walk: Option<Term>,
    /// τ of the curve's minimum, s (the bias instability's correlation time in a
    /// Gauss–Markov model).
    pub tau_min: f64,
    /// The record's length, s.
    pub span: f64,
}

/// Why a curve could not be computed.
#[derive(Clone, Debug, PartialEq)]
pub enum AllanError {
    /// Fewer samples than a curve needs.
    TooShort {
        /// Samples given.
        samples: usize,
        /// Samples needed.
        needed: usize,
    },
    /// The sample interval is not finite and positive.
    BadInterval(f64),
    /// An increment is not finite (its index).
    NotFinite(usize),
}

impl core::fmt::Display for AllanError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::TooShort { samples, needed } => write!(
                f,
                "{samples} samples: the Allan deviation needs at least {needed} (a few \
                 minutes resolve the white noise; bias instability needs hours)"
            ),
            Self::BadInterval(dt) => write!(f, "sample interval {dt} s: finite and positive"),
            Self::NotFinite(i) => write!(f, "sample {i} is not finite"),
        }
    }
}

/// Fewest samples a curve is computed from.
pub const MIN_SAMPLES: usize = 100;

/// Cluster sizes, about 10 per decade from 1 to `(n − 1) / 2`, where at least
/// `min_clusters` independent clusters fit.
pub fn cluster_sizes(n: usize, min_clusters: usize) -> Vec<usize> {
    let max = (n.saturating_sub(1) / 2).min(n / min_clusters.max(2));
    let mut out: Vec<usize> = Vec::new();
    let mut k = 0.0_f64;
    loop {
        let m = 10f64.powf(k / 10.0).round() as usize;
        if m > max {
            break;
        }
        if out.last() != Some(&m) {
            out.push(m);
        }
        k += 1.0;
    }
    out
}

/// The overlapping Allan deviation of `increments` (one axis, one per interval `dt`,
/// e.g. angle increments in rad) at the cluster sizes `ms`.
pub fn overlapping_adev(
    increments: &[f64],
    dt: f64,
    ms: &[usize],
) -> Result<Vec<AdevPoint>, AllanError> {
    if !(dt.is_finite() && dt > 0.0) {
        return Err(AllanError::BadInterval(dt));
    }
    if increments.len() < MIN_SAMPLES {
        return Err(AllanError::TooShort { samples: increments.len(), needed: MIN_SAMPLES });
    }
    if let Some(i) = increments.iter().position(|v| !v.is_finite()) {
        return Err(AllanError::NotFinite(i));
    }
    let mean = increments.iter().sum::<f64>() / increments.len() as f64;
    // θ₀ = 0, θₖ = Σ_{i<k} (xᵢ − mean): N + 1 values
    let mut theta = Vec::with_capacity(increments.len() + 1);
    let mut acc = 0.0;
    theta.push(0.0);
    for x in increments {
        acc += x - mean;
        theta.push(acc);
    }
    let n = theta.len();
    let mut out = Vec::with_capacity(ms.len());
    for &m in ms {
        if m == 0 || 2 * m >= n {
            continue;
        }
        let terms = n - 2 * m;
        let (a, b, c) = (&theta[..terms], &theta[m..m + terms], &theta[2 * m..]);
        let sum: f64 =
            a.iter().zip(b).zip(c).map(|((a, b), c)| (c - 2.0 * b + a) * (c - 2.0 * b + a)).sum();
        let tau = m as f64 * dt;
        let avar = sum / (2.0 * tau * tau * terms as f64);
        let clusters = (n - 1) as f64 / m as f64;
        out.push(AdevPoint {
            tau,
            adev: avar.sqrt(),
            error: 1.0 / (2.0 * (clusters - 1.0)).max(1.0).sqrt(),
        });
    }
    Ok(out)
}

/// The three terms fitted to a curve (see the module): weighted least squares on `σ²`,
/// weights from each point's percentage error, coefficients non-negative (every subset
/// of the terms tried, the feasible one of least residual kept).
pub fn fit(curve: &[AdevPoint], span: f64) -> AxisNoise {
    // columns: 1/τ, FLICKER_FLOOR, τ/3 → coefficients N², B², K²
    let rows: Vec<([f64; 3], f64, f64)> = curve
        .iter()
        .map(|p| {
            let v = p.adev * p.adev;
            // var(σ²) ≈ (2 δ σ²)²
            let w = 1.0 / (2.0 * p.error * v).max(f64::MIN_POSITIVE);
            ([1.0 / p.tau, FLICKER_FLOOR, p.tau / 3.0], v, w)
        })
        .collect();
    let mut best: Option<([f64; 3], [f64; 3], f64)> = None;
    for mask in 1u8..8 {
        let cols: Vec<usize> = (0..3).filter(|c| mask & (1 << c) != 0).collect();
        if let Some((coef, sig, res)) = solve(&rows, &cols)
            && coef.iter().all(|c| *c >= 0.0)
            && best.as_ref().is_none_or(|b| res < b.2)
        {
            best = Some((coef, sig, res));
        }
    }
    let tau_min = curve.iter().min_by(|a, b| a.adev.total_cmp(&b.adev)).map_or(f64::NAN, |p| p.tau);
    let (coef, sig) = best.map_or(([0.0; 3], [0.0; 3]), |b| (b.0, b.1));
    // a coefficient c = x² with 1σ s: x = √c, σₓ = s / (2 x); resolved when c > 2 s
    let term = |c: f64, s: f64| {
        (c > 0.0 && c > 2.0 * s).then(|| {
            let x = c.sqrt();
            Term { value: x, sigma: s / (2.0 * x) }
        })
    };
    AxisNoise {
        curve: curve.to_vec(),
        white: term(coef[0], sig[0]),
        instability: term(coef[1], sig[1]),
        rate_random_walk: term(coef[2], sig[2]),
        tau_min,
        span,
    }
}

/// Weighted least squares on the columns `cols` (the others zero): coefficients, their
/// 1σ and the weighted residual; `None` when the normal equations are singular.
fn solve(rows: &[([f64; 3], f64, f64)], cols: &[usize]) -> Option<([f64; 3], [f64; 3], f64)> {
    let k = cols.len();
    if rows.len() <= k {
        return None;
    }
    let mut ata = nalgebra::DMatrix::<f64>::zeros(k, k);
    let mut atb = nalgebra::DVector::<f64>::zeros(k);
    for (x, y, w) in rows {
        for (i, &ci) in cols.iter().enumerate() {
            atb[i] += w * w * x[ci] * y;
            for (j, &cj) in cols.iter().enumerate() {
                ata[(i, j)] += w * w * x[ci] * x[cj];
            }
        }
    }
    let inv = ata.try_inverse()?;
    let c = &inv * atb;
    let res: f64 = rows
        .iter()
        .map(|(x, y, w)| {
            let model: f64 = cols.iter().enumerate().map(|(i, &ci)| c[i] * x[ci]).sum();
            (w * (y - model)).powi(2)
        })
        .sum();
    // the residual's scatter scales the covariance when it is larger than the weights say
    let dof = (rows.len() - k) as f64;
    let scale = (res / dof).max(1.0);
    let (mut coef, mut sig) = ([0.0; 3], [0.0; 3]);
    for (i, &ci) in cols.iter().enumerate() {
        coef[ci] = c[i];
        sig[ci] = (inv[(i, i)] * scale).sqrt();
    }
    Some((coef, sig, res))
}

/// [`analyse`] on each of `axes` (same `dt`), the axes shared among the machine's cores
/// (`std::thread::available_parallelism`; each axis' cumulative sum is as long as its
/// series, so at most that many are held at once). The results in the axes' order.
pub fn analyse_axes<A: AsRef<[f64]> + Sync>(
    axes: &[A],
    dt: f64,
) -> Vec<Result<AxisNoise, AllanError>> {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(axes.len());
    if threads <= 1 {
        return axes.iter().map(|a| analyse(a.as_ref(), dt)).collect();
    }
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut out: Vec<Option<Result<AxisNoise, AllanError>>> =
        (0..axes.len()).map(|_| None).collect();
    let done: Vec<Vec<(usize, Result<AxisNoise, AllanError>)>> = std::thread::scope(|s| {
        let workers: Vec<_> = (0..threads)
            .map(|_| {
                s.spawn(|| {
                    let mut mine = Vec::new();
                    loop {
                        let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some(a) = axes.get(k) else { break mine };
                        mine.push((k, analyse(a.as_ref(), dt)));
                    }
                })
            })
            .collect();
        workers.into_iter().filter_map(|w| w.join().ok()).collect()
    });
    for (k, r) in done.into_iter().flatten() {
        out[k] = Some(r);
    }
    // (a worker that panicked leaves its axes to this thread)
    out.into_iter()
        .enumerate()
        .map(|(k, r)| r.unwrap_or_else(|| analyse(axes[k].as_ref(), dt)))
        .collect()
}

/// The curve and fit of one axis' increments (`dt` the sample interval): cluster sizes
/// where at least 3 clusters fit, the fit over those with at least 9.
pub fn analyse(increments: &[f64], dt: f64) -> Result<AxisNoise, AllanError> {
    let ms = cluster_sizes(increments.len(), 3);
    let curve = overlapping_adev(increments, dt, &ms)?;
    let span = increments.len() as f64 * dt;
    let n = increments.len() as f64;
    let fitted: Vec<AdevPoint> = curve.iter().copied().filter(|p| n * dt / p.tau >= 9.0).collect();
    let mut out = fit(&fitted, span);
    out.curve = curve;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::StdRng;
    use rand::SeedableRng;
    use rand_distr::{Distribution, StandardNormal};

    /// Reproducible standard normal draws.
    struct Gauss(StdRng);
    impl Gauss {
        fn new(seed: u64) -> Self {
            Self(StdRng::seed_from_u64(seed))
        }
        fn next(&mut self) -> f64 {
            StandardNormal.sample(&mut self.0)
        }
    }

    #[test]
    fn white_noise_has_the_slope_minus_half_and_its_density() {
        // N = 0.01 /√s at 100 Hz: increments N √dt · w
        let (dt, n_true) = (0.01_f64, 0.01);
        let mut g = Gauss::new(7);
        let x: Vec<f64> = (0..200_000).map(|_| n_true * dt.sqrt() * g.next()).collect();
        let a = analyse(&x, dt).unwrap();
        let w = a.white.expect("white noise resolved");
        assert!((w.value / n_true - 1.0).abs() < 0.03, "{w:?}");
        assert!(a.instability.is_none() && a.rate_random_walk.is_none(), "{a:?}");
        // σ(τ) = N/√τ on the curve, within each point's error band
        for p in a.curve.iter().filter(|p| p.error < 0.1) {
            let expected = n_true / p.tau.sqrt();
            assert!((p.adev / expected - 1.0).abs() < 4.0 * p.error, "{p:?}");
        }
    }

    #[test]
    fn a_rate_random_walk_and_white_noise_are_told_apart() {
        let (dt, n_true, k_true) = (0.01_f64, 0.005, 2e-4);
        let mut g = Gauss::new(3);
        let mut bias = 0.0;
        let x: Vec<f64> = (0..1_000_000)
            .map(|_| {
                bias += k_true * dt.sqrt() * g.next();
                (bias + n_true / dt.sqrt() * g.next()) * dt
            })
            .collect();
        let a = analyse(&x, dt).unwrap();
        let w = a.white.unwrap();
        let k = a.rate_random_walk.expect("rate random walk resolved");
        assert!((w.value / n_true - 1.0).abs() < 0.05, "{w:?}");
        assert!((k.value / k_true - 1.0).abs() < 0.35, "{k:?} against {k_true}");
    }

    #[test]
    fn short_and_broken_records_are_refused_not_nan() {
        assert!(matches!(analyse(&[0.0; 50], 0.01), Err(AllanError::TooShort { .. })));
        assert!(matches!(analyse(&[0.0; 500], 0.0), Err(AllanError::BadInterval(_))));
        let mut x = vec![0.0; 500];
        x[7] = f64::NAN;
        assert_eq!(analyse(&x, 0.01), Err(AllanError::NotFinite(7)));
    }
}
