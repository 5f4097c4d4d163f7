//! GNSS time: a GPS week and seconds of week, and the satellite identifiers.

use crate::calendar::{days_from_civil, GPS_EPOCH_DAYS};
use core::fmt;
/// Seconds in a week.
pub const WEEK: f64 = 604_800.0;
/// BeiDou time (BDT) is GPS time − 14 s; its week 0 starts at GPS week 1356.
pub const BDT_MINUS_GPST: f64 = -14.0;
/// GPS week of BDT week 0.
pub const BDT_WEEK_OFFSET: i32 = 1356;

/// A GPS-time instant: week and seconds of week (kept apart so that differences keep
/// nanoseconds).
#[derive(Clone, Copy, Debug, PartialEq, PartialOrd)]
pub struct GpsTime {
    /// Week since 1980-01-06.
    pub week: i32,
    /// Seconds of week, `[0, 604800)`.
    pub tow: f64,
}

impl GpsTime {
    /// From a week and seconds of week that may lie outside `[0, 604800)`.
    pub fn new(week: i32, tow: f64) -> Self {
        let shift = (tow / WEEK).floor();
        Self { week: week + shift as i32, tow: tow - shift * WEEK }
    }

    /// From a calendar date and time on GPS time's own scale (as RINEX writes them).
    pub fn from_calendar(y: i64, mo: i64, d: i64, h: i64, mi: i64, s: f64) -> Self {
        let days = days_from_civil(y, mo, d) - GPS_EPOCH_DAYS;
        let week = days.div_euclid(7);
        let tow = days.rem_euclid(7) as f64 * 86_400.0 + (h * 3600 + mi * 60) as f64 + s;
        Self::new(week as i32, tow)
    }

    /// `self − other`, s.
    pub fn diff(&self, other: &GpsTime) -> f64 {
        (self.week - other.week) as f64 * WEEK + (self.tow - other.tow)
    }

    /// `self + dt`.
    pub fn add(&self, dt: f64) -> Self {
        Self::new(self.week, self.tow + dt)
    }

    /// Calendar date and time `(y, m, d, h, min, s)` on GPS time's scale.
    pub fn calendar(&self) -> (i64, i64, i64, i64, i64, f64) {
        let day = (self.tow / 86_400.0).floor();
        let sod = self.tow - day * 86_400.0;
        let (y, m, d) =
            crate::calendar::civil_from_days(GPS_EPOCH_DAYS + self.week as i64 * 7 + day as i64);
        let h = (sod / 3600.0).floor();
        let mi = ((sod - h * 3600.0) / 60.0).floor();
        (y, m, d, h as i64, mi as i64, sod - h * 3600.0 - mi * 60.0)
    }
}

impl GpsTime {
    /// Day of the year with its fraction on GPS time's scale: 1.0 at 1 January 0 h (the
    /// season of the troposphere's mapping; leap seconds do not matter there).
    pub fn day_of_year(&self) -> f64 {
        let (y, ..) = self.calendar();
        let jan1 = days_from_civil(y, 1, 1) - GPS_EPOCH_DAYS;
        1.0 + (self.week as i64 * 7 - jan1) as f64 + self.tow / 86_400.0
    }
}

impl fmt::Display for GpsTime {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (y, m, d, h, mi, s) = self.calendar();
        write!(f, "{y:04}/{m:02}/{d:02} {h:02}:{mi:02}:{s:06.3} GPST")
    }
}

/// A satellite system.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum System {
    /// GPS.
    Gps,
    /// GLONASS (read, not used by the models here).
    Glonass,
    /// Galileo.
    Galileo,
    /// BeiDou.
    BeiDou,
    /// QZSS (GPS-like orbits).
    Qzss,
    /// SBAS (read, not used).
    Sbas,
    /// NavIC/IRNSS (read, not used).
    Irnss,
}

impl System {
    /// From the RINEX letter.
    pub fn from_letter(c: char) -> Option<Self> {
        Some(match c {
            'G' | ' ' => Self::Gps,
            'R' => Self::Glonass,
            'E' => Self::Galileo,
            'C' => Self::BeiDou,
            'J' => Self::Qzss,
            'S' => Self::Sbas,
            'I' => Self::Irnss,
            _ => return None,
        })
    }

    /// The RINEX letter.
    pub fn letter(self) -> char {
        match self {
            Self::Gps => 'G',
            Self::Glonass => 'R',
            Self::Galileo => 'E',
            Self::BeiDou => 'C',
            Self::Qzss => 'J',
            Self::Sbas => 'S',
            Self::Irnss => 'I',
        }
    }

