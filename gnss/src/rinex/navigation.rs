//! Navigation files: the ionosphere's header lines and the Keplerian records.

use super::*;

/// A navigation file's contents.
#[derive(Clone, Debug, Default)]
pub struct NavData {
    /// The Keplerian ephemerides.
    pub ephemerides: Ephemerides,
    /// The GPS ionosphere coefficients, when the header has them.
    pub klobuchar: Option<Klobuchar>,
    /// Records of systems not used (GLONASS, SBAS, NavIC), read past.
    pub unused: usize,
}

/// A navigation file's header: its version, its system letter (`G` when blank), and the
/// GPS ionosphere's α and β when it gives them.
#[allow(clippy::type_complexity)]
fn nav_header(
    input: &mut Input,
    path: &Path,
    line_no: &mut usize,
) -> Result<(f64, char, Option<[f64; 4]>, Option<[f64; 4]>), RawError> {
    let mut version = 0.0;
    let mut file_sys = 'G';
    let (mut alpha, mut beta) = (None, None);
    read_header(input, path, line_no, |l| {
        let d4 = |from: usize| -> Result<[f64; 4], String> {
            let mut c = [0.0; 4];
            for (k, v) in c.iter_mut().enumerate() {
                *v = field(l, from + 12 * k, from + 12 * (k + 1))?.unwrap_or(0.0);
            }
            Ok(c)
        };
        match label(l) {
            "RINEX VERSION / TYPE" => {
                let (v, kind, sys) = version_and_type(l)?;
                if !(2.0..4.0).contains(&v) {
                    return Err(format!("RINEX version {v}: 2.xx and 3.xx are read"));
                }
                if kind != 'N' {
                    return Err(format!(
                        "file type `{kind}`: only GPS (RINEX 2) and mixed/any (RINEX 3) navigation files (`N`) hold Keplerian ephemerides"
                    ));
                }
                version = v;
                file_sys = if sys == ' ' { 'G' } else { sys };
            }
            "ION ALPHA" => alpha = Some(d4(2)?),
            "ION BETA" => beta = Some(d4(2)?),
            "IONOSPHERIC CORR" => match l.get(..4) {
                Some("GPSA") => alpha = Some(d4(5)?),
                Some("GPSB") => beta = Some(d4(5)?),
                _ => {}
            },
            _ => {}
        }
        Ok(())
    })?;
    Ok((version, file_sys, alpha, beta))
}

/// Reads a RINEX 2 (GPS `N`) or 3 (any `N`) navigation file.
pub fn read_nav(path: &Path) -> Result<NavData, RawError> {
    let mut input = open_input(path)?;
    let mut line_no = 0;
    let (version, file_sys, alpha, beta) = nav_header(&mut input, path, &mut line_no)?;
    if version == 0.0 {
        return Err(err(path, 1, "no `RINEX VERSION / TYPE` line"));
    }
    let v3 = version >= 3.0;
    let mut records = Vec::new();
    let mut unused = 0;
    let mut line = String::new();
    let mut lines: Vec<String> = Vec::with_capacity(8);
    loop {
        line.clear();
        let n = input.read_line(&mut line).map_err(|e| err(path, line_no, e.to_string()))?;
        if n == 0 {
            break;
        }
        line_no += 1;
        let l = line.trim_end_matches(['\n', '\r']).to_string();
        if l.trim().is_empty() {
            continue;
        }
        let start = line_no;
        let sys = if v3 {
            let c = l.chars().next().unwrap_or(' ');
            System::from_letter(c)
                .ok_or_else(|| err(path, start, format!("`{c}` is not a satellite system")))?
        } else {
            System::from_letter(file_sys).unwrap_or(System::Gps)
        };
        // GLONASS and SBAS records have 4 lines, the Keplerian ones 8
        let total = if matches!(sys, System::Glonass | System::Sbas) { 4 } else { 8 };
        lines.clear();
        lines.push(l);
        while lines.len() < total {
            line.clear();
            let n = input.read_line(&mut line).map_err(|e| err(path, line_no, e.to_string()))?;
            if n == 0 {
                // the last record's final line may hold only its first fields; a record cut short is refused
                return Err(err(
                    path,
                    line_no,
                    format!("the file ends inside the record that starts on line {start}"),
                ));
            }
            line_no += 1;
            lines.push(line.trim_end_matches(['\n', '\r']).to_string());
        }
        if !sys.keplerian() {
            unused += 1;
            continue;
        }
        let e = kepler_record(&lines, sys, v3).map_err(|(k, m)| err(path, start + k, m))?;
        records.push(e);
    }
    let klobuchar = match (alpha, beta) {
        (Some(alpha), Some(beta)) => Some(Klobuchar { alpha, beta }).filter(Klobuchar::is_set),
        _ => None,
    };
    Ok(NavData { ephemerides: Ephemerides::new(records), klobuchar, unused })
}

