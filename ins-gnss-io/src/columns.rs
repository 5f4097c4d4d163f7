//! Logs with a header: the readers' fields picked from named columns, with units.
//!
//! A [`ColumnMap`] lists, in the order a reader expects its fields, where each one comes
//! from: a named column of the file's header, converted as `value · scale + offset`
//! (units, axis flips, a time offset), or a constant (a field the log does not have).
//! [`ColumnMap::resolve`] finds the columns in the header line; a missing one is an error
//! that names it and lists the columns present. The readers
//! ([`ImuReader::with_columns`](crate::ImuReader::with_columns),
//! [`GnssReader::with_columns`](crate::GnssReader::with_columns)) then read only those
//! columns of each line (the others may hold anything, text included).

/// Where one field comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum Source {
    /// A named column, converted as `value · scale + offset`.
    Column {
        /// The column's name in the header.
        name: String,
        /// Factor to the reader's unit.
        scale: f64,
        /// Added after scaling.
        offset: f64,
    },
    /// Not in the log: this value.
    Constant(f64),
}

impl Source {
    /// The column `name` in the reader's unit already.
    pub fn column(name: &str) -> Self {
        Source::Column { name: name.to_string(), scale: 1.0, offset: 0.0 }
    }

    /// The column `name` times `scale`.
    pub fn scaled(name: &str, scale: f64) -> Self {
        Source::Column { name: name.to_string(), scale, offset: 0.0 }
    }
}

/// The fields of one reader, in its order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ColumnMap {
    /// The fields.
    pub fields: Vec<Source>,
    /// The log has no header: every column is named by its 0-based index (`"4"`).
    pub headerless: bool,
    /// The time scale of the time field, converted to GPST seconds of week.
    pub time_scale: TimeScale,
    /// Which field is the time (0 for the IMU and GNSS readers, 1 for a reference's
    /// `week, t, …`).
    pub time_field: usize,
}

/// The time scale of a log's time column (after its unit and offset).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TimeScale {
    /// Already on the run's scale (GPS seconds of week, or relative seconds that match
    /// the other files).
    #[default]
    AsIs,
    /// Unix time (seconds since 1970-01-01 UTC, leap seconds not counted).
    UnixUtc,
    /// Seconds since the GPS epoch (1980-01-06), GPST.
    GpsSeconds,
}

impl TimeScale {
    /// The offset that takes a time `t` of this scale to GPST seconds of week (taken at
    /// the file's first time and kept for the whole file, so that a file crossing a week
    /// or a leap second stays continuous).
    pub fn offset_at(self, t: f64) -> f64 {
        const WEEK: f64 = 604_800.0;
        const GPS_EPOCH_UNIX: f64 = 315_964_800.0;
        let gps = match self {
            TimeScale::AsIs => return 0.0,
            TimeScale::UnixUtc => t - GPS_EPOCH_UNIX + ::gnss::calendar::gps_minus_utc(t),
            TimeScale::GpsSeconds => t,
        };
        gps.rem_euclid(WEEK) - t
    }
}

/// A [`ColumnMap`] matched to a header: the columns to read (in field order, distinct)
/// and how each field is made from them.
#[derive(Clone, Debug, PartialEq)]
pub struct Resolved {
    /// 0-based columns to read.
    pub columns: Vec<usize>,
    /// Per field: `(index into the values read, scale, offset)`, or a constant.
    plan: Vec<Result<(usize, f64, f64), f64>>,
    time_scale: TimeScale,
    time_field: usize,
    /// The time scale's offset, from the first line.
    time_offset: Option<f64>,
}

