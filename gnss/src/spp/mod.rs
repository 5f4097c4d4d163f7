//! Single-point positioning: weighted least squares on one epoch's pseudoranges, with a
//! χ² check of the residuals and RAIM-style exclusion, and the receiver velocity from the
//! Dopplers.
//!
//! The measurement model, per satellite `s` of system `k`:
//! `P = |r_s − r| + ω_e (x_s y − y_s x)/c + c·dt_k − c·dt_s + I + T + ε`, with the
//! satellite's position at its transmission time (`t_rx − P/c − dt_s`), the Sagnac term
//! for the Earth's rotation during the signal's travel, one receiver clock per system
//! (the differences are the inter-system biases), the broadcast ionosphere scaled to the
//! signal's frequency (or the iono-free combination of two codes) and Saastamoinen's
//! troposphere. The variance of `ε` is
//! `σ² = a² + b²/sin²(el) [+ c_cn0·10^(−C/N0/10)] + σ²_URA + σ²_code bias + σ²_iono + σ²_tropo`:
//! RTKLIB's error budget (its manual, appendix E: 0.3 m code-bias, 5 m ionosphere and 3 m
//! troposphere when uncorrected, half the Klobuchar delay and 0.3/(sin el + 0.1) m when
//! corrected) with the textbook 1/sin² elevation term (RTKLIB 2.4.3 divides by sin el).

use super::atmosphere::{saastamoinen, saastamoinen_niell, Klobuchar};
use super::ephemeris::{Ephemerides, SatState, C, OMEGA_E};
use super::obs::{frequency, ObsEpoch};
use super::time::{GpsTime, Sat, System};
use estimator_core::consistency::chi2_quantile;

use crate::geodesy::{ecef_to_geodetic, ecef_to_ned_rotation};
use nalgebra::{DMatrix, DVector, Matrix3, Matrix4, Vector3, Vector4};

mod models;
mod options;

pub use models::*;
pub use options::*;

/// A single-point solution.
#[derive(Clone, Debug, PartialEq)]
pub struct Spp {
    /// The epoch's receiver time stamp.
    pub time: GpsTime,
    /// ECEF position, m.
    pub pos: Vector3<f64>,
    /// Covariance of `pos` (ECEF), m².
    pub cov: Matrix3<f64>,
    /// Receiver clock per system, m (`c·dt`).
    pub clocks: Vec<(System, f64)>,
    /// Satellites used, with their post-fit residuals (m) and elevations (rad).
    pub used: Vec<(Sat, f64, f64)>,
    /// Satellites excluded by RAIM.
    pub excluded: Vec<Sat>,
    /// Satellites observed but not used (no ephemeris, unhealthy, below the masks, no code).
    pub dropped: usize,
    /// Σ (v/σ)² of the residuals, and its degrees of freedom.
    pub chi2: (f64, usize),
    /// Geometric dilution of precision.
    pub gdop: f64,
    /// Velocity (ECEF, m/s) and its covariance from the Dopplers, when ≥ 4 have them.
    pub velocity: Option<(Vector3<f64>, Matrix3<f64>)>,
}

impl Spp {
    /// The instant the position holds at: the time stamp corrected by the receiver clock
    /// of the first system (as RTKLIB writes solutions).
    pub fn solution_time(&self) -> GpsTime {
        self.time.add(-self.clocks.first().map_or(0.0, |c| c.1) / C)
    }
}

/// Why an epoch has no solution.
#[derive(Clone, Debug, PartialEq)]
pub enum SppFailure {
    /// Fewer usable satellites than unknowns.
    TooFewSatellites {
        /// Usable.
        usable: usize,
        /// Unknowns (3 + one clock per system).
        needed: usize,
    },
    /// The iterations did not converge.
    NoConvergence,
    /// The normal equations are singular (degenerate geometry).
    Singular,
    /// GDOP above the limit.
    Gdop(f64),
    /// The residuals fail the χ² check and RAIM could not find the faulty satellite.
    Residuals {
        /// Σ (v/σ)².
        chi2: f64,
        /// Degrees of freedom.
        dof: usize,
    },
}

impl core::fmt::Display for SppFailure {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::TooFewSatellites { usable, needed } => {
                write!(f, "{usable} usable satellites for {needed} unknowns")
            }
            Self::NoConvergence => write!(f, "no convergence"),
            Self::Singular => write!(f, "degenerate geometry"),
            Self::Gdop(g) => write!(f, "GDOP {g:.1}"),
            Self::Residuals { chi2, dof } => {
                write!(f, "residuals fail the χ² check ({chi2:.1} on {dof} degrees of freedom)")
            }
        }
    }
}

