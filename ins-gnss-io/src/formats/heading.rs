//! The reader of a moving-base receiver's headings (`data.heading`): RTKLIB's moving-base
//! solution in ENU (the baseline from the moving base to the rover), NMEA `HDT`/`THS`
//! (timed by the log's GGA and RMC/ZDA), or columns `t heading [σ [pitch σ]]` (deg).

use super::*;
use crate::rtklib::{covariance, field, split_line};
use ::gnss::calendar::TimeSystem;
use ins_gnss_core::heading::{wrap, AntennaHeading};

/// The headings of a file and what was left out.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Headings {
    /// In time order.
    pub list: Vec<AntennaHeading>,
    /// RTKLIB epochs whose quality is neither fix (1) nor float (2): a single point's
    /// baseline has no heading.
    pub dropped: usize,
    /// Malformed lines skipped under [`BadLinePolicy::Skip`].
    pub skipped: SkipCounts,
}

/// Where the fields of an RTKLIB ENU solution sit.
#[derive(Clone, Copy, Debug, PartialEq)]
struct EnuHeader {
    system: TimeSystem,
    /// e, n, u baseline; Q; sde, sdn, sdu, sden, sdnu, sdue (after the two time fields).
    enu: usize,
    q: Option<usize>,
    sd: Option<usize>,
}

impl EnuHeader {
    fn parse(line: &str) -> Option<Self> {
        let body = line.trim_start().strip_prefix('%')?;
        let mut names = body.split_whitespace();
        let system = TimeSystem::from_label(names.next()?)?;
        let names: Vec<&str> = names.collect();
        let at = |n: &str| names.iter().position(|x| x.starts_with(n));
        Some(Self { system, enu: at("e-baseline(")?, q: at("Q"), sd: at("sde(") })
    }
}

/// Heading and elevation (rad), and their σ where the covariance is known.
type Angles = (f64, f64, Option<(f64, f64)>);

/// Heading and elevation (rad) of an ENU baseline with their σ from its covariance
/// (E, N, U order); `None` when the baseline is (nearly) vertical or null.
fn baseline_angles(enu: &Vector3<f64>, cov: Option<&nalgebra::Matrix3<f64>>) -> Option<Angles> {
    if !ins_gnss_core::heading::has_horizontal_direction(enu) {
        return None;
    }
    let (e, n, u) = (enu.x, enu.y, enu.z);
    let h2 = e * e + n * n;
    let l2 = h2 + u * u;
    let h = h2.sqrt();
    let psi = e.atan2(n);
    let theta = u.atan2(h);
    let sd = cov.map(|c| {
        // ψ = atan2(e, n): ∂ψ = [n, −e, 0]/h²; θ = atan2(u, h): ∂θ = [−u e/h, −u n/h, h]/l²
        let g_psi = Vector3::new(n, -e, 0.0) / h2;
        let g_theta = Vector3::new(-u * e / h, -u * n / h, h) / l2;
        ((g_psi.dot(&(c * g_psi))).max(0.0).sqrt(), (g_theta.dot(&(c * g_theta))).max(0.0).sqrt())
    });
    Some((psi, theta, sd))
}

