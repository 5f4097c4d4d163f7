//! NMEA 0183 GNSS logs: GGA for the position and its quality, GST for its σ, RMC (or ZDA)
//! for the date. Sentences of one time of day make one epoch; the time, UTC in NMEA,
//! is put on the GPST seconds-of-week scale of the other formats (the leap seconds of
//! its date added). Every sentence's checksum is verified; other sentences (GSA, GSV,
//! VTG, …) are read past. Velocities are not taken from NMEA (RMC and VTG give the
//! horizontal speed without its σ and no vertical one): the epochs are position fixes.
//!
//! GGA's fix quality maps to the RTKLIB qualities whose σ factors and drops apply
//! ([`super::rtklib::QualityFactors`]): 4 RTK fix → fix, 5 RTK float → float, 2 DGPS →
//! dgps, 1 GPS → single, 9 WAAS/SBAS → sbas; 0 (invalid), 6 (dead reckoning), 7 (manual)
//! and 8 (simulator) are not fixes and are dropped.

use nalgebra::Vector3;

use super::lines::LineErrorKind;
use super::rtklib::QualityFactors;
use ::gnss::calendar::{seconds_of_week, TimeSystem};
use ins_gnss_core::gnss::GnssEpoch;
use ins_gnss_core::GeoPos;

/// One sentence's fields (after `$` and before `*`), checksum verified.
pub fn fields(line: &str) -> Result<Vec<&str>, LineErrorKind> {
    let bad = |m: String| LineErrorKind::WrongUnits(m);
    let body = line.trim().strip_prefix('$').ok_or_else(|| bad("not an NMEA sentence".into()))?;
    let (data, sum) = body
        .rsplit_once('*')
        .ok_or_else(|| bad("NMEA sentence without a checksum (`*hh`)".into()))?;
    let want = u8::from_str_radix(sum.trim(), 16)
        .map_err(|_| bad(format!("NMEA checksum `{sum}` is not two hex digits")))?;
    let got = data.bytes().fold(0u8, |a, b| a ^ b);
    if got != want {
        return Err(bad(format!("NMEA checksum {want:02X} but the sentence sums to {got:02X}")));
    }
    Ok(data.split(',').collect())
}

/// `ddmm.mmmm` / `dddmm.mmmm` with its hemisphere, in degrees.
fn angle(v: &str, hemi: &str, degree_digits: usize) -> Option<f64> {
    if v.len() < degree_digits + 2 {
        return None;
    }
    // (`get`: a byte that is not a character boundary is bad input, not a panic)
    let d: f64 = v.get(..degree_digits)?.parse().ok()?;
    let m: f64 = v.get(degree_digits..)?.parse().ok()?;
    if !(0.0..60.0).contains(&m) {
        return None;
    }
    let a = d + m / 60.0;
    match hemi {
        "N" | "E" => Some(a),
        "S" | "W" => Some(-a),
        _ => None,
    }
}

/// `hhmmss.sss` in seconds of the day.
fn time_of_day(v: &str) -> Option<f64> {
    if v.len() < 6 {
        return None;
    }
    let h: f64 = v.get(..2)?.parse().ok()?;
    let m: f64 = v.get(2..4)?.parse().ok()?;
    let s: f64 = v.get(4..)?.parse().ok()?;
    (h < 24.0 && m < 60.0 && s < 61.0).then_some(h * 3600.0 + m * 60.0 + s)
}

/// The epoch being gathered.
#[derive(Clone, Debug, Default)]
struct Pending {
    tod: f64,
    /// lat, lon (deg), ellipsoidal height (m), GGA quality.
    gga: Option<(f64, f64, f64, u8)>,
    /// The GGA's horizontal dilution of precision.
    hdop: Option<f64>,
    /// σ north, east, down from GST.
    gst: Option<Vector3<f64>>,
    /// The date of this time of day.
    date: Option<(i64, i64, i64)>,
    /// True heading from HDT or THS, deg.
    heading: Option<f64>,
}