struct Fit {
    x: DVector<f64>,
    used: Vec<(usize, f64, f64)>,
    chi2: f64,
    n_cov: DMatrix<f64>,
    gdop: f64,
    systems: Vec<System>,
}

/// Solves an epoch (see the module's text). `prior` is a position to start from (the
/// Earth's centre otherwise).
pub fn single_point(
    epoch: &ObsEpoch,
    eph: &Ephemerides,
    klobuchar: Option<&Klobuchar>,
    opt: &SppOptions,
    prior: Option<&Vector3<f64>>,
) -> Result<Spp, SppFailure> {
    let (sats, dropped) = prepare(epoch, eph, opt);
    solve_prepared(epoch.time, &sats, dropped, klobuchar, opt, prior)
}

/// [`single_point`] on satellites already prepared.
pub fn solve_prepared(
    time: GpsTime,
    sats: &[Prepared],
    dropped: usize,
    klobuchar: Option<&Klobuchar>,
    opt: &SppOptions,
    prior: Option<&Vector3<f64>>,
) -> Result<Spp, SppFailure> {
    let kb = klobuchar.copied().unwrap_or_default();
    let mut excluded: Vec<usize> = Vec::new();
    let mut fit = least_squares(time, sats, &excluded, &kb, opt, prior);
    loop {
        let failure = match &fit {
            Ok(f) => check(f, opt),
            Err(e) => Some(e.clone()),
        };
        let Some(failure) = failure else { break };
        let retry = matches!(failure, SppFailure::Residuals { .. } | SppFailure::Gdop(_));
        if !retry || excluded.len() >= opt.max_exclusions {
            return Err(failure);
        }
        // RAIM: the single exclusion that lowers χ² the most (the largest standardised
        // residual), kept only when it passes and stands out from the runner-up by
        // `raim_margin` — otherwise the fault cannot be told apart and the epoch is refused
        let mut ranked: Vec<(usize, Fit)> = Vec::new();
        for i in 0..sats.len() {
            if excluded.contains(&i) {
                continue;
            }
            let mut ex = excluded.clone();
            ex.push(i);
            if let Ok(f) = least_squares(time, sats, &ex, &kb, opt, prior)
                && f.used.len() > f.x.len()
            {
                ranked.push((i, f));
            }
        }
        ranked.sort_by(|a, b| a.1.chi2.total_cmp(&b.1.chi2));
        let separable = match ranked.get(1) {
            Some((_, second)) => second.chi2 - ranked[0].1.chi2 >= opt.raim_margin,
            None => true,
        };
        match ranked.into_iter().next() {
            Some((i, f)) if separable && check(&f, opt).is_none() => {
                excluded.push(i);
                fit = Ok(f);
            }
            _ => return Err(failure),
        }
    }
    let f = fit.map_err(|e| e.clone())?;
    let pos = Vector3::new(f.x[0], f.x[1], f.x[2]);
    let cov = f.n_cov.fixed_view::<3, 3>(0, 0).into_owned();
    let clocks = f.systems.iter().enumerate().map(|(k, s)| (*s, f.x[3 + k])).collect();
    let velocity = doppler_velocity(sats, &f, &pos, opt);
    Ok(Spp {
        time,
        pos,
        cov,
        clocks,
        used: f.used.iter().map(|(i, v, el)| (sats[*i].sat, *v, *el)).collect(),
        excluded: excluded.iter().map(|i| sats[*i].sat).collect(),
        dropped,
        chi2: (f.chi2, f.used.len() - f.x.len()),
        gdop: f.gdop,
        velocity,
    })
}

fn check(f: &Fit, opt: &SppOptions) -> Option<SppFailure> {
    let dof = f.used.len() - f.x.len();
    if dof > 0 && f.chi2 > chi2_quantile(1.0 - opt.alpha, dof as f64) {
        return Some(SppFailure::Residuals { chi2: f.chi2, dof });
    }
    if f.gdop.is_nan() || f.gdop > opt.max_gdop {
        return Some(SppFailure::Gdop(f.gdop));
    }
    None
}

