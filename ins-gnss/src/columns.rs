//! The configuration's column maps for logs with a header (`[data.imu_columns]`,
//! `[data.gnss_columns]`, `[data.truth_columns]`): which named column holds what, in
//! which unit, axes and conventions, turned into the readers' [`ColumnMap`]s.
//!
//! Every key has a default (the documented default map), so `[data.imu_columns]` alone
//! reads a CSV whose header is `t,gx,gy,gz,ax,ay,az` in s, rad/s and m/s².

use serde::{Deserialize, Serialize};

use ins_gnss_io::columns::unit_factor;
use ins_gnss_io::{ColumnMap, Quantity, Source, TimeScale};

/// Body axes of a log.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Axes {
    /// Forward, right, down (the filter's).
    #[default]
    Frd,
    /// Forward, left, up: y and z change sign.
    Flu,
}

/// The time scale of a log's time column.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum TimeScaleName {
    /// Already GPS seconds of week (or relative seconds that match the other files).
    #[default]
    AsIs,
    /// Unix time, UTC: converted to GPST seconds of week with the leap seconds of its date.
    UnixUtc,
    /// Seconds since the GPS epoch (1980-01-06), GPST.
    GpsSeconds,
}

impl From<TimeScaleName> for TimeScale {
    fn from(t: TimeScaleName) -> Self {
        match t {
            TimeScaleName::AsIs => TimeScale::AsIs,
            TimeScaleName::UnixUtc => TimeScale::UnixUtc,
            TimeScaleName::GpsSeconds => TimeScale::GpsSeconds,
        }
    }
}

/// Frame of a velocity triple.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum VelocityFrame {
    /// North, east, down.
    #[default]
    Ned,
    /// East, north, up.
    Enu,
}

/// How a log's heading (yaw) is counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Heading {
    /// From north, clockwise (NED yaw; the filter's).
    #[default]
    NorthClockwise,
    /// From east, counter-clockwise (ENU yaw): `yaw_NED = 90° − yaw_ENU`.
    EastCounterclockwise,
}

fn t() -> Col {
    "t".into()
}
fn seconds() -> String {
    "s".into()
}
fn gyro() -> [Col; 3] {
    ["gx".into(), "gy".into(), "gz".into()]
}
fn accel() -> [Col; 3] {
    ["ax".into(), "ay".into(), "az".into()]
}
fn lat() -> Col {
    "lat".into()
}
fn lon() -> Col {
    "lon".into()
}
fn height() -> Col {
    "h".into()
}
fn degrees() -> String {
    "deg".into()
}
fn metres() -> String {
    "m".into()
}
fn metres_per_second() -> String {
    "m/s".into()
}
fn yes() -> bool {
    true
}

/// A column: its name in the header, or with `header = false` its 0-based index (written
/// as a number or a string).
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
#[serde(transparent)]
pub struct Col(pub String);

impl std::ops::Deref for Col {
    type Target = str;
    fn deref(&self) -> &str {
        &self.0
    }
}

impl From<&str> for Col {
    fn from(s: &str) -> Self {
        Col(s.to_string())
    }
}

impl std::fmt::Display for Col {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl<'de> Deserialize<'de> for Col {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = Col;
            fn expecting(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str("a column name or a 0-based column index")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Col, E> {
                Ok(Col(v.to_string()))
            }
            fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Col, E> {
                if v < 0 {
                    return Err(E::custom(format!("column index {v}: 0 or more")));
                }
                Ok(Col(v.to_string()))
            }
            fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Col, E> {
                Ok(Col(v.to_string()))
            }
        }
        d.deserialize_any(V)
    }
}

