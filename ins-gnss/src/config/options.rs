//! The options of a run that change its configuration (`ins-gnss run`'s flags, the
//! Python package's arguments): applied once, before the run, and checked as the file's
//! keys are. (The command line's other options, [`crate::cli::RunOptions`], live with it.)

use super::*;

/// The options of a run that change its configuration, as `ins-gnss run` and the Python
/// package take them.
#[derive(Clone, Copy, Debug, Default)]
pub struct Overrides<'a> {
    /// Strategy name (default: the configuration's).
    pub strategy: Option<&'a str>,
    /// Bias model name (default: the configuration's).
    pub bias_model: Option<&'a str>,
    /// Open the gross-error gate (KF-GINS's behaviour: every fix used).
    pub no_gate: bool,
    /// Keep every stream's declared noise (sets `filter.gate.learn = false`).
    pub declared_noise: bool,
    /// Turn on NHC (configured settings or defaults).
    pub nhc: bool,
    /// Turn on ZUPT/ZARU (configured settings or defaults).
    pub zupt: bool,
    /// Turn on the odometer (configured settings or defaults).
    pub odometer: bool,
    /// Turn off all vehicle aiding.
    pub no_vehicle: bool,
    /// Override `filter.states` (15 or 21).
    pub states: Option<u32>,
    /// Smooth the run (sets `filter.smooth`).
    pub smooth: bool,
    /// Override `filter.covariance_interval` (s).
    pub covariance_interval: Option<f64>,
    /// Smooth with one covariance per update in the scratch file (sets
    /// `filter.smooth_low_scratch`).
    pub smooth_low_scratch: bool,
    /// Estimate the lever arm (sets `calibrate.lever_arm`).
    pub calibrate_lever_arm: bool,
    /// Estimate the IMU–GNSS time offset (sets `calibrate.time_offset`).
    pub calibrate_time_offset: bool,
    /// Estimate the IMU's mounting (sets `calibrate.mounting`).
    pub calibrate_mounting: bool,
    /// Estimate the odometer's scale and wheel point (sets `calibrate.odometer`).
    pub calibrate_odometer: bool,
    /// A moving-base receiver's headings (sets `data.heading`).
    pub heading: Option<&'a Path>,
    /// Leave the configuration's `[init]` out: the start finds the initial state from the
    /// data.
    pub no_init: bool,
}

impl Config {
    /// This configuration with the options of a run that change it (bias model, gate,
    /// vehicle aiding, states, smoothing), checked as the file's keys are, and the
    /// strategy (the option's, or the configuration's). `ins-gnss run` and the Python
    /// package take the same options through it.
    pub fn with_options(
        &self,
        o: &Overrides<'_>,
    ) -> Result<(Config, adaptive::AnyStrategy), String> {
        let mut cfg = self.clone();
        if let Some(b) = o.bias_model {
            cfg.imu_noise.bias_model = b.parse()?;
        }
        if o.no_gate {
            cfg.filter.gate.enabled = false;
        }
        if o.declared_noise {
            cfg.filter.gate.learn = false;
        }
        if o.nhc && cfg.vehicle.nhc.is_none() {
            cfg.vehicle.nhc = Some(Default::default());
        }
        if o.zupt && cfg.vehicle.zupt.is_none() {
            cfg.vehicle.zupt = Some(Default::default());
        }
        if o.odometer && cfg.vehicle.odometer.is_none() {
            cfg.vehicle.odometer = Some(Default::default());
        }
        if o.no_vehicle {
            cfg.vehicle = Default::default();
        }
        if let Some(n) = o.states {
            cfg.filter.states = n;
        }
        if o.smooth {
            cfg.filter.smooth = true;
        }
        if let Some(c) = o.covariance_interval {
            cfg.filter.covariance_interval = c;
        }
        if o.smooth_low_scratch {
            cfg.filter.smooth_low_scratch = true;
        }
        if o.calibrate_lever_arm {
            cfg.calibrate.lever_arm = true;
        }
        if o.calibrate_time_offset {
            cfg.calibrate.time_offset = true;
        }
        if o.calibrate_mounting {
            cfg.calibrate.mounting = true;
        }
        if o.calibrate_odometer {
            cfg.calibrate.odometer = true;
        }
        if let Some(h) = o.heading {
            cfg.data.heading = Some(h.to_path_buf());
        }
        if o.no_init {
            cfg.init = Default::default();
        }
        // the options are checked as the file's keys were
        cfg.validate()?;
        let name = o.strategy.unwrap_or(&cfg.filter.strategy);
        let chosen = name.parse().map_err(|e: adaptive::UnknownStrategy| e.to_string())?;
        Ok((cfg, chosen))
    }
}