/// The column names of a header line (split at commas and white space, quotes removed).
pub fn header_names(header: &str) -> Vec<String> {
    header
        .split(|c: char| c == ',' || c == ';' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .map(|s| s.trim_matches(|c| c == '"' || c == '\'').to_string())
        .collect()
}

impl ColumnMap {
    /// Match the map to a header line (ignored when the map is
    /// [`headerless`](Self::headerless)). Errors name the missing column and list the
    /// ones present.
    pub fn resolve(&self, header: &str) -> Result<Resolved, String> {
        let names = header_names(header);
        let index_of = |name: &str| -> Result<usize, String> {
            if self.headerless {
                return name.trim().parse::<usize>().map_err(|_| {
                    format!(
                        "the log has no header (`header = false`): columns are named by \
                         0-based index, not `{name}`"
                    )
                });
            }
            names.iter().position(|n| n == name).ok_or_else(|| {
                format!("no column `{name}` in the header; its columns are: {}", names.join(", "))
            })
        };
        let mut columns: Vec<usize> = Vec::new();
        let mut plan = Vec::with_capacity(self.fields.len());
        for f in &self.fields {
            match f {
                Source::Constant(v) => plan.push(Err(*v)),
                Source::Column { name, scale, offset } => {
                    let i = index_of(name)?;
                    let slot = match columns.iter().position(|&c| c == i) {
                        Some(s) => s,
                        None => {
                            columns.push(i);
                            columns.len() - 1
                        }
                    };
                    plan.push(Ok((slot, *scale, *offset)));
                }
            }
        }
        Ok(Resolved {
            columns,
            plan,
            time_scale: self.time_scale,
            time_field: self.time_field,
            time_offset: None,
        })
    }
}

impl Resolved {
    /// The fields of one line from the values of [`columns`](Self::columns) (in that
    /// order), into `out` (cleared first).
    pub fn apply(&mut self, values: &[f64], out: &mut Vec<f64>) {
        out.clear();
        out.extend(self.plan.iter().map(|p| match p {
            Ok((slot, scale, offset)) => values[*slot] * scale + offset,
            Err(v) => *v,
        }));
        if self.time_scale != TimeScale::AsIs
            && let Some(t) = out.get_mut(self.time_field)
        {
            let scale = self.time_scale;
            *t += *self.time_offset.get_or_insert_with(|| scale.offset_at(*t));
        }
    }
}

/// Kinds of quantity a column can hold, for [`unit_factor`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Quantity {
    /// Time, to seconds.
    Time,
    /// Angular rate, to rad/s.
    Rate,
    /// Specific force, to m/s².
    Acceleration,
    /// Angle, to radians.
    Angle,
    /// Velocity (and velocity increment), to m/s.
    Speed,
    /// Length, to metres.
    Length,
}

/// The factor from `unit` to the SI unit of `q` (`"deg/s"` → π/180 for a rate), or an
/// error listing the units known.
pub fn unit_factor(q: Quantity, unit: &str) -> Result<f64, String> {
    let deg = core::f64::consts::PI / 180.0;
    let u = unit.trim().replace(' ', "");
    let known: &[(&str, f64)] = match q {
        Quantity::Time => &[("s", 1.0), ("ms", 1e-3), ("us", 1e-6), ("µs", 1e-6), ("ns", 1e-9)],
        Quantity::Rate => &[
            ("rad/s", 1.0),
            ("deg/s", deg),
            ("deg/h", deg / 3600.0),
            ("rpm", 2.0 * core::f64::consts::PI / 60.0),
        ],
        Quantity::Acceleration => {
            &[("m/s^2", 1.0), ("m/s2", 1.0), ("m/s²", 1.0), ("g", 9.80665), ("mg", 9.80665e-3)]
        }
        Quantity::Angle => &[("rad", 1.0), ("deg", deg), ("mrad", 1e-3)],
        Quantity::Speed => &[("m/s", 1.0), ("km/h", 1.0 / 3.6), ("mm/s", 1e-3)],
        Quantity::Length => &[("m", 1.0), ("mm", 1e-3), ("cm", 1e-2), ("km", 1e3)],
    };
    known.iter().find(|(n, _)| *n == u).map(|(_, f)| *f).ok_or_else(|| {
        format!(
            "unknown unit `{unit}` for {q:?}; known: {}",
            known.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resolves_names_units_and_constants() {
        let map = ColumnMap {
            headerless: false,
            time_scale: TimeScale::AsIs,
            time_field: 0,
            fields: vec![
                Source::scaled("t_ms", 1e-3),
                Source::Constant(2.5),
                Source::Column { name: "yaw".into(), scale: -1.0, offset: 90.0 },
                Source::column("t_ms"),
            ],
        };
        let mut r = map.resolve("k, t_ms ,\"yaw\", status").unwrap();
        assert_eq!(r.columns, vec![1, 2]);
        let mut out = Vec::new();
        r.apply(&[1500.0, 30.0], &mut out);
        assert_eq!(out, vec![1.5, 2.5, 60.0, 1500.0]);
        let e = map.resolve("k,time,yaw").unwrap_err();
        assert!(e.contains("`t_ms`") && e.contains("k, time, yaw"), "{e}");
    }

    #[test]
    fn units_convert_to_si_and_unknown_ones_are_refused() {
        let f = |q, u| unit_factor(q, u).unwrap();
        assert!((f(Quantity::Rate, "deg/h") * 3600.0 - 1f64.to_radians()).abs() < 1e-15);
        assert_eq!(f(Quantity::Acceleration, "g"), 9.80665);
        assert_eq!(f(Quantity::Time, "ns"), 1e-9);
        let e = unit_factor(Quantity::Rate, "dps").unwrap_err();
        assert!(e.contains("deg/s"), "{e}");
    }
}