/// The weighted least-squares iterations with the satellites `excluded` left out.
fn least_squares(
    time: GpsTime,
    sats: &[Prepared],
    excluded: &[usize],
    kb: &Klobuchar,
    opt: &SppOptions,
    prior: Option<&Vector3<f64>>,
) -> Result<Fit, SppFailure> {
    let candidates: Vec<usize> = (0..sats.len()).filter(|i| !excluded.contains(i)).collect();
    let mut systems: Vec<System> = candidates.iter().map(|i| sats[*i].sat.sys).collect();
    systems.sort();
    systems.dedup();
    let nx = 3 + systems.len();
    let mut x = DVector::zeros(nx);
    if let Some(p) = prior {
        x.fixed_rows_mut::<3>(0).copy_from(p);
    }
    for _ in 0..10 {
        let rr = Vector3::new(x[0], x[1], x[2]);
        let known = rr.norm() > 6.0e6;
        let (lat, lon, h) = if known { ecef_to_geodetic(&rr) } else { (0.0, 0.0, 0.0) };
        let mut rows: Vec<(usize, DVector<f64>, f64, f64, f64)> =
            Vec::with_capacity(candidates.len());
        for &i in &candidates {
            let s = &sats[i];
            let (r, e) = geometry(&s.state.pos, &rr);
            let (az, el) =
                if known { azel(lat, lon, &e) } else { (0.0, core::f64::consts::FRAC_PI_2) };
            if known && el < opt.elevation_mask {
                continue;
            }
            let (corr, var) = if known {
                corrections(opt, kb, (lat, lon, h), (az, el), time, s)
            } else {
                // no position yet: no atmosphere, its whole budget in the variance
                let mut var = code_variance(opt, el, s);
                var += if opt.ionosphere == Ionosphere::IonoFree { 0.0 } else { 25.0 };
                var += 9.0;
                (0.0, var)
            };
            let k = systems.iter().position(|y| *y == s.sat.sys).unwrap_or(0);
            let v = s.range - (r + x[3 + k] - C * s.state.clock + corr);
            let mut hrow = DVector::zeros(nx);
            hrow.fixed_rows_mut::<3>(0).copy_from(&(-e));
            hrow[3 + k] = 1.0;
            rows.push((i, hrow, v, var, el));
        }
        if rows.len() < nx {
            return Err(SppFailure::TooFewSatellites { usable: rows.len(), needed: nx });
        }
        let mut n = DMatrix::zeros(nx, nx);
        let mut g = DMatrix::zeros(nx, nx);
        let mut y = DVector::zeros(nx);
        for (_, hr, v, var, _) in &rows {
            n += hr * hr.transpose() / *var;
            g += hr * hr.transpose();
            y += hr * (*v / *var);
        }
        let chol = n.clone().cholesky().ok_or(SppFailure::Singular)?;
        let dx = chol.solve(&y);
        x += &dx;
        if dx.norm() < 1e-4 {
            // the residuals at the solution
            let mut chi2 = 0.0;
            let mut used = Vec::with_capacity(rows.len());
            for (i, hr, v, var, el) in &rows {
                let vv = v - hr.dot(&dx);
                chi2 += vv * vv / var;
                used.push((*i, vv, *el));
            }
            let gdop = g.clone().cholesky().map_or(f64::INFINITY, |c| c.inverse().trace().sqrt());
            return Ok(Fit { x, used, chi2, n_cov: chol.inverse(), gdop, systems });
        }
    }
    Err(SppFailure::NoConvergence)
}

/// The receiver velocity and clock drift from the range rates of the satellites used.
fn doppler_velocity(
    sats: &[Prepared],
    f: &Fit,
    rr: &Vector3<f64>,
    opt: &SppOptions,
) -> Option<(Vector3<f64>, Matrix3<f64>)> {
    let with: Vec<&Prepared> =
        f.used.iter().map(|(i, _, _)| &sats[*i]).filter(|s| s.range_rate.is_some()).collect();
    if with.len() < 4 {
        return None;
    }
    let w = 1.0 / (opt.doppler_std * opt.doppler_std);
    let mut x = Vector4::zeros();
    for _ in 0..6 {
        let mut n = Matrix4::zeros();
        let mut y = Vector4::zeros();
        let vr = Vector3::new(x[0], x[1], x[2]);
        for s in &with {
            let (_, e) = geometry(&s.state.pos, rr);
            let rate = range_rate(&s.state.pos, &s.state.vel, rr, &vr, &e);
            let v = s.range_rate? - (rate + x[3] - C * s.state.drift);
            let h = Vector4::new(-e.x, -e.y, -e.z, 1.0);
            n += h * h.transpose() * w;
            y += h * v * w;
        }
        let chol = n.cholesky()?;
        let dx = chol.solve(&y);
        x += dx;
        if dx.norm() < 1e-6 {
            let cov = chol.inverse().fixed_view::<3, 3>(0, 0).into_owned();
            return Some((Vector3::new(x[0], x[1], x[2]), cov));
        }
    }
    None
}