/// Reads a heading file (format detected: an RTKLIB header naming `e-baseline(m)`, NMEA
/// sentences, or columns).
pub fn read_headings(path: &Path, policy: BadLinePolicy) -> Result<Headings, LineError> {
    let mut head = [0u8; 2];
    let n = std::io::Read::read(&mut open(path)?, &mut head).unwrap_or(0);
    if n == 2 && head == [0xB5, 0x62] {
        // a u-blox log: its NAV-RELPOSNED (fixed and float ambiguities)
        let (list, dropped) = ::gnss::ubx::read_relposned(path, false).map_err(|e| LineError {
            path: path.to_path_buf(),
            line: 0,
            kind: LineErrorKind::Io(e.message),
        })?;
        if list.is_empty() {
            return Err(LineError {
                path: path.to_path_buf(),
                line: 0,
                kind: LineErrorKind::WrongUnits(format!(
                    "a u-blox log without a valid NAV-RELPOSNED heading ({dropped} without a \
                     valid relative position and heading): a moving-base rover's log (F9P, \
                     protocol 27 or later) is needed"
                )),
            });
        }
        return Ok(Headings { list, dropped, skipped: SkipCounts::default() });
    }
    let mut lines = NumericLines::new(open(path)?, path);
    let comments = lines.leading_comments()?;
    if let Some(h) = comments.iter().rev().find_map(|l| EnuHeader::parse(l)) {
        return read_enu(lines, h, policy);
    }
    if comments.iter().any(|l| l.contains("latitude(") || l.contains("x-ecef(")) {
        return Err(lines.error(LineErrorKind::WrongUnits(
            "an RTKLIB solution in geodetic or ECEF coordinates: a heading needs the \
             moving-base baseline, RTKLIB's `out-solformat = enu` with `pos1-posmode = \
             movingbase`"
                .into(),
        )));
    }
    if lines.peek_byte()? == Some(b'$') {
        return read_nmea(path, policy);
    }
    read_columns(lines, policy)
}

fn read_enu(
    mut lines: NumericLines<Input>,
    h: EnuHeader,
    policy: BadLinePolicy,
) -> Result<Headings, LineError> {
    let mut out = Headings::default();
    let mut prev = None;
    while let Some(text) = lines.next_text()? {
        let step = enu_line(&h, text, prev);
        match step {
            Ok(Some(m)) => {
                prev = Some(m.t);
                out.list.push(m);
            }
            Ok(None) => out.dropped += 1,
            Err(kind) if policy == BadLinePolicy::Skip => count(&mut out.skipped, &kind),
            Err(kind) => return Err(lines.error(kind)),
        }
    }
    if out.list.is_empty() && out.dropped == 0 {
        return Err(LineError {
            path: lines.path().to_path_buf(),
            line: 0,
            kind: LineErrorKind::Empty,
        });
    }
    Ok(out)
}

fn enu_line(
    h: &EnuHeader,
    line: &str,
    prev: Option<f64>,
) -> Result<Option<AntennaHeading>, LineErrorKind> {
    let (t, fields) = split_line(h.system, line, 5)?;
    let num = |i: usize| field(&fields, i);
    if let Some(q) = h.q {
        let q = num(q)?;
        if q != 1.0 && q != 2.0 {
            return Ok(None);
        }
    }
    check_time(prev, t)?;
    let enu = Vector3::new(num(h.enu)?, num(h.enu + 1)?, num(h.enu + 2)?);
    // RTKLIB: sde sdn sdu sden sdnu sdue, the last three signed square roots
    let cov = match h.sd {
        Some(i) => Some(covariance(&(0..6).map(|k| num(i + k)).collect::<Result<Vec<_>, _>>()?)),
        None => None,
    };
    let Some((psi, theta, sd)) = baseline_angles(&enu, cov.as_ref()) else {
        return Err(LineErrorKind::WrongUnits(
            "the baseline is vertical or null: no heading".into(),
        ));
    };
    Ok(Some(AntennaHeading {
        t,
        heading: psi,
        heading_std: sd.map(|s| s.0),
        pitch: Some((theta, sd.map(|s| s.1))),
        length: Some(enu.norm()),
    }))
}

fn read_nmea(path: &Path, policy: BadLinePolicy) -> Result<Headings, LineError> {
    // the fixes' σ does not matter here: any value lets a fix without GST through
    let mut r = GnssReader::open(path, policy)?
        .with_format(GnssFormat::Nmea)
        .with_default_sigma(Some(Vector3::repeat(1.0)));
    let mut out = Headings::default();
    while let Some(e) = r.next_epoch()? {
        match e.heading {
            Some(h) => out.list.push(h),
            None => out.dropped += 1,
        }
    }
    out.skipped = r.skipped;
    Ok(out)
}

