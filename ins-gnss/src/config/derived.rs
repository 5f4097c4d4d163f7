//! The configurations the program derives from the user's to try a hypothesis or to run
//! again (the user's is never changed: each is a new configuration, and each change is
//! named here): the fixes' error model a bank of runs judges, a bank's pass, and the IMU's
//! stamps shifted by the offset the start or the filter found.

use super::*;

impl Config {
    /// Whether the start reads the data at all: checks on, or a part of the configuration
    /// to fill, or the noise's static floor.
    pub fn start_looks_at_data(&self) -> bool {
        self.align.checks || self.start_fills() || self.start_floors()
    }

    /// Whether the start fills a part of the configuration from the data: `[init]`
    /// incomplete or the noise `from_static`. (Otherwise it only checks.)
    pub fn start_fills(&self) -> bool {
        !self.init.is_complete() || self.imu_noise.from_static
    }

    /// Whether the start may raise the noise to the static start's floor (it reads the
    /// data until the static start ends).
    pub fn start_floors(&self) -> bool {
        self.imu_noise.static_floor && !self.imu_noise.from_static
    }

    /// With the fixes' errors white (`gnss.errors.model = "white"`): the bank's white
    /// hypothesis, or its choice.
    pub fn with_white_fix_errors(&self) -> Config {
        let mut c = self.clone();
        c.gnss.errors.model = ErrorModel::White;
        c
    }

    /// With a persisting part of the fixes' errors of σ `sigma` (N, E, D; m) and
    /// correlation time `tau` (s) as states, the white part's scale learned: a hypothesis
    /// of the fix-error bank, or its choice.
    pub fn with_persisting_fix_errors(&self, sigma: Vector3<f64>, tau: f64) -> Config {
        let mut c = self.clone();
        c.gnss.errors.model = ErrorModel::Persisting;
        c.gnss.errors.sigma = Some(sigma.into());
        c.gnss.errors.tau = tau;
        c.gnss.errors.learn = true;
        c
    }

    /// For a bank's pass: not smoothed, and without the checks that run beside the filter
    /// when the start is given (they only refuse or let go, and the run after the bank
    /// makes them).
    pub fn for_bank_pass(&self) -> Config {
        let mut c = self.clone();
        c.filter.smooth = false;
        if !(c.start_fills() || c.calibrate.time_offset) {
            c.align.checks = false;
        }
        c
    }

    /// With the gross-error gate open (the papers' filters have none: their
    /// reproductions run without it, the strategy alone deciding).
    pub fn with_gate_open(&self) -> Config {
        let mut c = self.clone();
        c.filter.gate.enabled = false;
        c
    }

    /// With the IMU's stamps shifted by `offset` s (`data.imu_time_offset`): the offset
    /// the start's search or the calibration state found, applied for a run again.
    pub fn with_imu_time_offset(&self, offset: f64) -> Config {
        let mut c = self.clone();
        c.data.imu_time_offset = offset;
        c
    }
}

/// What a ROS recording (`[data.ros]`) gives a configuration, in its units, where the
/// configuration leaves it: the IMU's rate, its noise from the messages' covariances
/// (when `data.ros.imu_noise_from_covariance` asks), and from the static transforms the
/// IMU's mounting and the antenna's and the odometer's lever arms.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FromRecording {
    /// The IMU messages' median rate, Hz (taken when `data.imu_rate` is 0).
    pub imu_rate: f64,
    /// ARW (deg/√h) and VRW (m/s/√h) per axis.
    pub noise: Option<([f64; 3], [f64; 3])>,
    /// The IMU's axes in the FRD body frame (rows).
    pub mounting: Option<[[f64; 3]; 3]>,
    /// The antenna from the IMU, FRD, m (taken when `gnss.lever_arm` is 0).
    pub lever_arm: Option<[f64; 3]>,
    /// The odometer's point from the IMU, FRD, m (taken when its lever arm is 0).
    pub odometer_lever_arm: Option<[f64; 3]>,
}

impl Config {
    /// This configuration completed by what its recording gives (`from`), the IMU read as
    /// rates, and checked as a file's keys are.
    pub fn completed_by_recording(&self, from: &FromRecording) -> Result<Config, String> {
        let mut c = self.clone();
        c.data.imu_format = ImuFormatName::Rates;
        if c.data.imu_rate == 0.0 {
            c.data.imu_rate = from.imu_rate;
        }
        if let Some((arw, vrw)) = from.noise {
            (c.imu_noise.arw, c.imu_noise.vrw) = (arw, vrw);
            // taken: the run's configuration gives them now
            if let Some(r) = c.data.ros.as_mut() {
                r.imu_noise_from_covariance = false;
            }
        }
        if let Some(m) = from.mounting {
            c.imu.mounting = Some(Mounting::Matrix(m));
        }
        if let Some(l) = from.lever_arm {
            c.gnss.lever_arm = l;
        }
        if let (Some(o), Some(l)) = (c.vehicle.odometer.as_mut(), from.odometer_lever_arm) {
            o.lever_arm = l;
        }
        c.validate()?;
        Ok(c)
    }
}
