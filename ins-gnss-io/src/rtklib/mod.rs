//! RTKLIB solution files (`.pos`, written by `rnx2rtkp`, RTKPOST, RTKNAVI, the demo5
//! fork): read as GNSS epochs, and the navigation result written in the same format.
//!
//! The header's last line names the columns: the time system (`GPST`, `UTC`, `JST`),
//! then `latitude(deg) longitude(deg) height(m)` (or `latitude(d'")` … in degrees,
//! minutes and seconds, or `x-ecef(m) y-ecef(m) z-ecef(m)`), `Q ns`, the σ and the
//! signed square roots of the covariances (`sdn sde sdu sdne sdeu sdun`, or `sdx sdy sdz
//! sdxy sdyz sdzx`), `age ratio`, and optionally the velocity with its σ and covariances
//! (`vn ve vu sdvn sdve sdvu sdvne sdveu sdvun`, or their ECEF counterparts). Each epoch's
//! time is a date and time (`2025/08/28 17:30:39.749`) or a GPS week and seconds of week.
//! Epochs are returned on the GPST seconds-of-week scale of the KF-GINS formats (UTC
//! plus the leap seconds of its date; JST minus 9 h first).
//!
//! RTKLIB writes a covariance `c` as `sign(c) √|c|`, so `c = s |s|`. The quality flag
//! `Q` (1 fix, 2 float, 3 SBAS, 4 DGPS, 5 single, 6 PPP) scales σ by
//! [`QualityFactors`] and can drop an epoch.

use std::io::Write;

use nalgebra::{Matrix3, Vector3};

use super::lines::LineErrorKind;
use ins_gnss_core::earth::{ecef_to_geodetic, ecef_to_ned_rotation, geodetic_to_ecef};
use ins_gnss_core::gnss::GnssEpoch;
use ins_gnss_core::GeoPos;

mod write;

pub use ::gnss::calendar::{
    civil_from_days, days_from_civil, gps_minus_utc, seconds_of_week, TimeSystem,
};
use ::gnss::calendar::{GPS_EPOCH_DAYS, WEEK};
pub use write::*;

/// The σ factor per solution quality `Q` (index 1–6) and the qualities dropped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QualityFactors {
    /// σ factor for Q = 1 (fix) … 6 (PPP); index 0 is unused (Q = 0: no solution, always
    /// dropped).
    pub factor: [f64; 7],
    /// Epochs of these qualities are dropped.
    pub drop: [bool; 7],
}

impl Default for QualityFactors {
    /// Fix 1, float 2, SBAS 5, DGPS 3, single 5, PPP 2 (the factors the open INS/GNSS
    /// tools that read RTKLIB output use for float and single: 2 and 5); nothing dropped.
    fn default() -> Self {
        Self { factor: [1.0, 1.0, 2.0, 5.0, 3.0, 5.0, 2.0], drop: [false; 7] }
    }
}

/// The solution quality names, by `Q`.
pub const QUALITY_NAMES: [&str; 7] = ["none", "fix", "float", "sbas", "dgps", "single", "ppp"];

/// How positions are written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum PosForm {
    /// Latitude, longitude in degrees.
    Degrees,
    /// Latitude, longitude as degrees, minutes, seconds (three fields each).
    Dms,
    /// ECEF x, y, z.
    Ecef,
}

/// A parsed `.pos` header: where each quantity sits in a data line.
#[derive(Clone, Debug, PartialEq)]
pub struct PosHeader {
    /// The time scale named by the header.
    pub system: TimeSystem,
    form: PosForm,
    /// Field index (after the two time fields) of position, Q, σ, velocity, velocity σ.
    pos: usize,
    q: Option<usize>,
    sd: Option<usize>,
    vel: Option<usize>,
    sdv: Option<usize>,
}

impl PosHeader {
    /// Parses a header line (`%  GPST  latitude(deg) …`); `None` when it is not one.
    pub fn parse(line: &str) -> Option<Self> {
        let body = line.trim_start().strip_prefix('%')?;
        let mut names = body.split_whitespace();
        let system = TimeSystem::from_label(names.next()?)?;
        let names: Vec<&str> = names.collect();
        let at = |n: &str| names.iter().position(|x| x.starts_with(n));
        let (pos_name, form) = if let Some(i) = at("latitude(d'\"") {
            (i, PosForm::Dms)
        } else if let Some(i) = at("latitude(") {
            (i, PosForm::Degrees)
        } else {
            (at("x-ecef(")?, PosForm::Ecef)
        };
        // data fields per header name: a dms angle is three
        let width = |i: usize| -> usize {
            if form == PosForm::Dms && (i == pos_name || i == pos_name + 1) {
                3
            } else {
                1
            }
        };
        let field = |name_index: usize| -> usize { (0..name_index).map(width).sum() };
        let idx = |n: &str| at(n).map(field);
        let (vel, sdv) = match form {
            PosForm::Ecef => (idx("vx-ecef("), idx("sdvx")),
            _ => (idx("vn("), idx("sdvn")),
        };
        let sd = match form {
            PosForm::Ecef => idx("sdx("),
            _ => idx("sdn("),
        };
        Some(Self { system, form, pos: field(pos_name), q: idx("Q"), sd, vel, sdv })
    }