/// The NMEA state of a GNSS reader: the date, and the epoch being gathered.
#[derive(Clone, Debug, Default)]
pub struct NmeaState {
    /// (year, month, day) from the last RMC or ZDA.
    date: Option<(i64, i64, i64)>,
    pending: Option<Pending>,
    last_tod: Option<f64>,
    /// The date when `last_tod` was seen.
    date_at_last: Option<(i64, i64, i64)>,
    /// Epochs whose GGA quality was dropped, by GGA quality (0–9).
    pub dropped: [usize; 10],
    /// Fixes whose σ came from their HDOP ([`hdop_sigma`]): no GST, none configured.
    pub sigma_from_hdop: usize,
}

/// The range error (UERE, m) a fix type's HDOP is scaled by when the log states no σ, by
/// the RTKLIB quality of [`NmeaState`]'s map (1 fix, 2 float, 3 SBAS, 4 DGPS, 5 single):
/// RTK fixed 0.02 m, float 0.3 m, SBAS and DGPS 1 m, a single point 3 m (a u-blox M8's
/// 2.5 m CEP at HDOP 1 is 3 m horizontal RMS). A prior: the run learns the scale from the
/// fixes' innovations.
pub const UERE: [f64; 6] = [0.0, 0.02, 0.3, 1.0, 1.0, 3.0];

/// σ (N, E, D) of a fix with HDOP `hdop` of RTKLIB quality `rtk` (1–5): `HDOP · UERE / √2`
/// on each horizontal axis, twice that down (a vertical DOP near twice the horizontal
/// per-axis one, as over open sky).
pub fn hdop_sigma(rtk: usize, hdop: f64) -> Vector3<f64> {
    let h = hdop * UERE[rtk.min(5)] / core::f64::consts::SQRT_2;
    Vector3::new(h, h, 2.0 * h)
}

impl NmeaState {
    /// A moving-base receiver's true heading: HDT (heading, `T`) or THS (heading, mode;
    /// only `A`, autonomous, is a measurement). Neither has a time: the epoch being
    /// gathered is theirs.
    fn heading(&mut self, kind: &str, f: &[&str]) -> Result<Option<GnssEpoch>, LineErrorKind> {
        let valid = match kind {
            "HDT" => f.get(2).is_none_or(|m| m.is_empty() || *m == "T"),
            _ => f.get(2).is_some_and(|m| *m == "A"),
        };
        let v = f.get(1).and_then(|v| v.parse::<f64>().ok());
        match (v, self.pending.as_mut()) {
            (Some(v), Some(p)) if valid => {
                if !(0.0..=360.0).contains(&v) {
                    return Err(LineErrorKind::WrongUnits(format!(
                        "{}: heading outside 0–360°",
                        f[0]
                    )));
                }
                p.heading = Some(v);
            }
            _ => {}
        }
        Ok(None)
    }