fn read_columns(
    mut lines: NumericLines<Input>,
    policy: BadLinePolicy,
) -> Result<Headings, LineError> {
    let mut out = Headings::default();
    let mut prev = None;
    while next_record(&mut lines, policy, &mut out.skipped, out.list.len())? {
        let v = lines.values();
        let result = match v.len() {
            2 if !(-360.0..=360.0).contains(&v[1]) => {
                Err(LineErrorKind::WrongUnits("heading beyond ±360° (degrees expected)".into()))
            }
            // no σ: the configuration's (`gnss.heading.std`)
            2 => check_time(prev, v[0]).map(|_| AntennaHeading {
                t: v[0],
                heading: wrap(v[1].to_radians()),
                heading_std: None,
                pitch: None,
                length: None,
            }),
            3 | 5 => {
                let bad = v[2] <= 0.0 || (v.len() == 5 && v[4] <= 0.0);
                if bad {
                    Err(LineErrorKind::WrongUnits("standard deviations must be positive".into()))
                } else if !(-360.0..=360.0).contains(&v[1]) || (v.len() == 5 && v[3].abs() > 90.0) {
                    Err(LineErrorKind::WrongUnits(
                        "heading beyond ±360° or pitch beyond ±90° (degrees expected)".into(),
                    ))
                } else {
                    check_time(prev, v[0]).map(|_| AntennaHeading {
                        t: v[0],
                        heading: wrap(v[1].to_radians()),
                        heading_std: Some(v[2].to_radians()),
                        pitch: (v.len() == 5).then(|| (v[3].to_radians(), Some(v[4].to_radians()))),
                        length: None,
                    })
                }
            }
            n => Err(LineErrorKind::ColumnCount { expected: vec![2, 3, 5], found: n }),
        };
        match result {
            Ok(m) => {
                prev = Some(m.t);
                out.list.push(m);
            }
            Err(kind) if policy == BadLinePolicy::Skip => count(&mut out.skipped, &kind),
            Err(kind) => return Err(lines.error(kind)),
        }
    }
    Ok(out)
}

/// Writes headings as columns `t heading [σ [pitch σ]]` (deg), as [`read_headings`] reads
/// them: a heading without its σ as `t heading` (the reader then takes the
/// configuration's), an elevation only with both σ.
pub fn write_headings<W: Write>(w: &mut W, list: &[AntennaHeading]) -> std::io::Result<()> {
    for m in list {
        write!(w, "{:.4} {:.6}", m.t, m.heading.to_degrees())?;
        if let Some(s) = m.heading_std {
            write!(w, " {:.6}", s.to_degrees())?;
            if let Some((p, Some(ps))) = m.pitch {
                write!(w, " {:.6} {:.6}", p.to_degrees(), ps.to_degrees())?;
            }
        }
        writeln!(w)?;
    }
    Ok(())
}