    /// Index of the `Q` field after the two time fields.
    pub fn quality_field(&self) -> Option<usize> {
        self.q
    }

    /// Whether the file has velocities.
    pub fn has_velocity(&self) -> bool {
        self.vel.is_some()
    }
}

/// The `c = s |s|` of RTKLIB's signed square roots.
fn unsqrt(s: f64) -> f64 {
    s * s.abs()
}

/// A symmetric matrix from σ (3) and the signed roots of the (01, 12, 20) covariances.
pub(crate) fn covariance(sd: &[f64]) -> Matrix3<f64> {
    let (xy, yz, zx) = (unsqrt(sd[3]), unsqrt(sd[4]), unsqrt(sd[5]));
    Matrix3::new(sd[0] * sd[0], xy, zx, xy, sd[1] * sd[1], yz, zx, yz, sd[2] * sd[2])
}

/// NEU (RTKLIB's local frame) → NED: `D = −U`.
fn neu_to_ned(c: &Matrix3<f64>) -> Matrix3<f64> {
    let f = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0));
    f * c * f
}

/// A solution line's time (its first two fields, on `system`'s scale) and its other
/// fields; a line of one field is `expected` columns short.
pub(crate) fn split_line(
    system: TimeSystem,
    line: &str,
    expected: usize,
) -> Result<(f64, Vec<&str>), LineErrorKind> {
    let mut it = line.split_whitespace();
    let (a, b) = match (it.next(), it.next()) {
        (Some(a), Some(b)) => (a, b),
        _ => return Err(LineErrorKind::ColumnCount { expected: vec![expected], found: 1 }),
    };
    Ok((parse_time(system, a, b)?, it.collect()))
}

/// Field `i` after the two time fields as a finite number; errors name its column.
pub(crate) fn field(fields: &[&str], i: usize) -> Result<f64, LineErrorKind> {
    let s = fields
        .get(i)
        .ok_or(LineErrorKind::ColumnCount { expected: vec![i + 3], found: fields.len() + 2 })?;
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(LineErrorKind::NonFinite { column: i + 3 }),
        Err(_) => {
            Err(LineErrorKind::NotNumeric { column: i + 3, text: s.chars().take(40).collect() })
        }
    }
}

/// A line's position (its fields after the time) in the header's form, and for ECEF the
/// rotation to NED that its covariances need.
#[allow(clippy::type_complexity)]
fn position_of(
    h: &PosHeader,
    fields: &[&str],
) -> Result<(GeoPos, Option<Matrix3<f64>>), LineErrorKind> {
    let num = |i: usize| field(fields, i);
    let p = h.pos;
    Ok(match h.form {
        PosForm::Degrees => {
            let pos = GeoPos::from_degrees(num(p)?, num(p + 1)?, num(p + 2)?);
            (pos, None)
        }
        PosForm::Dms => {
            let angle = |i: usize| -> Result<f64, LineErrorKind> {
                let (d, m, s) = (num(i)?, num(i + 1)?, num(i + 2)?);
                let negative = d < 0.0 || fields[i].starts_with('-');
                let v = d.abs() + m / 60.0 + s / 3600.0;
                Ok(if negative { -v } else { v })
            };
            (GeoPos::from_degrees(angle(p)?, angle(p + 3)?, num(p + 6)?), None)
        }
        PosForm::Ecef => {
            let r = Vector3::new(num(p)?, num(p + 1)?, num(p + 2)?);
            if r.norm() < 1e6 {
                return Err(LineErrorKind::WrongUnits(format!(
                    "ECEF position {:.1} m from the Earth's centre",
                    r.norm()
                )));
            }
            let (lat, lon, hgt) = ecef_to_geodetic(&r);
            (GeoPos::new(lat, lon, hgt), Some(ecef_to_ned_rotation(lat, lon)))
        }
    })
}

