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
use crate::earth::{ecef_to_geodetic, ecef_to_ned_rotation};
use crate::gnss::GnssEpoch;
use crate::position::GeoPos;
use estimator_core::consistency::chi2_quantile;
use nalgebra::{DMatrix, DVector, Matrix3, Matrix4, Vector3, Vector4};

/// The ionosphere model of a solution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ionosphere {
    /// No correction (5 m of error budget).
    Off,
    /// The broadcast Klobuchar model, scaled to each signal's frequency.
    Klobuchar,
    /// The iono-free combination of the two frequencies' codes (satellites with one are
    /// dropped).
    IonoFree,
}

/// The troposphere model of a solution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Troposphere {
    /// No correction (3 m of error budget).
    Off,
    /// Saastamoinen with the standard atmosphere, mapped by 1/sin(el) (RTKLIB's single
    /// point).
    Saastamoinen,
    /// Saastamoinen's zenith delays mapped by Niell's hydrostatic and wet functions
    /// (lower than 1/sin(el) by 0.5 m at 10° and 3 m at 5°).
    Niell,
}

/// Options of the single-point solution.
#[derive(Clone, Debug, PartialEq)]
pub struct SppOptions {
    /// Elevation mask, rad.
    pub elevation_mask: f64,
    /// Ionosphere.
    pub ionosphere: Ionosphere,
    /// Troposphere.
    pub troposphere: Troposphere,
    /// The systems used.
    pub systems: Vec<System>,
    /// Elevation weighting `σ² = a² + b²/sin²(el)`: `(a, b)`, m.
    pub elevation_weight: (f64, f64),
    /// C/N0 weighting `c·10^(−C/N0/10)` (m²·Hz), added when the observation has C/N0;
    /// `None` for elevation only. The σ-ε model of Hartinger and Brunner (1999); 1.6e4 m²Hz
    /// suits a C/A code.
    pub cn0_weight: Option<f64>,
    /// Satellites below this C/N0 (dB-Hz) are not used (0: no mask).
    pub cn0_mask: f64,
    /// Significance of the residuals' χ² check (RTKLIB: 0.001).
    pub alpha: f64,
    /// Largest GDOP accepted.
    pub max_gdop: f64,
    /// Satellites RAIM may exclude one by one while the check fails (0: no exclusion).
    pub max_exclusions: usize,
    /// How much lower (in χ²) the best exclusion must leave the residuals than the
    /// runner-up for RAIM to name a satellite; below it the epoch is refused (a wrong
    /// exclusion would leave the fault in a trusted fix).
    pub raim_margin: f64,
    /// σ of a Doppler's range rate, m/s.
    pub doppler_std: f64,
}

impl Default for SppOptions {
    fn default() -> Self {
        Self {
            elevation_mask: 15f64.to_radians(),
            ionosphere: Ionosphere::Klobuchar,
            troposphere: Troposphere::Saastamoinen,
            systems: vec![System::Gps, System::Galileo, System::BeiDou, System::Qzss],
            elevation_weight: (0.3, 0.3),
            cn0_weight: None,
            cn0_mask: 0.0,
            alpha: 1e-3,
            max_gdop: 30.0,
            max_exclusions: 2,
            raim_margin: 2.0,
            doppler_std: 0.1,
        }
    }
}