/// A record's first line's satellite and epoch, and where its values start.
fn record_epoch(
    first: &str,
    sys: System,
    v3: bool,
) -> Result<(Sat, GpsTime, usize), (usize, String)> {
    if v3 {
        let id = first.get(..3).unwrap_or("");
        let sat = Sat::parse(id).ok_or((0, format!("`{id}` is not a satellite")))?;
        let g = |a, z| {
            int_field(first, a, z).map_err(|m| (0, m))?.ok_or((0, "incomplete epoch".to_string()))
        };
        let t = GpsTime::from_calendar(
            g(4, 8)?,
            g(9, 11)?,
            g(12, 14)?,
            g(15, 17)?,
            g(18, 20)?,
            g(21, 23)? as f64,
        );
        Ok((sat, t, 23))
    } else {
        let prn = int_field(first, 0, 2).map_err(|m| (0, m))?.ok_or((0, "no PRN".to_string()))?;
        let sat = Sat { sys, prn: u8::try_from(prn).map_err(|_| (0, format!("PRN {prn}")))? };
        let g = |a, z| {
            int_field(first, a, z).map_err(|m| (0, m))?.ok_or((0, "incomplete epoch".to_string()))
        };
        let sec = field(first, 17, 22).map_err(|m| (0, m))?.ok_or((0, "no seconds".to_string()))?;
        let t = GpsTime::from_calendar(
            year4(g(2, 5)?),
            g(5, 8)?,
            g(8, 11)?,
            g(11, 14)?,
            g(14, 17)?,
            sec,
        );
        Ok((sat, t, 22))
    }
}

/// One Keplerian record from its 8 lines; an error names the line (0-based in the record).
fn kepler_record(lines: &[String], sys: System, v3: bool) -> Result<Ephemeris, (usize, String)> {
    let first = &lines[0];
    let (sat, t, head) = record_epoch(first, sys, v3)?;
    let mut v = [0.0f64; 31];
    for (k, slot) in v.iter_mut().take(3).enumerate() {
        *slot =
            field(first, head + 19 * k, head + 19 * (k + 1)).map_err(|m| (0, m))?.unwrap_or(0.0);
    }
    let indent = if v3 { 4 } else { 3 };
    for (r, l) in lines.iter().enumerate().skip(1) {
        for k in 0..4 {
            let idx = 3 + 4 * (r - 1) + k;
            if idx < v.len() {
                v[idx] = field(l, indent + 19 * k, indent + 19 * (k + 1))
                    .map_err(|m| (r, m))?
                    .unwrap_or(0.0);
            }
        }
    }
    // v: af0 af1 af2 | IODE Crs Δn M0 | Cuc e Cus √A | toe Cic Ω0 Cis | i0 Crc ω Ω̇ |
    //    IDOT codes week flag | accuracy health TGD IODC(TGD2) | ttm fit
    let week = v[21] as i32;
    let toe_sow = v[11];
    let (toc, toe) = match sys {
        System::BeiDou => {
            (t.add(-BDT_MINUS_GPST), GpsTime::new(week + BDT_WEEK_OFFSET, toe_sow - BDT_MINUS_GPST))
        }
        _ => (t, GpsTime::new(week, toe_sow)),
    };
    if v[10] <= 1000.0 || !(0.0..1.0).contains(&v[8]) {
        return Err((2, format!("{sat}: √A = {} m^½, e = {}: not an orbit", v[10], v[8])));
    }
    let tgd = match sys {
        System::Galileo | System::BeiDou => [v[25], v[26]],
        _ => [v[25], 0.0],
    };
    Ok(Ephemeris {
        sat,
        toc,
        toe,
        toe_sow,
        af: [v[0], v[1], v[2]],
        iode: v[3] as i32,
        iodc: if matches!(sys, System::Gps | System::Qzss) { v[26] as i32 } else { v[3] as i32 },
        sqrt_a: v[10],
        e: v[8],
        i0: v[15],
        omega0: v[13],
        omega: v[17],
        m0: v[6],
        delta_n: v[5],
        omega_dot: v[18],
        idot: v[19],
        harmonics: [v[7], v[9], v[16], v[4], v[12], v[14]],
        tgd,
        // GPS/QZSS health is a bit field; Galileo's and BeiDou's likewise: 0 is healthy
        health: v[24] as u32,
        accuracy: v[23],
    })
}
