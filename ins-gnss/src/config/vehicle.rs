//! `[vehicle]`: odometer, non-holonomic constraints, ZUPT/ZARU.

use super::*;

/// Land-vehicle aiding: `[vehicle.nhc]` and `[vehicle.zupt]`, each on when present.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VehicleSection {
    /// The non-holonomic constraint.
    #[serde(default)]
    pub nhc: Option<NhcSection>,
    /// ZUPT and ZARU on detected stops.
    #[serde(default)]
    pub zupt: Option<ZuptSection>,
    /// The odometer: the IMU file's 8th column (forward wheel speed, m/s), or a ROS
    /// recording's odometry (`data.ros.odometry_topic`).
    #[serde(default)]
    pub odometer: Option<OdometerSection>,
}

/// `[vehicle.odometer]`: the forward speed of the IMU file's 8th column (or of a ROS
/// recording's odometry), its scale calibrated against the filter while GNSS is
/// available. A run in which the filter moves against the odometer for most of the time
/// it reads motion is flagged (its heading is 180° off).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OdometerSection {
    /// The wheel point (middle of the rear axle) from the IMU, body frame FRD, m. Default 0.
    #[serde(default)]
    pub lever_arm: [f64; 3],
    /// 1σ of the scale-corrected forward speed, m/s. Default 0.1.
    #[serde(default = "default_odometer_std")]
    pub std: f64,
    /// Time between updates, s. Default 0.1.
    #[serde(default = "default_aiding_interval")]
    pub interval: f64,
    /// Time constant of the scale calibration, s. Default 120.
    #[serde(default = "default_calibration_time")]
    pub calibration_time: f64,
    /// Samples with the odometer reading above 1 m/s and GNSS before the
    /// odometer is used. Default 500.
    #[serde(default = "default_calibration_samples")]
    pub calibration_samples: f64,
}

pub(crate) fn default_odometer_std() -> f64 {
    0.1
}
pub(crate) fn default_calibration_time() -> f64 {
    120.0
}
pub(crate) fn default_calibration_samples() -> f64 {
    500.0
}

impl Default for OdometerSection {
    fn default() -> Self {
        Self {
            lever_arm: [0.0; 3],
            std: default_odometer_std(),
            interval: default_aiding_interval(),
            calibration_time: default_calibration_time(),
            calibration_samples: default_calibration_samples(),
        }
    }
}

/// `[vehicle.nhc]`: lateral and vertical velocity zero at a point of the vehicle.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NhcSection {
    /// Roll, pitch, yaw of the IMU relative to the vehicle frame, degrees. Default 0.
    #[serde(default)]
    pub mounting: [f64; 3],
    /// The constraint point (middle of the rear axle) from the IMU, body frame FRD, m.
    /// Default 0.
    #[serde(default)]
    pub lever_arm: [f64; 3],
    /// 1σ of the lateral and vertical velocity, m/s. Default [0.1, 0.1].
    #[serde(default = "default_nhc_std")]
    pub std: [f64; 2],
    /// Time between updates, s. Default 0.1.
    #[serde(default = "default_aiding_interval")]
    pub interval: f64,
    /// Applied only above this speed, m/s. Default 0.
    #[serde(default)]
    pub min_speed: f64,
}

pub(crate) fn default_nhc_std() -> [f64; 2] {
    [0.1, 0.1]
}
pub(crate) fn default_aiding_interval() -> f64 {
    0.1
}

impl Default for NhcSection {
    fn default() -> Self {
        Self {
            mounting: [0.0; 3],
            lever_arm: [0.0; 3],
            std: default_nhc_std(),
            interval: default_aiding_interval(),
            min_speed: 0.0,
        }
    }
}

/// `[vehicle.zupt]`: the stationary detector's thresholds and the ZUPT/ZARU noise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ZuptSection {
    /// Detector window, s. Default 1.
    #[serde(default = "default_window")]
    pub window: f64,
    /// Largest bias-corrected rate in the window, deg/s. Default 0.5.
    #[serde(default = "default_gyro_max")]
    pub gyro_max: f64,
    /// Largest standard deviation of the specific-force magnitude in the window, m/s².
    /// Default 0.05.
    #[serde(default = "default_accel_std_max")]
    pub accel_std_max: f64,
    /// 1σ of the zero velocity, m/s. Default 0.02.
    #[serde(default = "default_zupt_std")]
    pub velocity_std: f64,
    /// 1σ of the zero angular rate beyond the window mean's white noise (added from
    /// `imu_noise.arw`), deg/s; 0 turns ZARU off. Default 0.01.
    #[serde(default = "default_zaru_std")]
    pub rate_std: f64,
    /// Time between ZUPTs while stationary, s. Default 0.1 (ZARU: once per window).
    #[serde(default = "default_aiding_interval")]
    pub interval: f64,
    /// ZUPT/ZARU only while the filter's speed is below this plus `speed_sigmas` σ of it,
    /// m/s. Default 0.3.
    #[serde(default = "default_zupt_max_speed")]
    pub max_speed: f64,
    /// σ of the filter's speed added to `max_speed` (a stop in an outage is still taken).
    /// Default 3; 0 for a detector that fires while the vehicle creeps.
    #[serde(default = "default_speed_sigmas")]
    pub speed_sigmas: f64,
}

pub(crate) fn default_speed_sigmas() -> f64 {
    3.0
}

pub(crate) fn default_zupt_max_speed() -> f64 {
    0.3
}

pub(crate) fn default_window() -> f64 {
    1.0
}
pub(crate) fn default_gyro_max() -> f64 {
    0.5
}
pub(crate) fn default_accel_std_max() -> f64 {
    0.05
}
pub(crate) fn default_zupt_std() -> f64 {
    0.02
}
pub(crate) fn default_zaru_std() -> f64 {
    0.01
}

impl Default for ZuptSection {
    fn default() -> Self {
        Self {
            window: default_window(),
            gyro_max: default_gyro_max(),
            accel_std_max: default_accel_std_max(),
            velocity_std: default_zupt_std(),
            rate_std: default_zaru_std(),
            interval: default_aiding_interval(),
            max_speed: default_zupt_max_speed(),
            speed_sigmas: default_speed_sigmas(),
        }
    }
}
