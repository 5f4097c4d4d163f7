//! `[calibrate]`: the rig's calibration as states of the filter.

use super::*;

/// `[calibrate]`: the rig's calibration estimated by the filter (loose coupling, 15
/// states: seven states more, 22), each item on its own — the antenna lever arm, the
/// IMU–GNSS time offset, the IMU's mounting in the vehicle (with the non-holonomic
/// constraint or the odometer). The configured `gnss.lever_arm`, `data.imu_time_offset`
/// and `vehicle.nhc.mounting` are where they start; the run summary gives what the data
/// made of them, their σ and how much the data reduced it, or says that the data could
/// not tell. With the time offset on, an offset the start's
/// search finds decisively (the gyro's turns against the GNSS course) is applied to the
/// IMU's stamps instead of refusing the run, the state refining what is left.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrateSection {
    /// Estimate the antenna lever arm. Default false.
    #[serde(default)]
    pub lever_arm: bool,
    /// The lever arm's prior 1σ per axis about `gnss.lever_arm`, m. Default 1.0.
    #[serde(default = "default_lever_arm_std")]
    pub lever_arm_std: f64,
    /// Estimate the IMU–GNSS time offset. Default false.
    #[serde(default)]
    pub time_offset: bool,
    /// The time offset's prior 1σ about `data.imu_time_offset` (after the start's search
    /// applied what it found), s. Default 0.1.
    #[serde(default = "default_time_offset_std")]
    pub time_offset_std: f64,
    /// Estimate the IMU's mounting in the vehicle (roll, pitch, yaw of the body relative
    /// to the vehicle frame, seen by the non-holonomic constraint and the odometer; needs
    /// one of them). Default false.
    #[serde(default)]
    pub mounting: bool,
    /// The mounting's prior 1σ per angle about `vehicle.nhc.mounting`, degrees. Default
    /// 3.
    #[serde(default = "default_mounting_std")]
    pub mounting_std: f64,
    /// Estimate the odometer's scale error and its wheel point's lever arm as states
    /// (needs `[vehicle.odometer]`; the reading is then used from the start, its scale not
    /// calibrated outside the filter first). Default false.
    #[serde(default)]
    pub odometer: bool,
    /// The odometer's scale error's prior 1σ, %. Default 5.
    #[serde(default = "default_odometer_scale_std")]
    pub odometer_scale_std: f64,
    /// The wheel point's prior 1σ per axis about `vehicle.odometer.lever_arm`, m.
    /// Default 0.5.
    #[serde(default = "default_odometer_lever_arm_std")]
    pub odometer_lever_arm_std: f64,
}

fn default_odometer_scale_std() -> f64 {
    5.0
}

fn default_odometer_lever_arm_std() -> f64 {
    0.5
}

fn default_mounting_std() -> f64 {
    3.0
}

fn default_lever_arm_std() -> f64 {
    1.0
}

fn default_time_offset_std() -> f64 {
    0.1
}

impl Default for CalibrateSection {
    fn default() -> Self {
        Self {
            lever_arm: false,
            lever_arm_std: default_lever_arm_std(),
            time_offset: false,
            time_offset_std: default_time_offset_std(),
            mounting: false,
            mounting_std: default_mounting_std(),
            odometer: false,
            odometer_scale_std: default_odometer_scale_std(),
            odometer_lever_arm_std: default_odometer_lever_arm_std(),
        }
    }
}

impl CalibrateSection {
    pub(crate) fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// The navigator's calibration: the items estimated (the driving noises the
    /// library's).
    pub fn calibration(&self) -> ins_gnss_core::calibration::Calibration {
        ins_gnss_core::calibration::Calibration {
            lever_arm: self.lever_arm,
            time_offset: self.time_offset,
            mounting: self.mounting,
            odometer: self.odometer,
            ..Default::default()
        }
    }

    /// Whether any item is estimated.
    pub fn any(&self) -> bool {
        self.lever_arm || self.time_offset || self.mounting || self.odometer
    }

    /// The section's values checked (`calibrate.*` named in errors).
    pub(crate) fn check(&self) -> Result<(), String> {
        if !(self.lever_arm_std.is_finite() && self.lever_arm_std > 0.0) {
            return Err(format!(
                "`calibrate.lever_arm_std = {}`: metres, positive",
                self.lever_arm_std
            ));
        }
        if !(self.time_offset_std.is_finite() && self.time_offset_std > 0.0) {
            return Err(format!(
                "`calibrate.time_offset_std = {}`: seconds, positive",
                self.time_offset_std
            ));
        }
        for (key, v, unit) in [
            ("odometer_scale_std", self.odometer_scale_std, "%"),
            ("odometer_lever_arm_std", self.odometer_lever_arm_std, "metres"),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("`calibrate.{key} = {v}`: {unit}, positive"));
            }
        }
        if !(self.mounting_std.is_finite() && self.mounting_std > 0.0) {
            return Err(format!(
                "`calibrate.mounting_std = {}`: degrees, positive",
                self.mounting_std
            ));
        }
        Ok(())
    }
}
