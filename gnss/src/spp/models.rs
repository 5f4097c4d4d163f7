//! A satellite's code and Doppler as the single point and the tightly coupled filter model
//! them: the satellite prepared at its transmission time, the geometry, the code's variance
//! and the atmosphere's delays.

use super::*;

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
    let tropo = opt.troposphere.delay(lat, h, el, time);
    let var_tropo = if opt.troposphere == Troposphere::Off { 9.0 } else { residual };
    ((iono, var_iono), (tropo, var_tropo))
}