/// One data line: the epoch, or `None` when its quality is dropped (`Q = 0` always).
pub fn parse_line(
    h: &PosHeader,
    line: &str,
    quality: &QualityFactors,
) -> Result<Option<GnssEpoch>, LineErrorKind> {
    let (t, fields) = split_line(h.system, line, 3)?;
    let num = |i: usize| field(&fields, i);
    let q = match h.q {
        Some(i) => {
            let q = num(i)?;
            if !(0.0..=6.0).contains(&q) || q.fract() != 0.0 {
                return Err(LineErrorKind::WrongUnits(format!(
                    "solution quality Q = {q}: RTKLIB writes 0–6"
                )));
            }
            q as usize
        }
        None => 1,
    };
    if q == 0 || quality.drop[q] {
        return Ok(None);
    }
    let k = quality.factor[q];
    let (pos, c_ne) = position_of(h, &fields)?;
    if pos.lat.abs() > core::f64::consts::FRAC_PI_2 || pos.lon.abs() > 2.0 * core::f64::consts::PI {
        return Err(LineErrorKind::WrongUnits("latitude or longitude out of range".into()));
    }
    let local = |c: Matrix3<f64>| -> Matrix3<f64> {
        match c_ne {
            Some(r) => r * c * r.transpose(),
            None => neu_to_ned(&c),
        }
    };
    let read6 = |i: usize| -> Result<[f64; 6], LineErrorKind> {
        let mut v = [0.0; 6];
        for (j, x) in v.iter_mut().enumerate() {
            *x = num(i + j)?;
        }
        Ok(v)
    };
    let pos_cov = match h.sd {
        Some(i) => local(covariance(&read6(i)?)) * (k * k),
        None => return Err(LineErrorKind::WrongUnits("the header names no σ columns".into())),
    };
    check_cov(&pos_cov, "position")?;
    let vel = match (h.vel, h.sdv) {
        (Some(i), Some(j)) => {
            let v = Vector3::new(num(i)?, num(i + 1)?, num(i + 2)?);
            let v = match c_ne {
                Some(r) => r * v,
                None => Vector3::new(v.x, v.y, -v.z),
            };
            let c = local(covariance(&read6(j)?)) * (k * k);
            check_cov(&c, "velocity")?;
            Some((v, c))
        }
        _ => None,
    };
    let sd = |c: &Matrix3<f64>| c.diagonal().map(f64::sqrt);
    let mut e = GnssEpoch::new(t, pos, sd(&pos_cov), vel.map(|(v, c)| (v, sd(&c))));
    e.pos_cov = Some(pos_cov);
    e.vel_cov = vel.map(|(_, c)| c);
    Ok(Some(e))
}

fn check_cov(c: &Matrix3<f64>, what: &str) -> Result<(), LineErrorKind> {
    if c.diagonal().iter().any(|v| *v <= 0.0) {
        return Err(LineErrorKind::WrongUnits(format!("{what} σ must be positive")));
    }
    if c.cholesky().is_none() {
        return Err(LineErrorKind::WrongUnits(format!(
            "{what} covariance (σ and sdne/sdeu/sdun) is not positive definite"
        )));
    }
    Ok(())
}