impl SppOptions {
    /// The options `rnx2rtkp -p 0` uses when given no configuration (RTKLIB 2.4.3):
    /// 15° mask, no ionosphere and no troposphere correction, no exclusion.
    pub fn rtklib_default() -> Self {
        Self {
            ionosphere: Ionosphere::Off,
            troposphere: Troposphere::Off,
            max_exclusions: 0,
            ..Self::default()
        }
    }
}

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

    /// The solution as a GNSS fix at time `t` (on the caller's clock): the geodetic
    /// position with its NED covariance, and the Doppler velocity (NED) with its
    /// covariance when there is one — what loose coupling and `.pos` output take.
    pub fn fix(&self, t: f64) -> GnssEpoch {
        let (lat, lon, h) = ecef_to_geodetic(&self.pos);
        let c_ne = ecef_to_ned_rotation(lat, lon);
        let cov = c_ne * self.cov * c_ne.transpose();
        let sd =
            |c: &Matrix3<f64>| Vector3::new(c[(0, 0)].sqrt(), c[(1, 1)].sqrt(), c[(2, 2)].sqrt());
        let vel = self.velocity.map(|(v, vc)| (c_ne * v, c_ne * vc * c_ne.transpose()));
        GnssEpoch {
            t,
            pos: GeoPos { lat, lon, h },
            pos_std: sd(&cov),
            vel: vel.map(|(v, vc)| (v, sd(&vc))),
            pos_cov: Some(cov),
            vel_cov: vel.map(|(_, vc)| vc),
        }
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

/// One satellite's measurement, prepared once per epoch.
#[derive(Clone, Copy, Debug)]
pub struct Prepared {
    /// The satellite.
    pub sat: Sat,
    /// Its state at transmission (clock for the code used).
    pub state: SatState,
    /// The pseudorange (or iono-free combination), m.
    pub range: f64,
    /// `(f_L1/f)²` of the code (0 for iono-free).
    pub iono_scale: f64,
    /// Range rate from the first frequency's Doppler, m/s.
    pub range_rate: Option<f64>,
    /// C/N0 of the code, dB-Hz.
    pub cn0: Option<f64>,
    /// The first frequency's carrier phase, m (cycles × wavelength).
    pub phase: Option<f64>,
    /// The receiver flagged a possible cycle slip on that phase (LLI bit 0).
    pub slip: bool,
}

/// The satellites of an epoch with a usable code and ephemeris, their states at
/// transmission; the count of those dropped.
pub fn prepare(epoch: &ObsEpoch, eph: &Ephemerides, opt: &SppOptions) -> (Vec<Prepared>, usize) {
    let mut out = Vec::with_capacity(epoch.sats.len());
    let mut dropped = 0;
    for o in &epoch.sats {
        let s0 = &o.signals[0];
        let usable = opt.systems.contains(&o.sat.sys) && s0.cn0.is_none_or(|c| c >= opt.cn0_mask);
        let (Some(p1), Some(e)) = (s0.code.filter(|_| usable), eph.select(o.sat, &epoch.time))
        else {
            dropped += 1;
            continue;
        };
        let (f1, f2) = (frequency(o.sat.sys, 0), frequency(o.sat.sys, 1));
        let (range, iono_scale, tgd_back) = match opt.ionosphere {
            Ionosphere::IonoFree => match o.signals[1].code {
                Some(p2) => {
                    let g = (f1 / f2).powi(2);
                    // the broadcast clock is the iono-free one: no group delay
                    ((g * p1 - p2) / (g - 1.0), 0.0, e.group_delay())
                }
                None => {
                    dropped += 1;
                    continue;
                }
            },
            _ => (p1, (frequency(System::Gps, 0) / f1).powi(2), 0.0),
        };
        // transmission time: the code's travel time and the satellite clock
        let mut t = epoch.time.add(-range / C);
        for _ in 0..3 {
            t = epoch.time.add(-range / C - e.clock_polynomial(&t));
        }
        let mut state = e.state(&t);
        state.clock += tgd_back;
        let range_rate = s0.doppler.map(|d| -d * C / f1);
        out.push(Prepared {
            sat: o.sat,
            state,
            range,
            iono_scale,
            range_rate,
            cn0: s0.cn0,
            phase: s0.phase.map(|l| l * C / f1),
            slip: s0.lli & 1 != 0,
        });
    }
    (out, dropped)
}

/// Geometric range from a receiver at `rr` to a satellite at `rs` (ECEF) with the Sagnac
/// term for the Earth's rotation during the signal's travel, and the unit vector
/// receiver → satellite: the range of the single point, the tightly coupled filter and
/// the simulator alike.
pub fn geometry(rs: &Vector3<f64>, rr: &Vector3<f64>) -> (f64, Vector3<f64>) {
    let d = rs - rr;
    let r = d.norm();
    (r + OMEGA_E * (rs.x * rr.y - rs.y * rr.x) / C, d / r)
}

/// The rate of [`geometry`]'s range for satellite and receiver velocities `vs`, `vr`
/// (ECEF), with the unit vector `u` it gave.
pub fn range_rate(
    rs: &Vector3<f64>,
    vs: &Vector3<f64>,
    rr: &Vector3<f64>,
    vr: &Vector3<f64>,
    u: &Vector3<f64>,
) -> f64 {
    u.dot(&(vs - vr)) + OMEGA_E / C * (vs.y * rr.x + rs.y * vr.x - vs.x * rr.y - rs.x * vr.y)
}

/// Azimuth and elevation (rad) of the unit vector `e` (ECEF) at geodetic `(lat, lon)`.
pub fn azel(lat: f64, lon: f64, e: &Vector3<f64>) -> (f64, f64) {
    let n = ecef_to_ned_rotation(lat, lon) * e;
    (n.y.atan2(n.x).rem_euclid(2.0 * core::f64::consts::PI), (-n.z).clamp(-1.0, 1.0).asin())
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
            if let Ok(f) = least_squares(time, sats, &ex, &kb, opt, prior) {
                if f.used.len() > f.x.len() {
                    ranked.push((i, f));
                }
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

/// A code's variance apart from the atmosphere's: elevation (and C/N0) weighting, the
/// broadcast orbit and clock, the code bias (m²).
pub fn code_variance(opt: &SppOptions, el: f64, s: &Prepared) -> f64 {
    code_noise_variance(opt, el, s) + s.state.variance + 0.09
}

/// The part of [`code_variance`] that is new at every epoch (m²): the elevation (and
/// C/N0) weighted noise of the code, without the satellite's orbit and clock (URA) and code
/// bias, which stay the same from one epoch to the next.
pub fn code_noise_variance(opt: &SppOptions, el: f64, s: &Prepared) -> f64 {
    let (a, b) = opt.elevation_weight;
    let sin_el = el.sin().max(0.05);
    let mut noise = a * a + (b / sin_el).powi(2);
    if opt.ionosphere == Ionosphere::IonoFree {
        // the combination's noise: (γ² + 1)/(γ − 1)² ≈ 9 times a code's (RTKLIB's factor)
        noise *= 9.0;
    }
    if let (Some(c), Some(cn0)) = (opt.cn0_weight, s.cn0) {
        noise += c * 10f64.powf(-cn0 / 10.0);
    }
    noise
}

/// The atmospheric corrections `I + T` (m) of a code at the receiver `(lat, lon, h)` for a
/// satellite at `(az, el)` at GPS time `time`, and the code's whole variance
/// (m²): [`code_variance`] plus the models' residual errors (5 m of ionosphere and 3 m of
/// troposphere when not corrected; half the Klobuchar delay and 0.3/(sin el + 0.1) m
/// when corrected). Used by the single point and the tightly coupled filter alike.
pub fn corrections(
    opt: &SppOptions,
    kb: &Klobuchar,
    llh: (f64, f64, f64),
    azel: (f64, f64),
    time: GpsTime,
    s: &Prepared,
) -> (f64, f64) {
    let ((iono, var_iono), (tropo, var_tropo)) = atmosphere(opt, kb, llh, azel, time, s);
    (iono + tropo, code_variance(opt, azel.1, s) + var_iono + var_tropo)
}

/// The ionosphere's and the troposphere's delays of a code (m) with their residual
/// variances (m²), as [`corrections`] adds them (the carrier phase sees `T − I`).
pub fn atmosphere(
    opt: &SppOptions,
    kb: &Klobuchar,
    (lat, lon, h): (f64, f64, f64),
    (az, el): (f64, f64),
    time: GpsTime,
    s: &Prepared,
) -> ((f64, f64), (f64, f64)) {
    let (iono, var_iono) = match opt.ionosphere {
        Ionosphere::Off => (0.0, 25.0),
        Ionosphere::IonoFree => (0.0, 0.0),
        Ionosphere::Klobuchar => {
            let d = kb.delay(lat, lon, az, el, time.tow) * s.iono_scale;
            (d, (0.5 * d).powi(2))
        }
    };
    let residual = (0.3 / (el.sin().max(0.05) + 0.1)).powi(2);
    let (tropo, var_tropo) = match opt.troposphere {
        Troposphere::Off => (0.0, 9.0),
        Troposphere::Saastamoinen => (saastamoinen(lat, h, el), residual),
        Troposphere::Niell => (saastamoinen_niell(lat, h, el, time.day_of_year()), residual),
    };
    ((iono, var_iono), (tropo, var_tropo))
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