/// `[data.imu_columns]`: an IMU log with a header. Rates or increments as
/// `data.imu_format` says.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuColumns {
    /// Time column. Default `t`.
    #[serde(default = "t")]
    pub time: Col,
    /// `s` (default), `ms`, `us`, `ns`.
    #[serde(default = "seconds")]
    pub time_unit: String,
    /// Added to every time, s (after the unit). Default 0.
    #[serde(default)]
    pub time_offset: f64,
    /// Gyro x, y, z columns. Default `gx, gy, gz`.
    #[serde(default = "gyro")]
    pub gyro: [Col; 3],
    /// Rates: `rad/s` (default), `deg/s`, `deg/h`; increments: `rad` (default), `deg`.
    #[serde(default)]
    pub gyro_unit: Option<String>,
    /// Accelerometer x, y, z columns. Default `ax, ay, az`.
    #[serde(default = "accel")]
    pub accel: [Col; 3],
    /// Rates: `m/s^2` (default), `g`, `mg`; increments: `m/s` (default).
    #[serde(default)]
    pub accel_unit: Option<String>,
    /// `frd` (default) or `flu`.
    #[serde(default)]
    pub axes: Axes,
    /// Wheel-speed column, optional.
    #[serde(default)]
    pub odometer: Option<Col>,
    /// `m/s` (default), `km/h`.
    #[serde(default = "metres_per_second")]
    pub odometer_unit: String,
    /// The log has a header line (default true); `false`: columns are named by 0-based
    /// index (`gyro = [4, 5, 6]`).
    #[serde(default = "yes")]
    pub header: bool,
    /// `as-is` (default: GPS seconds of week), `unix-utc` or `gps-seconds`: converted to
    /// GPST seconds of week (the leap seconds of the file's first time).
    #[serde(default)]
    pub time_scale: TimeScaleName,
}

impl Default for ImuColumns {
    fn default() -> Self {
        toml::from_str("").expect("every key has a default")
    }
}

fn time_source(name: &str, unit: &str, offset: f64) -> Result<Source, String> {
    let scale = unit_factor(Quantity::Time, unit)?;
    Ok(Source::Column { name: name.into(), scale, offset })
}

impl ImuColumns {
    /// The IMU reader's map: `t, ωx, ωy, ωz, fx, fy, fz [, odometer]`.
    pub fn map(&self, rates: bool) -> Result<ColumnMap, String> {
        let (gq, aq, gu, au) = if rates {
            (Quantity::Rate, Quantity::Acceleration, "rad/s", "m/s^2")
        } else {
            (Quantity::Angle, Quantity::Speed, "rad", "m/s")
        };
        let g = unit_factor(gq, self.gyro_unit.as_deref().unwrap_or(gu))?;
        let a = unit_factor(aq, self.accel_unit.as_deref().unwrap_or(au))?;
        let sign = |k: usize| if self.axes == Axes::Flu && k > 0 { -1.0 } else { 1.0 };
        let mut fields = vec![time_source(&self.time, &self.time_unit, self.time_offset)?];
        fields.extend((0..3).map(|k| Source::scaled(&self.gyro[k], g * sign(k))));
        fields.extend((0..3).map(|k| Source::scaled(&self.accel[k], a * sign(k))));
        if let Some(o) = &self.odometer {
            fields.push(Source::scaled(o, unit_factor(Quantity::Speed, &self.odometer_unit)?));
        }
        Ok(ColumnMap {
            fields,
            headerless: !self.header,
            time_scale: self.time_scale.into(),
            time_field: 0,
        })
    }
}