    /// Takes one line; an epoch is returned when a sentence of a later time starts the
    /// next one. `sigma` replaces a missing GST.
    pub fn push(
        &mut self,
        line: &str,
        quality: &QualityFactors,
        sigma: Option<Vector3<f64>>,
    ) -> Result<Option<GnssEpoch>, LineErrorKind> {
        let f = fields(line)?;
        let kind = f[0].get(2..).unwrap_or("");
        let bad = |m: &str| LineErrorKind::WrongUnits(format!("{}: {m}", f[0]));
        match kind {
            "RMC" | "ZDA" => {
                let date = date_of(kind, &f);
                let tod = f.get(1).and_then(|t| time_of_day(t));
                let out = match tod {
                    Some(tod) => self.start(tod, quality, sigma)?,
                    None => None,
                };
                if let Some((y, m, d)) = date {
                    if !(1..=12).contains(&m) || !(1..=31).contains(&d) {
                        return Err(bad("date out of range"));
                    }
                    self.date = Some((y, m, d));
                    self.date_at_last = self.date;
                    if let (Some(p), Some(_)) = (self.pending.as_mut(), tod) {
                        p.date = self.date;
                    }
                }
                Ok(out)
            }
            "GGA" => {
                if f.len() < 12 {
                    return Err(bad("fewer than 12 fields"));
                }
                let tod = time_of_day(f[1]).ok_or_else(|| bad("time is not hhmmss.ss"))?;
                let q: u8 = f[6].parse().map_err(|_| bad("fix quality is not a number"))?;
                let out = self.start(tod, quality, sigma)?;
                if q != 0 {
                    let lat = angle(f[2], f[3], 2).ok_or_else(|| bad("latitude"))?;
                    let lon = angle(f[4], f[5], 3).ok_or_else(|| bad("longitude"))?;
                    let alt: f64 = f[9].parse().map_err(|_| bad("altitude"))?;
                    let sep: f64 = f[11].parse().unwrap_or(0.0);
                    let p = self.pending.get_or_insert_with(Default::default);
                    p.gga = Some((lat, lon, alt + sep, q));
                    p.hdop = f[8].parse::<f64>().ok().filter(|h| h.is_finite() && *h > 0.0);
                } else {
                    self.dropped[0] += 1;
                }
                Ok(out)
            }
            "GST" => {
                if f.len() < 9 {
                    return Err(bad("fewer than 9 fields"));
                }
                let tod = time_of_day(f[1]).ok_or_else(|| bad("time is not hhmmss.ss"))?;
                let out = self.start(tod, quality, sigma)?;
                let v = |i: usize| f[i].parse::<f64>().ok().filter(|v| *v > 0.0);
                if let (Some(n), Some(e), Some(d)) = (v(6), v(7), v(8)) {
                    let p = self.pending.get_or_insert_with(Default::default);
                    p.gst = Some(Vector3::new(n, e, d));
                }
                Ok(out)
            }
            // a moving-base receiver's true heading: HDT (heading, `T`) or THS (heading,
            // mode; only `A`, autonomous, is a measurement). Neither has a time: the
            // epoch being gathered is theirs.
            "HDT" | "THS" => self.heading(kind, &f),
            _ => Ok(None),
        }
    }

    /// A sentence of time `tod`: a later time closes the pending epoch.
    fn start(
        &mut self,
        tod: f64,
        quality: &QualityFactors,
        sigma: Option<Vector3<f64>>,
    ) -> Result<Option<GnssEpoch>, LineErrorKind> {
        let same = self.pending.as_ref().is_some_and(|p| (p.tod - tod).abs() < 1e-6);
        if same {
            return Ok(None);
        }
        let out = self.finish(quality, sigma)?;
        // after midnight with no new date since: the next day
        if let (Some(last), Some((y, m, d))) = (self.last_tod, self.date)
            && tod + 43_200.0 < last
            && self.date == self.date_at_last
        {
            let days = ::gnss::calendar::days_from_civil(y, m, d) + 1;
            self.date = Some(::gnss::calendar::civil_from_days(days));
        }
        self.last_tod = Some(tod);
        self.date_at_last = self.date;
        self.pending = Some(Pending { tod, date: self.date, ..Default::default() });
        Ok(out)
    }

