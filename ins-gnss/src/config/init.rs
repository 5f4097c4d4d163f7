//! `[init]`, `[imu]` (mounting) and `[align]`: the initial state and how the start finds it.

use super::*;

/// Initial state and its 1σ, datasheet units. Every key is optional: what is not given
/// is found from the data before the run starts (see [`crate::start`]): position and
/// velocity from the first GNSS fixes, roll and pitch by levelling over a static start or
/// by the in-motion alignment, heading by the in-motion alignment, the gyro biases from a
/// static start. Given values always win.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitSection {
    /// Latitude, longitude (deg), height (m).
    #[serde(default)]
    pub position: Option<[f64; 3]>,
    /// NED velocity, m/s.
    #[serde(default)]
    pub velocity: Option<[f64; 3]>,
    /// Roll, pitch, yaw, deg.
    #[serde(default)]
    pub attitude: Option<[f64; 3]>,
    /// Gyro bias, deg/h (from the static start when there is one, else 0).
    #[serde(default)]
    pub gyro_bias: Option<[f64; 3]>,
    /// Accelerometer bias, mGal. Default 0.
    #[serde(default)]
    pub accel_bias: Option<[f64; 3]>,
    /// Position 1σ (N, E, D), m.
    #[serde(default)]
    pub position_std: Option<[f64; 3]>,
    /// Velocity 1σ, m/s.
    #[serde(default)]
    pub velocity_std: Option<[f64; 3]>,
    /// Attitude 1σ, deg.
    #[serde(default)]
    pub attitude_std: Option<[f64; 3]>,
    /// Gyro bias 1σ, deg/h.
    #[serde(default)]
    pub gyro_bias_std: Option<[f64; 3]>,
    /// Accelerometer bias 1σ, mGal (default 20,000: a consumer MEMS turn-on bias).
    #[serde(default)]
    pub accel_bias_std: Option<[f64; 3]>,
    /// Gyro scale factors, ppm (21 states). Default 0.
    #[serde(default)]
    pub gyro_scale: [f64; 3],
    /// Accelerometer scale factors, ppm (21 states). Default 0.
    #[serde(default)]
    pub accel_scale: [f64; 3],
    /// Gyro scale-factor 1σ, ppm (21 states). Default 1000.
    #[serde(default = "default_scale_std")]
    pub gyro_scale_std: [f64; 3],
    /// Accelerometer scale-factor 1σ, ppm (21 states). Default 1000.
    #[serde(default = "default_scale_std")]
    pub accel_scale_std: [f64; 3],
}

impl Default for InitSection {
    fn default() -> Self {
        toml::from_str("").expect("every key of [init] has a default")
    }
}

impl InitSection {
    /// Every part of the initial state given (nothing to find from the data).
    pub fn is_complete(&self) -> bool {
        self.position.is_some()
            && self.velocity.is_some()
            && self.attitude.is_some()
            && self.position_std.is_some()
            && self.velocity_std.is_some()
            && self.attitude_std.is_some()
            && self.gyro_bias_std.is_some()
    }
}

/// `[imu]`: how the IMU is mounted.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImuSection {
    /// The sensor's axes in the body (vehicle) frame, FRD: an axis map
    /// (`["-y", "-x", "-z"]`: body x is the sensor's −y, …), the sensor's roll, pitch, yaw
    /// relative to the body in degrees (`[180.0, 0.0, -90.0]`, the same mounting), or the
    /// sensor-to-body matrix `C_bs` (rows). Applied to every sample as it is read (after
    /// a column map's `axes`); the filter, the lever arms, NHC and the odometer then work
    /// in the body frame. A left-handed map is refused. Default: the sensor axes are the
    /// body's.
    #[serde(default)]
    pub mounting: Option<Mounting>,
}