/// `[data.gnss_columns]`: a GNSS log with a header.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GnssColumns {
    /// Time column. Default `t`.
    #[serde(default = "t")]
    pub time: Col,
    /// `s` (default), `ms`, `us`, `ns`.
    #[serde(default = "seconds")]
    pub time_unit: String,
    /// Added to every time, s. Default 0.
    #[serde(default)]
    pub time_offset: f64,
    /// Latitude column. Default `lat`.
    #[serde(default = "lat")]
    pub latitude: Col,
    /// Longitude column. Default `lon`.
    #[serde(default = "lon")]
    pub longitude: Col,
    /// `deg` (default) or `rad`.
    #[serde(default = "degrees")]
    pub angle_unit: String,
    /// Ellipsoidal height column. Default `h`.
    #[serde(default = "height")]
    pub height: Col,
    /// `m` (default) or `mm`, `cm`, `km`, for the height and the σ.
    #[serde(default = "metres")]
    pub length_unit: String,
    /// Position σ north, east, down columns; without them `gnss.position_std` is
    /// required.
    #[serde(default)]
    pub position_std: Option<[Col; 3]>,
    /// Velocity columns (in `velocity_frame` order), optional.
    #[serde(default)]
    pub velocity: Option<[Col; 3]>,
    /// `ned` (default) or `enu`.
    #[serde(default)]
    pub velocity_frame: VelocityFrame,
    /// `m/s` (default), `km/h`, `mm/s`, for the velocity and its σ.
    #[serde(default = "metres_per_second")]
    pub velocity_unit: String,
    /// Velocity σ columns (north, east, down); without them, with a velocity,
    /// `gnss.velocity_std` is required.
    #[serde(default)]
    pub velocity_std: Option<[Col; 3]>,
    /// The log has a header line (default true); `false`: columns are named by 0-based
    /// index (`gyro = [4, 5, 6]`).
    #[serde(default = "yes")]
    pub header: bool,
    /// `as-is` (default: GPS seconds of week), `unix-utc` or `gps-seconds`: converted to
    /// GPST seconds of week (the leap seconds of the file's first time).
    #[serde(default)]
    pub time_scale: TimeScaleName,
}

impl GnssColumns {
    /// The GNSS reader's map: `t, lat, lon, h, σN, σE, σD` (s, deg, m) and, with a
    /// velocity, `vN, vE, vD, σvN, σvE, σvD`. σ the log does not have are placeholders
    /// (1) that `gnss.position_std` / `gnss.velocity_std` replace.
    pub fn map(&self) -> Result<ColumnMap, String> {
        let m = unit_factor(Quantity::Length, &self.length_unit)?;
        let v = unit_factor(Quantity::Speed, &self.velocity_unit)?;
        let mut fields = position_fields(
            (&self.time, &self.time_unit, self.time_offset),
            [&self.latitude, &self.longitude, &self.angle_unit],
            (&self.height, &self.length_unit),
        )?;
        match &self.position_std {
            Some(s) => fields.extend(s.iter().map(|n| Source::scaled(n, m))),
            None => fields.extend((0..3).map(|_| Source::Constant(1.0))),
        }
        if let Some(vel) = &self.velocity {
            fields.extend(ned(vel, self.velocity_frame, v));
            match &self.velocity_std {
                Some(s) => fields.extend(s.iter().map(|n| Source::scaled(n, v))),
                None => fields.extend((0..3).map(|_| Source::Constant(1.0))),
            }
        }
        Ok(ColumnMap {
            fields,
            headerless: !self.header,
            time_scale: self.time_scale.into(),
            time_field: 0,
        })
    }
}

/// `t, lat, lon, h` in s, degrees and metres from (time column, unit, offset),
/// (latitude, longitude, angle unit) and (height, length unit).
fn position_fields(
    (time, time_unit, offset): (&str, &str, f64),
    [lat, lon, angle_unit]: [&str; 3],
    (height, length_unit): (&str, &str),
) -> Result<Vec<Source>, String> {
    let deg = unit_factor(Quantity::Angle, angle_unit)?.to_degrees();
    let m = unit_factor(Quantity::Length, length_unit)?;
    Ok(vec![
        time_source(time, time_unit, offset)?,
        Source::scaled(lat, deg),
        Source::scaled(lon, deg),
        Source::scaled(height, m),
    ])
}

/// North, east, down from a triple named in `frame`'s order, times `scale`.
fn ned(v: &[Col; 3], frame: VelocityFrame, scale: f64) -> [Source; 3] {
    match frame {
        VelocityFrame::Ned => [0, 1, 2].map(|k| Source::scaled(&v[k], scale)),
        VelocityFrame::Enu => [
            Source::scaled(&v[1], scale),
            Source::scaled(&v[0], scale),
            Source::scaled(&v[2], -scale),
        ],
    }
}