    /// The pending epoch, complete (at a new time or the end of the file).
    pub fn finish(
        &mut self,
        quality: &QualityFactors,
        sigma: Option<Vector3<f64>>,
    ) -> Result<Option<GnssEpoch>, LineErrorKind> {
        let Some(p) = self.pending.take() else { return Ok(None) };
        let Some((lat, lon, h, q)) = p.gga else { return Ok(None) };
        let rtk = match q {
            4 => 1,
            5 => 2,
            9 => 3,
            2 | 3 => 4,
            1 => 5,
            _ => 0,
        };
        if rtk == 0 || quality.drop[rtk] {
            self.dropped[q.min(9) as usize] += 1;
            return Ok(None);
        }
        let Some((y, m, d)) = p.date else {
            return Err(LineErrorKind::WrongUnits(
                "a GGA fix before any date: NMEA logs need an RMC or ZDA sentence (GGA has \
                 the time of day only)"
                    .into(),
            ));
        };
        // the σ: GST's or the configuration's (times the quality's factor), else the
        // HDOP's prior (the fix type's own range error, no factor)
        let s =
            match (p.gst.or(sigma), p.hdop) {
                (Some(s), _) => s * quality.factor[rtk],
                (None, Some(hdop)) => {
                    self.sigma_from_hdop += 1;
                    hdop_sigma(rtk, hdop)
                }
                (None, None) => return Err(LineErrorKind::WrongUnits(
                    "a fix without its σ: the log has no GST sentence and the GGA no HDOP; set \
                     `gnss.position_std`"
                        .into(),
                )),
            };
        let hh = (p.tod / 3600.0).floor();
        let mm = ((p.tod - hh * 3600.0) / 60.0).floor();
        let ss = p.tod - hh * 3600.0 - mm * 60.0;
        let t = seconds_of_week(TimeSystem::Utc, (y, m, d), (hh as i64, mm as i64, ss));
        let mut e = GnssEpoch::new(t, GeoPos::from_degrees(lat, lon, h), s, None);
        e.heading = p.heading.map(|deg| ins_gnss_core::heading::AntennaHeading {
            t,
            heading: ins_gnss_core::heading::wrap(deg.to_radians()),
            heading_std: None,
            pitch: None,
            length: None,
        });
        Ok(Some(e))
    }
}

