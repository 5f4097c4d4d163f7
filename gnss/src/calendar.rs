//! Calendar dates, leap seconds and time systems: an epoch on the GPST seconds-of-week
//! scale, for every file format that states a date (RTKLIB solutions, NMEA, RINEX, logs
//! stamped in UTC) and for the raw observations' GPS time.

/// Seconds in a GPS week.
pub const WEEK: f64 = 604_800.0;

/// GPS − UTC (s) from each date (year, month, day; 0 h UTC) on: the leap seconds since
/// the GPS epoch (1980-01-06), from the IERS bulletins.
const LEAP_SECONDS: [(i64, i64, i64, f64); 18] = [
    (1981, 7, 1, 1.0),
    (1982, 7, 1, 2.0),
    (1983, 7, 1, 3.0),
    (1985, 7, 1, 4.0),
    (1988, 1, 1, 5.0),
    (1990, 1, 1, 6.0),
    (1991, 1, 1, 7.0),
    (1992, 7, 1, 8.0),
    (1993, 7, 1, 9.0),
    (1994, 7, 1, 10.0),
    (1996, 1, 1, 11.0),
    (1997, 7, 1, 12.0),
    (1999, 1, 1, 13.0),
    (2006, 1, 1, 14.0),
    (2009, 1, 1, 15.0),
    (2012, 7, 1, 16.0),
    (2015, 7, 1, 17.0),
    (2017, 1, 1, 18.0),
];

/// Days from 1970-01-01 to a civil date (proleptic Gregorian).
pub fn days_from_civil(y: i64, m: i64, d: i64) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (m + 9) % 12;
    let doy = (153 * mp + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// Civil date (year, month, day) of a day count from 1970-01-01.
pub fn civil_from_days(z: i64) -> (i64, i64, i64) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    (if m <= 2 { yoe + era * 400 + 1 } else { yoe + era * 400 }, m, d)
}

/// Days from 1970-01-01 to the GPS epoch, 1980-01-06.
pub const GPS_EPOCH_DAYS: i64 = 3657;

/// GPS − UTC (s) at a UTC instant given as seconds since 1970-01-01 (UTC, no leap
/// seconds counted, as Unix time).
pub fn gps_minus_utc(unix: f64) -> f64 {
    let day = (unix / 86_400.0).floor() as i64;
    LEAP_SECONDS
        .iter()
        .rev()
        .find(|(y, m, d, _)| day >= days_from_civil(*y, *m, *d))
        .map_or(0.0, |l| l.3)
}

/// A time scale of a file's time stamps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimeSystem {
    /// GPS time.
    Gpst,
    /// UTC.
    Utc,
    /// Japan standard time (UTC + 9 h), which RTKLIB can write.
    Jst,
}

impl TimeSystem {
    /// The system of a label RTKLIB writes (`GPST`, `UTC`, `JST`).
    pub fn from_label(s: &str) -> Option<Self> {
        match s {
            "GPST" => Some(Self::Gpst),
            "UTC" => Some(Self::Utc),
            "JST" => Some(Self::Jst),
            _ => None,
        }
    }

    /// The label RTKLIB writes.
    pub fn label(self) -> &'static str {
        match self {
            Self::Gpst => "GPST",
            Self::Utc => "UTC",
            Self::Jst => "JST",
        }
    }
}

/// GPST seconds of week of a date and time `(y, m, d, hh, mm, ss)` on `system`'s scale.
pub fn seconds_of_week(system: TimeSystem, date: (i64, i64, i64), hms: (i64, i64, f64)) -> f64 {
    let days = days_from_civil(date.0, date.1, date.2);
    // the day of the week first: seconds of week stay small numbers (no rounding at 1e9 s)
    let mut secs = (days - GPS_EPOCH_DAYS).rem_euclid(7) as f64 * 86_400.0
        + hms.0 as f64 * 3600.0
        + hms.1 as f64 * 60.0
        + hms.2;
    match system {
        TimeSystem::Gpst => {}
        TimeSystem::Utc => secs += gps_minus_utc(days as f64 * 86_400.0 + hms_secs(hms)),
        TimeSystem::Jst => {
            secs -= 9.0 * 3600.0;
            let unix = days as f64 * 86_400.0 + hms_secs(hms) - 9.0 * 3600.0;
            secs += gps_minus_utc(unix);
        }
    }
    secs.rem_euclid(WEEK)
}

fn hms_secs(hms: (i64, i64, f64)) -> f64 {
    hms.0 as f64 * 3600.0 + hms.1 as f64 * 60.0 + hms.2
}