/// A sensor mounting as the configuration states it ([`ImuSection::mounting`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(
    untagged,
    expecting = "a mounting: an axis map such as [\"-y\", \"-x\", \"-z\"], three angles \
                 [roll, pitch, yaw] in degrees, or a 3×3 matrix [[…], […], […]]"
)]
pub enum Mounting {
    /// Body x, y, z as signed sensor axes: `["-y", "-x", "-z"]`.
    Axes([String; 3]),
    /// Roll, pitch, yaw of the sensor relative to the body, degrees.
    Angles([f64; 3]),
    /// `C_bs`, row by row.
    Matrix([[f64; 3]; 3]),
}

impl Mounting {
    /// `C_bs` (sensor → body), checked to be a proper rotation. The error names what is
    /// wrong (the caller names the key).
    pub fn matrix(&self) -> Result<Matrix3<f64>, String> {
        let c = match self {
            Mounting::Axes(axes) => {
                let mut c = Matrix3::zeros();
                let mut seen = [false; 3];
                for (row, a) in axes.iter().enumerate() {
                    let a = a.trim().to_ascii_lowercase();
                    let (sign, name) = match a.strip_prefix('-') {
                        Some(n) => (-1.0, n),
                        None => (1.0, a.strip_prefix('+').unwrap_or(&a)),
                    };
                    let col = match name {
                        "x" => 0,
                        "y" => 1,
                        "z" => 2,
                        _ => {
                            return Err(format!(
                                "axis `{a}`: each entry is a sensor axis `x`, `y` or `z`, with a \
                                 sign if reversed (`-y`)"
                            ));
                        }
                    };
                    if seen[col] {
                        return Err(format!("sensor axis `{name}` named twice in {axes:?}"));
                    }
                    seen[col] = true;
                    c[(row, col)] = sign;
                }
                c
            }
            Mounting::Angles(a) => {
                finite("angles", a)?;
                if a.iter().any(|v| v.abs() > 360.0) {
                    return Err(format!("angles {a:?}: degrees within ±360"));
                }
                let d = core::f64::consts::PI / 180.0;
                So3::from_euler(a[0] * d, a[1] * d, a[2] * d).matrix()
            }
            Mounting::Matrix(m) => {
                let c = Matrix3::from_fn(|i, j| m[i][j]);
                finite("matrix", c.as_slice())?;
                let err = (c * c.transpose() - Matrix3::identity()).abs().max();
                if err > 1e-6 {
                    return Err(format!(
                        "the matrix is not a rotation (C Cᵀ differs from I by {err:.2e})"
                    ));
                }
                c
            }
        };
        if c.determinant() < 0.0 {
            return Err(format!(
                "{self:?} is left-handed (a mirror image, determinant −1): no rotation mounts \
                 a sensor so; one axis sign or one swap too many"
            ));
        }
        Ok(c)
    }
}

/// `[align]`: how the missing parts of `[init]` are found from the data, and the checks of
/// units and axes against the data.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AlignSection {
    /// Window of the static-start detector, s. Default 1.
    #[serde(default = "one")]
    pub static_window: f64,
    /// Shortest static start used for levelling and gyro biases, s. Default 5.
    #[serde(default = "default_min_static")]
    pub min_static: f64,
    /// Longest span of data the in-motion alignment may use, s, counted from the end of
    /// a static start (of up to 3600 s), else from the
    /// start. Default 120.
    #[serde(default = "default_align_time")]
    pub max_time: f64,
    /// The alignment stops once its heading 1σ is below this, deg. Default 1.
    #[serde(default = "one")]
    pub heading_std: f64,
    /// Check units, axes and times against the data before the run (default true).
    #[serde(default = "yes")]
    pub checks: bool,
}

pub(crate) fn one() -> f64 {
    1.0
}
pub(crate) fn default_min_static() -> f64 {
    5.0
}
pub(crate) fn default_align_time() -> f64 {
    120.0
}

impl Default for AlignSection {
    fn default() -> Self {
        toml::from_str("").expect("every key of [align] has a default")
    }
}

pub(crate) fn default_scale_std() -> [f64; 3] {
    [1000.0; 3]
}