    /// Its name as users write it (`GPS`, `Galileo`, …).
    pub fn name(self) -> &'static str {
        match self {
            Self::Gps => "GPS",
            Self::Glonass => "GLONASS",
            Self::Galileo => "Galileo",
            Self::BeiDou => "BeiDou",
            Self::Qzss => "QZSS",
            Self::Sbas => "SBAS",
            Self::Irnss => "NavIC",
        }
    }

    /// Whether its broadcast orbit is Keplerian (the model of [`super::ephemeris`]).
    pub fn keplerian(self) -> bool {
        matches!(self, Self::Gps | Self::Galileo | Self::BeiDou | Self::Qzss)
    }

    /// The systems of a list as users write them: RINEX letters (`G`, `E`, `C`, `J`) or
    /// names (`GPS`, `Galileo`, `BeiDou`, `QZSS`), any case — the systems the satellite
    /// models serve. An error names the first entry that is none of them, or an empty list.
    pub fn parse_list<S: AsRef<str>>(list: &[S]) -> Result<Vec<Self>, String> {
        if list.is_empty() {
            return Err("no system given: G, E, C or J".into());
        }
        let mut out = Vec::with_capacity(list.len());
        for entry in list {
            let entry = entry.as_ref().trim();
            let mut letters = entry.chars();
            let by_letter = match (letters.next(), letters.next()) {
                (Some(c), None) => Self::from_letter(c.to_ascii_uppercase()),
                _ => None,
            };
            let sys = by_letter
                .or_else(|| {
                    [Self::Gps, Self::Galileo, Self::BeiDou, Self::Qzss]
                        .into_iter()
                        .find(|s| s.name().eq_ignore_ascii_case(entry))
                })
                .filter(|s| s.keplerian())
                .ok_or_else(|| {
                    format!("`{entry}`: not a system the models serve (G, E, C or J)")
                })?;
            if !out.contains(&sys) {
                out.push(sys);
            }
        }
        Ok(out)
    }
}

/// A satellite: system and number.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Sat {
    /// System.
    pub sys: System,
    /// PRN (slot for GLONASS).
    pub prn: u8,
}

impl Sat {
    /// Parses `G05`, `G 5`, ` 5` (RINEX 2: GPS), `E11`.
    pub fn parse(s: &str) -> Option<Self> {
        let mut c = s.chars();
        let first = c.next()?;
        let (sys, rest) = if first.is_ascii_digit() {
            (System::Gps, s)
        } else {
            (System::from_letter(first)?, c.as_str())
        };
        let prn: u8 = rest.trim().parse().ok()?;
        (prn > 0).then_some(Self { sys, prn })
    }

    /// BeiDou geostationary satellites (PRN 1–5 and 59–63), whose orbit is rotated.
    pub fn beidou_geo(&self) -> bool {
        self.sys == System::BeiDou && (self.prn <= 5 || self.prn >= 59)
    }
}

impl fmt::Display for Sat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}{:02}", self.sys.letter(), self.prn)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn system_lists_read_letters_and_names_and_refuse_the_rest() {
        use System::*;
        assert_eq!(
            System::parse_list(&["G", "c", "Galileo", "QZSS", "G"]),
            Ok(vec![Gps, BeiDou, Galileo, Qzss])
        );
        for bad in ["R", "GLONASS", "X", "", "GP"] {
            let e = System::parse_list(&[bad]).unwrap_err();
            assert!(e.contains(&format!("`{bad}`")), "{e}");
        }
        assert!(System::parse_list::<&str>(&[]).is_err());
    }

    #[test]
    fn calendar_round_trip_and_known_week() {
        // 2005-04-02 00:00:00 GPST is week 1316, 518400 s (RTKLIB's header of the shipped run)
        let t = GpsTime::from_calendar(2005, 4, 2, 0, 0, 0.0);
        assert_eq!(t.week, 1316);
        assert_eq!(t.tow, 518_400.0);
        let (y, m, d, h, mi, s) = t.add(3723.5).calendar();
        assert_eq!((y, m, d, h, mi), (2005, 4, 2, 1, 2));
        assert!((s - 3.5).abs() < 1e-9);
        // across the week's end
        let u = t.add(100_000.0);
        assert_eq!(u.week, 1317);
        assert!((u.diff(&t) - 100_000.0).abs() < 1e-9);
        // 2 April 2005 is day 92 of its year; 2004 was a leap year (31 December: day 366)
        assert!((t.add(43_200.0).day_of_year() - 92.5).abs() < 1e-9);
        assert_eq!(GpsTime::from_calendar(2005, 1, 1, 0, 0, 0.0).day_of_year(), 1.0);
        assert_eq!(GpsTime::from_calendar(2004, 12, 31, 6, 0, 0.0).day_of_year(), 366.25);
    }

    #[test]
    fn satellites_parse_both_rinex_spellings() {
        assert_eq!(Sat::parse("G05"), Some(Sat { sys: System::Gps, prn: 5 }));
        assert_eq!(Sat::parse("G 5"), Some(Sat { sys: System::Gps, prn: 5 }));
        assert_eq!(Sat::parse(" 5"), Some(Sat { sys: System::Gps, prn: 5 }));
        assert_eq!(Sat::parse("E11").unwrap().to_string(), "E11");
        assert!(Sat::parse("C03").unwrap().beidou_geo());
        assert_eq!(Sat::parse("X01"), None);
        assert_eq!(Sat::parse("G00"), None);
    }
}