/// The date (year, month, day) of an RMC (`ddmmyy`, field 9) or ZDA (fields 2–4)
/// sentence's fields `f`, when it has one.
fn date_of(kind: &str, f: &[&str]) -> Option<(i64, i64, i64)> {
    if kind == "RMC" {
        let d = f.get(9).copied().unwrap_or("");
        let p = |i: usize| d.get(i..i + 2).and_then(|x| x.parse::<i64>().ok());
        match (p(0), p(2), p(4)) {
            (Some(dd), Some(mm), Some(yy)) => {
                Some((if yy < 80 { 2000 + yy } else { 1900 + yy }, mm, dd))
            }
            _ => None,
        }
    } else {
        let p = |i: usize| f.get(i).and_then(|x| x.parse::<i64>().ok());
        match (p(2), p(3), p(4)) {
            (Some(dd), Some(mm), Some(yyyy)) => Some((yyyy, mm, dd)),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checksums_are_verified() {
        // the NMEA standard's example sentence
        let ok = "$GPGGA,092750.000,5321.6802,N,00630.3372,W,1,8,1.03,61.7,M,55.2,M,,*76";
        assert!(fields(ok).is_ok());
        let bad = ok.replace("*76", "*77");
        assert!(fields(&bad).is_err());
        assert!(fields("$GPGGA,1,2").is_err());
    }

    #[test]
    fn text_that_is_not_ascii_is_an_error_not_a_panic() {
        let with_sum = |body: &str| {
            let c = body.bytes().fold(0u8, |a, b| a ^ b);
            format!("${body}*{c:02X}")
        };
        let q = QualityFactors::default();
        for body in [
            "GPRMC,092750.000,A,5321.6802,N,00630.3372,W,0.02,31.66,2é0825,,,A",
            "GPGGA,0é2750.000,5321.6802,N,00630.3372,W,4,8,1.03,61.7,M,55.2,M,,",
            "GPGGA,092750.000,5é21.6802,N,00630.3372,W,4,8,1.03,61.7,M,55.2,M,,",
            "GPGGA,092750.000,5321.6802,N,00é30.3372,W,4,8,1.03,61.7,M,55.2,M,,",
            "GPGST,0é2750.000,1.0,0.02,0.01,12.0,0.010,0.020,0.030",
        ] {
            let mut s = NmeaState::default();
            let r = s.push(&with_sum(body), &q, None);
            assert!(r.is_err() || r.unwrap().is_none(), "{body}");
        }
    }

    #[test]
    fn a_gga_gst_rmc_epoch() {
        let q = QualityFactors::default();
        let mut s = NmeaState::default();
        let with_sum = |body: &str| {
            let c = body.bytes().fold(0u8, |a, b| a ^ b);
            format!("${body}*{c:02X}")
        };
        let lines = [
            "GPRMC,092750.000,A,5321.6802,N,00630.3372,W,0.02,31.66,280825,,,A",
            "GPGGA,092750.000,5321.6802,N,00630.3372,W,4,8,1.03,61.7,M,55.2,M,,",
            "GPGST,092750.000,1.0,0.02,0.01,12.0,0.010,0.020,0.030",
            "GPGGA,092751.000,5321.6802,N,00630.3372,W,5,8,1.03,61.7,M,55.2,M,,",
        ];
        let mut out = Vec::new();
        for l in lines {
            if let Some(e) = s.push(&with_sum(l), &q, None).unwrap() {
                out.push(e);
            }
        }
        assert_eq!(out.len(), 1);
        let e = out[0];
        assert!((e.pos.lat.to_degrees() - (53.0 + 21.6802 / 60.0)).abs() < 1e-12);
        assert!((e.pos.lon.to_degrees() + (6.0 + 30.3372 / 60.0)).abs() < 1e-12);
        assert!((e.pos.h - 116.9).abs() < 1e-9);
        assert!((e.pos_std - Vector3::new(0.01, 0.02, 0.03)).abs().max() < 1e-12);
        // 2025-08-28 09:27:50 UTC = 09:28:08 GPST, Thursday
        let t = 4.0 * 86_400.0 + 9.0 * 3600.0 + 28.0 * 60.0 + 8.0;
        assert!((e.t - t).abs() < 1e-9, "{}", e.t);
        // the float fix without GST: its σ from the configuration, doubled
        let last = s.finish(&q, Some(Vector3::new(0.1, 0.1, 0.2))).unwrap().unwrap();
        assert!((last.pos_std - Vector3::new(0.2, 0.2, 0.4)).abs().max() < 1e-12);
    }

    #[test]
    fn hdt_and_ths_give_the_epoch_its_heading() {
        let q = QualityFactors::default();
        let sigma = Some(Vector3::new(0.02, 0.02, 0.04));
        let with_sum = |body: &str| {
            let c = body.bytes().fold(0u8, |a, b| a ^ b);
            format!("${body}*{c:02X}")
        };
        let lines = [
            "GPRMC,092750.000,A,5321.6802,N,00630.3372,W,0.02,31.66,280825,,,A",
            "GPGGA,092750.000,5321.6802,N,00630.3372,W,4,8,1.03,61.7,M,55.2,M,,",
            "GPHDT,271.25,T",
            "GPGGA,092751.000,5321.6802,N,00630.3372,W,4,8,1.03,61.7,M,55.2,M,,",
            "GNTHS,12.5,V",
            "GPGGA,092752.000,5321.6802,N,00630.3372,W,4,8,1.03,61.7,M,55.2,M,,",
            "GNTHS,12.5,A",
        ];
        let mut st = NmeaState::default();
        let mut out = Vec::new();
        for l in lines {
            out.extend(st.push(&with_sum(l), &q, sigma).unwrap());
        }
        out.extend(st.finish(&q, sigma).unwrap());
        assert_eq!(out.len(), 3);
        let h = out[0].heading.expect("HDT");
        assert!((h.heading.to_degrees() + 88.75).abs() < 1e-9, "{}", h.heading.to_degrees());
        assert_eq!(h.t, out[0].t);
        assert!(out[1].heading.is_none(), "THS mode V is not a measurement");
        assert!((out[2].heading.expect("THS").heading.to_degrees() - 12.5).abs() < 1e-9);
        // out of range: an error at its line
        let mut st = NmeaState::default();
        st.push(&with_sum(lines[0]), &q, sigma).unwrap();
        st.push(&with_sum(lines[1]), &q, sigma).unwrap();
        assert!(st.push(&with_sum("GPHDT,361.0,T"), &q, sigma).is_err());
    }
}