/// `[data.truth_columns]`: a truth or reference log with a header (for `run --truth`,
/// `eval --config` and the plots).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TruthColumns {
    /// Time column. Default `t`.
    #[serde(default = "t")]
    pub time: Col,
    /// `s` (default), `ms`, `us`, `ns`.
    #[serde(default = "seconds")]
    pub time_unit: String,
    /// Added to every time, s. Default 0.
    #[serde(default)]
    pub time_offset: f64,
    /// Latitude column. Default `lat`.
    #[serde(default = "lat")]
    pub latitude: Col,
    /// Longitude column. Default `lon`.
    #[serde(default = "lon")]
    pub longitude: Col,
    /// `deg` (default) or `rad`, for latitude and longitude.
    #[serde(default = "degrees")]
    pub angle_unit: String,
    /// Ellipsoidal height column. Default `h`.
    #[serde(default = "height")]
    pub height: Col,
    /// `m` (default), `mm`, `cm`, `km`.
    #[serde(default = "metres")]
    pub length_unit: String,
    /// Velocity columns (in `velocity_frame` order); without them (and the attitude)
    /// the reference is positions only, compared at its own epochs.
    #[serde(default)]
    pub velocity: Option<[Col; 3]>,
    /// `ned` (default) or `enu`.
    #[serde(default)]
    pub velocity_frame: VelocityFrame,
    /// `m/s` (default), `km/h`, `mm/s`.
    #[serde(default = "metres_per_second")]
    pub velocity_unit: String,
    /// Roll, pitch, yaw (heading) columns, optional.
    #[serde(default)]
    pub attitude: Option<[Col; 3]>,
    /// `deg` (default) or `rad`.
    #[serde(default = "degrees")]
    pub attitude_unit: String,
    /// `north-clockwise` (default) or `east-counterclockwise`.
    #[serde(default)]
    pub heading: Heading,
    /// The log has a header line (default true); `false`: columns are named by 0-based
    /// index (`gyro = [4, 5, 6]`).
    #[serde(default = "yes")]
    pub header: bool,
    /// `as-is` (default: GPS seconds of week), `unix-utc` or `gps-seconds`: converted to
    /// GPST seconds of week (the leap seconds of the file's first time).
    #[serde(default)]
    pub time_scale: TimeScaleName,
}

impl TruthColumns {
    /// The reference reader's map, the 11 fields of the navigation format (`week, t,
    /// lat, lon, h` in deg and m, `vN, vE, vD`, roll, pitch, yaw in deg); what the log
    /// does not have is NaN.
    pub fn map(&self) -> Result<ColumnMap, String> {
        let v = unit_factor(Quantity::Speed, &self.velocity_unit)?;
        let nan = || Source::Constant(f64::NAN);
        let mut fields = vec![Source::Constant(0.0)];
        fields.extend(position_fields(
            (&self.time, &self.time_unit, self.time_offset),
            [&self.latitude, &self.longitude, &self.angle_unit],
            (&self.height, &self.length_unit),
        )?);
        match &self.velocity {
            Some(vel) => fields.extend(ned(vel, self.velocity_frame, v)),
            None => fields.extend([nan(), nan(), nan()]),
        }
        match &self.attitude {
            Some(att) => {
                let a = unit_factor(Quantity::Angle, &self.attitude_unit)?.to_degrees();
                fields.push(Source::scaled(&att[0], a));
                fields.push(Source::scaled(&att[1], a));
                fields.push(match self.heading {
                    Heading::NorthClockwise => Source::scaled(&att[2], a),
                    Heading::EastCounterclockwise => {
                        Source::Column { name: att[2].to_string(), scale: -a, offset: 90.0 }
                    }
                });
            }
            None => fields.extend([nan(), nan(), nan()]),
        }
        Ok(ColumnMap {
            fields,
            headerless: !self.header,
            time_scale: self.time_scale.into(),
            time_field: 1,
        })
    }

    /// Positions only (no velocity): compared at the reference's epochs.
    pub fn positions_only(&self) -> bool {
        self.velocity.is_none()
    }
}