/// GPST seconds of week of a time written as `yyyy/mm/dd hh:mm:ss.sss` or `week tow`.
fn parse_time(system: TimeSystem, a: &str, b: &str) -> Result<f64, LineErrorKind> {
    let bad = |text: String| LineErrorKind::NotNumeric { column: 1, text };
    if a.contains('/') || a.contains('-') && a.len() >= 8 {
        let d: Vec<i64> = a
            .split(['/', '-'])
            .map(|x| x.parse::<i64>())
            .collect::<Result<_, _>>()
            .map_err(|_| bad(a.into()))?;
        let t: Vec<&str> = b.split(':').collect();
        if d.len() != 3 || t.len() != 3 {
            return Err(bad(format!("{a} {b}")));
        }
        let hh = t[0].parse::<i64>().map_err(|_| bad(b.into()))?;
        let mm = t[1].parse::<i64>().map_err(|_| bad(b.into()))?;
        let ss = t[2].parse::<f64>().map_err(|_| bad(b.into()))?;
        if !(1..=12).contains(&d[1]) || !(1..=31).contains(&d[2]) || !(0.0..61.0).contains(&ss) {
            return Err(bad(format!("{a} {b}")));
        }
        Ok(seconds_of_week(system, (d[0], d[1], d[2]), (hh, mm, ss)))
    } else {
        let week = a.parse::<f64>().map_err(|_| bad(a.into()))?;
        let tow = b.parse::<f64>().map_err(|_| bad(b.into()))?;
        if week.fract() != 0.0 || !(0.0..WEEK).contains(&tow) {
            return Err(bad(format!("{a} {b}")));
        }
        match system {
            TimeSystem::Gpst => Ok(tow),
            _ => {
                // a week and seconds in UTC or JST: through the calendar
                let unix = (GPS_EPOCH_DAYS as f64) * 86_400.0 + week * WEEK + tow;
                let day = (unix / 86_400.0).floor();
                let (y, m, d) = civil_from_days(day as i64);
                let s = unix - day * 86_400.0;
                let (hh, mm) = ((s / 3600.0).floor(), ((s % 3600.0) / 60.0).floor());
                Ok(seconds_of_week(
                    system,
                    (y, m, d),
                    (hh as i64, mm as i64, s - hh * 3600.0 - mm * 60.0),
                ))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The epoch as `write!` wrote it before [`push_epoch`]: the bytes must not change.
    fn formatted(
        t: f64,
        pos: &GeoPos,
        pc: &Matrix3<f64>,
        vel: Option<(&Vector3<f64>, &Matrix3<f64>)>,
        q: u8,
    ) -> String {
        let d = 180.0 / core::f64::consts::PI;
        let f = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0));
        let c = f * pc * f;
        let mut s = format!(
            "{:4} {:11.4} {:16.11} {:16.11} {:12.6} {:3} {:3} {:9.6} {:9.6} {:9.6} {:9.6} {:9.6} {:9.6} {:6.2} {:6.1}",
            0,
            t,
            pos.lat * d,
            pos.lon * d,
            pos.h,
            q,
            0,
            c[(0, 0)].sqrt(),
            c[(1, 1)].sqrt(),
            c[(2, 2)].sqrt(),
            sqvar(c[(0, 1)]),
            sqvar(c[(1, 2)]),
            sqvar(c[(2, 0)]),
            0.0,
            0.0
        );
        if let Some((v, vc)) = vel {
            let c = f * vc * f;
            s += &format!(
                " {:11.6} {:11.6} {:11.6} {:9.6} {:9.6} {:9.6} {:9.6} {:9.6} {:9.6}",
                v.x,
                v.y,
                -v.z,
                c[(0, 0)].sqrt(),
                c[(1, 1)].sqrt(),
                c[(2, 2)].sqrt(),
                sqvar(c[(0, 1)]),
                sqvar(c[(1, 2)]),
                sqvar(c[(2, 0)])
            );
        }
        s + "\n"
    }

    proptest::proptest! {
        #[test]
        fn push_epoch_writes_what_format_wrote(
            t in 0.0f64..700_000.0,
            lat in -1.5f64..1.5,
            lon in -3.1f64..3.1,
            h in -500.0f64..1e5,
            var in proptest::collection::vec(1e-9f64..1e6, 6),
            cross in -0.9f64..0.9,
            v in proptest::collection::vec(-1e3f64..1e3, 3),
            q in 1u8..7,
            with_vel in proptest::bool::ANY,
        ) {
            let pos = GeoPos { lat, lon, h };
            let pc = Matrix3::new(var[0], cross * (var[0] * var[1]).sqrt(), 0.0,
                cross * (var[0] * var[1]).sqrt(), var[1], 0.0, 0.0, 0.0, var[2]);
            let vc = Matrix3::from_diagonal(&Vector3::new(var[3], var[4], var[5]));
            let vel = Vector3::new(v[0], v[1], v[2]);
            let vel = with_vel.then_some((&vel, &vc));
            let mut out = Vec::new();
            push_epoch(&mut out, 0.0, t, &pos, &pc, vel, q);
            proptest::prop_assert_eq!(String::from_utf8(out).unwrap(), formatted(t, &pos, &pc, vel, q));
        }
    }

    #[test]
    fn the_calendar_round_trips_and_knows_the_gps_epoch() {
        assert_eq!(days_from_civil(1980, 1, 6), GPS_EPOCH_DAYS);
        assert_eq!(days_from_civil(1970, 1, 1), 0);
        for z in [-1000, 0, 3657, 17_532, 20_000, 40_000] {
            let (y, m, d) = civil_from_days(z);
            assert_eq!(days_from_civil(y, m, d), z);
        }
    }

    #[test]
    fn utc_and_gpst_differ_by_the_leap_seconds_of_the_date() {
        // 2017-01-01 on: 18 s; 2016-12-31: 17 s; 1980-01-06: 0
        let at = |y, m, d| days_from_civil(y, m, d) as f64 * 86_400.0 + 3600.0;
        assert_eq!(gps_minus_utc(at(2025, 8, 28)), 18.0);
        assert_eq!(gps_minus_utc(at(2016, 12, 31)), 17.0);
        assert_eq!(gps_minus_utc(at(1980, 1, 6)), 0.0);
        let g = seconds_of_week(TimeSystem::Gpst, (2025, 8, 28), (17, 30, 39.749));
        let u = seconds_of_week(TimeSystem::Utc, (2025, 8, 28), (17, 30, 39.749));
        let j = seconds_of_week(TimeSystem::Jst, (2025, 8, 29), (2, 30, 39.749));
        assert!((u - g - 18.0).abs() < 1e-9 && (j - u).abs() < 1e-9, "{g} {u} {j}");
        // 2025-08-28 is a Thursday: 4 days into the GPS week
        assert!((g - (4.0 * 86_400.0 + 17.0 * 3600.0 + 30.0 * 60.0 + 39.749)).abs() < 1e-9);
    }
}