/// Attaches each heading to the fix at its time (within 1 ms); returns how many found no
/// fix.
pub fn attach_headings(fixes: &mut [GnssEpoch], headings: &[AntennaHeading]) -> usize {
    let mut queue = ins_gnss_core::heading::HeadingQueue::new(headings.to_vec());
    for f in fixes.iter_mut() {
        if let Some(m) = queue.take(f.t) {
            f.heading = Some(m);
        }
    }
    queue.unmatched()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp(name: &str, text: &str) -> std::path::PathBuf {
        let p = std::env::temp_dir().join(format!("heading-{}-{name}", std::process::id()));
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn rtklib_enu_baseline() {
        let text = "% program   : RTKLIB\n\
            %  GPST                  e-baseline(m)   n-baseline(m)   u-baseline(m)   Q  ns   sde(m)   sdn(m)   sdu(m)  sden(m)  sdnu(m)  sdue(m) age(s)  ratio\n\
            2024/01/02 00:00:01.000    0.7071  0.7071  0.0100  1  12  0.0020  0.0020  0.0040  0.0000  0.0000  0.0000  0.0  9.9\n\
            2024/01/02 00:00:02.000    0.0000  1.0000  0.0000  5  12  1.0  1.0  1.0  0.0  0.0  0.0  0.0  0.0\n\
            2024/01/02 00:00:03.000   -1.0000  0.0000  0.0000  2  12  0.0100  0.0100  0.0100  0.0000  0.0000  0.0000  0.0  1.2\n";
        let p = temp("enu.pos", text);
        let h = read_headings(&p, BadLinePolicy::Error).unwrap();
        assert_eq!(h.list.len(), 2);
        assert_eq!(h.dropped, 1);
        let a = h.list[0];
        assert!((a.heading.to_degrees() - 45.0).abs() < 1e-9);
        // σ across a 1 m baseline of 2 mm: 2 mrad
        assert!((a.heading_std.unwrap() - 0.002).abs() < 1e-6, "{:?}", a.heading_std);
        assert!((a.pitch.unwrap().0 - 0.01f64.atan2(1.0)).abs() < 1e-4);
        assert!((h.list[1].heading.to_degrees() + 90.0).abs() < 1e-9);
        assert!(h.list[1].t - a.t == 2.0);
        std::fs::remove_file(p).ok();
        let geo = temp("llh.pos", "%  GPST   latitude(deg) longitude(deg)  height(m)   Q  ns\n");
        let e = read_headings(&geo, BadLinePolicy::Error).unwrap_err();
        assert!(e.to_string().contains("movingbase"), "{e}");
        std::fs::remove_file(geo).ok();
    }

    /// A NAV-RELPOSNED version 1 frame (64-byte payload) with its checksum.
    fn relposned(
        itow_ms: u32,
        ned_cm: [i32; 3],
        heading_deg: f64,
        acc_deg: f64,
        flags: u32,
    ) -> Vec<u8> {
        let mut p = vec![1u8, 0, 0, 0];
        p.extend(itow_ms.to_le_bytes());
        for c in ned_cm {
            p.extend(c.to_le_bytes());
        }
        let len = ((ned_cm[0] as f64).hypot(ned_cm[1] as f64)).hypot(ned_cm[2] as f64);
        p.extend((len.round() as i32).to_le_bytes());
        p.extend(((heading_deg * 1e5).round() as i32).to_le_bytes());
        p.extend([0u8; 4]); // reserved
        p.extend([0u8; 4]); // hp n, e, d, length
        for acc_mm10 in [20u32, 20, 40, 20] {
            p.extend(acc_mm10.to_le_bytes());
        }
        p.extend(((acc_deg * 1e5).round() as u32).to_le_bytes());
        p.extend([0u8; 4]);
        p.extend(flags.to_le_bytes());
        assert_eq!(p.len(), 64);
        let mut frame = vec![0xB5, 0x62, 0x01, 0x3C, 64, 0];
        frame.extend(&p);
        let (mut a, mut b) = (0u8, 0u8);
        for x in &frame[2..] {
            a = a.wrapping_add(*x);
            b = b.wrapping_add(a);
        }
        frame.extend([a, b]);
        frame
    }

    #[test]
    fn ublox_relposned() {
        // fixed (carrSoln 2), float (1), and one without a valid heading
        let ok = 0x1 | 0x4 | (2 << 3) | 0x100;
        let float = 0x1 | 0x4 | (1 << 3) | 0x100;
        let mut bytes = relposned(100_000, [70, 70, 5], 45.0, 0.3, ok);
        bytes.extend(relposned(100_200, [0, -100, 0], 270.0, 0.5, float));
        bytes.extend(relposned(100_400, [0, -100, 0], 270.0, 0.5, 0x1 | 0x4 | (2 << 3)));
        let p = temp("rover.ubx", "");
        std::fs::write(&p, &bytes).unwrap();
        let h = read_headings(&p, BadLinePolicy::Error).unwrap();
        std::fs::remove_file(&p).ok();
        assert_eq!(h.list.len(), 2);
        assert_eq!(h.dropped, 1);
        let a = h.list[0];
        assert!((a.t - 100.0).abs() < 1e-12);
        assert!((a.heading.to_degrees() - 45.0).abs() < 1e-9);
        assert!((a.heading_std.unwrap().to_degrees() - 0.3).abs() < 1e-9);
        // 5 cm down over 0.99 m: the baseline dips
        assert!(a.pitch.unwrap().0 < 0.0);
        assert!((h.list[1].heading.to_degrees() + 90.0).abs() < 1e-9);
    }

    #[test]
    fn columns_and_their_errors() {
        let p = temp("cols.txt", "10.0 359.5 0.2\n10.2 0.5 0.2 1.0 0.4\n");
        let h = read_headings(&p, BadLinePolicy::Error).unwrap();
        assert_eq!(h.list.len(), 2);
        assert!((h.list[0].heading.to_degrees() + 0.5).abs() < 1e-9);
        assert!((h.list[1].pitch.unwrap().0.to_degrees() - 1.0).abs() < 1e-9);
        std::fs::remove_file(p).ok();
        let p = temp("bad.txt", "10.0 30 0.2\n10.0 31 0.2\n");
        let e = read_headings(&p, BadLinePolicy::Error).unwrap_err();
        assert_eq!(e.line, 2, "{e}");
        std::fs::remove_file(p).ok();
        let p = temp("rad.txt", "10.0 0.5 0.2 95 0.1\n");
        assert!(read_headings(&p, BadLinePolicy::Error).is_err());
        std::fs::remove_file(p).ok();
    }

    #[test]
    fn written_headings_read_back() {
        let m = |t: f64, std: Option<f64>, pitch: Option<(f64, Option<f64>)>| AntennaHeading {
            t,
            heading: 0.5,
            heading_std: std,
            pitch,
            length: None,
        };
        let list = [
            m(1.0, Some(0.003), Some((0.01, Some(0.006)))),
            m(2.0, None, Some((0.01, Some(0.006)))),
            m(3.0, Some(0.003), Some((0.01, None))),
        ];
        let mut text = Vec::new();
        write_headings(&mut text, &list).unwrap();
        let p = temp("roundtrip.txt", std::str::from_utf8(&text).unwrap());
        let h = read_headings(&p, BadLinePolicy::Error).unwrap();
        std::fs::remove_file(p).ok();
        assert_eq!(h.list.len(), 3);
        assert!((h.list[0].pitch.unwrap().1.unwrap() - 0.006).abs() < 1e-8);
        assert!(h.list[1].heading_std.is_none() && h.list[1].pitch.is_none());
        assert!(h.list[2].heading_std.is_some() && h.list[2].pitch.is_none());
        assert!(h.list.iter().all(|x| (x.heading - 0.5).abs() < 1e-8));
    }

    #[test]
    fn headings_attach_to_fixes_at_their_time() {
        let pos = GeoPos::from_degrees(30.0, 114.0, 20.0);
        let mut fixes: Vec<GnssEpoch> =
            (0..4).map(|k| GnssEpoch::new(k as f64, pos, Vector3::repeat(0.1), None)).collect();
        let m = |t: f64| AntennaHeading {
            t,
            heading: 0.1,
            heading_std: None,
            pitch: None,
            length: None,
        };
        let lost = attach_headings(&mut fixes, &[m(0.0005), m(1.5), m(3.0)]);
        assert_eq!(lost, 1);
        assert!(fixes[0].heading.is_some() && fixes[3].heading.is_some());
        assert!(fixes[1].heading.is_none() && fixes[2].heading.is_none());
        assert_eq!(fixes[0].heading.unwrap().t, 0.0);
    }
}
