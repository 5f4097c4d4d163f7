//! [`Config::validate`] and the checks of the inputs: every value finite and physical, the key named.

use super::*;

impl Config {
    /// That each input file named exists; the error names its key (`data.imu`,
    /// `data.gnss`, `data.truth`; `imupath`, `gnsspath` in a KF-GINS YAML).
    pub fn require_inputs(&self) -> Result<(), ConfigError> {
        let files = self.data.ros.is_none();
        let inputs = [
            ("data.imu (imupath in a KF-GINS YAML)", Some(&self.data.imu).filter(|_| files)),
            ("data.gnss (gnsspath in a KF-GINS YAML)", Some(&self.data.gnss).filter(|_| files)),
            ("data.ros.recording", self.data.ros.as_ref().map(|r| &r.recording)),
            ("data.truth", self.data.truth.as_ref()),
            ("data.base", self.data.base.as_ref()),
        ];
        let navs = self.data.nav.iter().map(|n| ("data.nav", Some(n)));
        for (key, file) in inputs.into_iter().chain(navs) {
            let Some(file) = file else { continue };
            if !file.is_file() {
                let what = if file.exists() { "is not a file" } else { "does not exist" };
                return Err(ConfigError {
                    path: file.clone(),
                    message: format!(
                        "`{key}`: {what} (a relative path is read from the configuration's \
                         folder)"
                    ),
                });
            }
        }
        Ok(())
    }

    /// `[data.ros]` and what it excludes: the IMU and GNSS files, their column maps and
    /// formats, tight coupling; without it, the files are required.
    fn validate_ros(&self) -> Result<(), String> {
        let d = &self.data;
        let Some(_) = &d.ros else {
            if d.imu.as_os_str().is_empty() || d.gnss.as_os_str().is_empty() {
                return Err("`data.imu` and `data.gnss` are required (or a ROS recording in \
                            `[data.ros]`)"
                    .into());
            }
            return Ok(());
        };
        let excluded = [
            ("data.imu", !d.imu.as_os_str().is_empty()),
            ("data.gnss", !d.gnss.as_os_str().is_empty()),
            ("data.imu_columns", d.imu_columns.is_some()),
            ("data.gnss_columns", d.gnss_columns.is_some()),
            ("data.gnss_format", d.gnss_format != GnssFormatName::Auto),
            ("gnss.coupling = \"tight\"", self.gnss.coupling == Coupling::Tight),
            ("gnss.coupling = \"rtk\"", self.gnss.coupling == Coupling::Rtk),
        ];
        match excluded.iter().find(|(_, set)| *set) {
            Some((key, _)) => Err(format!(
                "`{key}` and `[data.ros]` exclude each other: the recording holds the IMU \
                 and the fixes, in the messages' own layout"
            )),
            None => Ok(()),
        }
    }

    /// `gnss.coupling = "tight"` and what it excludes: column maps and a fixes' format
    /// (the raw file names its contents).
    pub(crate) fn validate_tight(&self) -> Result<(), String> {
        self.gnss.tight.spp_options()?;
        if self.gnss.coupling == Coupling::Rtk {
            self.gnss.rtk.options()?;
            if self.data.base.is_none() {
                return Err("`gnss.coupling = \"rtk\"` needs a base station's raw observations \
                            in `data.base` (RINEX or a u-blox log)"
                    .into());
            }
        } else if self.data.base.is_some() {
            return Err("`data.base` is read by RTK only: set `gnss.coupling = \"rtk\"` (with \
                        the rover's raw observations in `data.gnss`) or remove it"
                .into());
        } else if self.gnss.rtk != RtkSection::default() {
            return Err("`[gnss.rtk]` is read by RTK only: set `gnss.coupling = \"rtk\"` or \
                        remove it"
                .into());
        }
        if !self.gnss.coupling.is_raw() {
            if !self.data.nav.is_empty() {
                return Err("`data.nav` is read by tight coupling and RTK only: set \
                            `gnss.coupling = \"tight\"` (with raw observations in \
                            `data.gnss`) or remove it"
                    .into());
            }
            return Ok(());
        }
        if self.data.gnss_columns.is_some() || self.data.gnss_format != GnssFormatName::Auto {
            return Err(format!(
                "`gnss.coupling = \"{}\"` reads `data.gnss` as RINEX observations or a u-blox \
                 log: remove `data.gnss_columns` and `data.gnss_format`",
                if self.gnss.coupling == Coupling::Rtk { "rtk" } else { "tight" }
            ));
        }
        Ok(())
    }

    /// Check that every value is finite and physically possible; the message names the
    /// key and the limit. Heights must lie within −1 km…+100 km, lever arms within 100 m,
    /// noise densities and standard deviations must be positive, the start before the
    /// end.
    pub fn validate(&self) -> Result<(), String> {
        self.validate_formats()?;
        self.validate_calibrate()?;
        self.validate_tight()?;
        self.validate_columns()?;
        self.validate_ros()?;
        self.validate_data()?;
        self.validate_init()?;
        self.validate_mounting_and_align()?;
        self.validate_scale_and_noise()?;
        self.validate_filter()?;
        self.validate_gnss()?;
        self.validate_vehicle()?;
        self.validate_strategies()?;
        Ok(())
    }

    /// The IMU's column map and each section's own checks (quality factors, error model,
    /// heading, calibration items).
    fn validate_formats(&self) -> Result<(), String> {
        let d = &self.data;
        let rates = d.imu_format == ImuFormatName::Rates;
        if let Some(c) = &d.imu_columns {
            c.map(rates).map_err(|e| format!("`data.imu_columns`: {e}"))?;
        }
        self.gnss.quality.factors()?;
        self.gnss.errors.check()?;
        self.gnss.heading.check()?;
        self.calibrate.check()?;
        Ok(())
    }

    /// `[calibrate]` and what it runs with.
    fn validate_calibrate(&self) -> Result<(), String> {
        if self.calibrate.any() {
            let with = if self.gnss.coupling == Coupling::Tight {
                Some("`gnss.coupling = \"tight\"`")
            } else if self.filter.states == 21 {
                Some("`filter.states = 21`")
            } else if self.gnss.errors.model == ErrorModel::Persisting {
                Some("`gnss.errors.model = \"persisting\"`")
            } else {
                None
            };
            if self.calibrate.mounting
                && self.vehicle.nhc.is_none()
                && self.vehicle.odometer.is_none()
            {
                return Err("`calibrate.mounting` needs `[vehicle.nhc]` or `[vehicle.odometer]`: \
                            the mounting is seen through the vehicle-frame velocity they \
                            measure"
                    .into());
            }
            if self.calibrate.odometer && self.vehicle.odometer.is_none() {
                return Err("`calibrate.odometer` needs `[vehicle.odometer]` (the odometer's \
                            scale and wheel point are seen through its readings)"
                    .into());
            }
            if let Some(with) = with {
                return Err(format!(
                    "`calibrate` runs with loose coupling, 15 states and white fix errors; \
                     not yet with {with}: calibrate the rig on such a run first, then write \
                     what it found into `gnss.lever_arm`, `data.imu_time_offset` and \
                     `vehicle.nhc.mounting`"
                ));
            }
        }
        Ok(())
    }

    /// The GNSS and truth column maps, and the σ they need.
    fn validate_columns(&self) -> Result<(), String> {
        let d = &self.data;
        if d.gnss_columns.is_some() && d.gnss_format == GnssFormatName::Rtklib {
            return Err("`data.gnss_format = \"rtklib\"` and `data.gnss_columns` exclude each \
                        other: an RTKLIB solution names its columns in its header"
                .into());
        }
        if let Some(c) = &d.gnss_columns {
            c.map().map_err(|e| format!("`data.gnss_columns`: {e}"))?;
            if c.position_std.is_none() && self.gnss.position_std.is_none() {
                return Err("`data.gnss_columns` names no `position_std` columns: set \
                            `gnss.position_std` (m) for the fixes"
                    .into());
            }
            if c.velocity.is_some()
                && c.velocity_std.is_none()
                && self.gnss.velocity_std.is_none()
                && self.gnss.use_velocity
            {
                return Err(
                    "`data.gnss_columns` has a `velocity` but no `velocity_std` \
                            columns: set `gnss.velocity_std` (m/s), or `gnss.use_velocity = false`"
                        .into(),
                );
            }
        }
        if let Some(c) = &d.truth_columns {
            c.map().map_err(|e| format!("`data.truth_columns`: {e}"))?;
        }
        Ok(())
    }

    /// `[data]`: the IMU rate, gaps, time offset and the time span.
    fn validate_data(&self) -> Result<(), String> {
        let d = &self.data;
        finite("data.imu_rate", &[d.imu_rate])?;
        let from_recording = d.ros.is_some() && d.imu_rate == 0.0;
        let in_range = d.imu_rate > 0.0 && d.imu_rate <= 100_000.0;
        if !(from_recording || in_range) {
            return Err(format!(
                "`data.imu_rate` must be positive and at most 100 kHz (Hz), got {}",
                d.imu_rate
            ));
        }
        finite("data.max_gap", &[d.max_gap])?;
        if d.max_gap < 1.0 {
            return Err(format!(
                "`data.max_gap` must be at least 1 (IMU intervals), got {}",
                d.max_gap
            ));
        }
        finite("data.max_bridge", &[d.max_bridge])?;
        finite("data.imu_time_offset", &[d.imu_time_offset])?;
        if d.max_bridge < d.max_gap {
            return Err(format!(
                "`data.max_bridge` ({}) must be at least `data.max_gap` ({}) (IMU intervals)",
                d.max_bridge, d.max_gap
            ));
        }
        if let Some(t) = d.start_time {
            finite("data.start_time", &[t])?;
        }
        if let Some(t) = d.end_time {
            finite("data.end_time", &[t])?;
        }
        if let (Some(s), Some(e)) = (d.start_time, d.end_time)
            && s >= e
        {
            return Err(format!(
                "`data.start_time` ({s} s) must be before `data.end_time` ({e} s)"
            ));
        }
        Ok(())
    }

    /// `[init]`: every value finite and physical, every σ positive.
    fn validate_init(&self) -> Result<(), String> {
        let i = &self.init;
        for (key, v) in [
            ("init.position", i.position),
            ("init.velocity", i.velocity),
            ("init.attitude", i.attitude),
            ("init.gyro_bias", i.gyro_bias),
            ("init.accel_bias", i.accel_bias),
        ] {
            if let Some(v) = v {
                finite(key, &v)?;
            }
        }
        if let Some(p) = i.position {
            if p[0].abs() > 90.0 || p[1].abs() > 360.0 {
                return Err(format!(
                    "`init.position` latitude/longitude out of range (degrees): {p:?}"
                ));
            }
            if !(-1_000.0..=100_000.0).contains(&p[2]) {
                return Err(format!("`init.position` height {} m is outside −1 km…+100 km", p[2]));
            }
        }
        if let Some(v) = i.velocity
            && v.iter().any(|v| v.abs() > 2_000.0)
        {
            return Err(format!("`init.velocity` {v:?} m/s: a component beyond 2 km/s"));
        }
        for (key, v) in [
            ("init.position_std", i.position_std),
            ("init.velocity_std", i.velocity_std),
            ("init.attitude_std", i.attitude_std),
            ("init.gyro_bias_std", i.gyro_bias_std),
            ("init.accel_bias_std", i.accel_bias_std),
        ] {
            if let Some(v) = v {
                positive(key, &v)?;
            }
        }
        Ok(())
    }

    /// The IMU's mounting and `[align]`.
    fn validate_mounting_and_align(&self) -> Result<(), String> {
        if let Some(m) = &self.imu.mounting {
            m.matrix().map_err(|e| format!("`imu.mounting`: {e}"))?;
        }
        let a = &self.align;
        positive("align.static_window", &[a.static_window])?;
        nonneg("align.min_static", &[a.min_static])?;
        positive("align.max_time", &[a.max_time])?;
        positive("align.heading_std", &[a.heading_std])?;
        Ok(())
    }

    /// The scale factors' start and `[imu_noise]`.
    fn validate_scale_and_noise(&self) -> Result<(), String> {
        let (d, i) = (&self.data, &self.init);
        finite("init.gyro_scale", &i.gyro_scale)?;
        finite("init.accel_scale", &i.accel_scale)?;
        if i.gyro_scale.iter().chain(&i.accel_scale).any(|v| v.abs() >= 1e5) {
            return Err(format!(
                "`init.gyro_scale`/`init.accel_scale` {:?} / {:?} ppm: a scale factor of 10 % or \
                 more is not a calibration error",
                i.gyro_scale, i.accel_scale
            ));
        }
        positive("init.gyro_scale_std", &i.gyro_scale_std)?;
        positive("init.accel_scale_std", &i.accel_scale_std)?;
        let n = &self.imu_noise;
        if n.from_static {
            if n.arw != [0.0; 3] || n.vrw != [0.0; 3] {
                return Err("`imu_noise.from_static` measures `arw` and `vrw` on the static \
                            start: give either, not both"
                    .into());
            }
        } else {
            let from_recording = d.ros.as_ref().is_some_and(|r| r.imu_noise_from_covariance);
            if from_recording && (n.arw != [0.0; 3] || n.vrw != [0.0; 3]) {
                return Err("`data.ros.imu_noise_from_covariance` takes `imu_noise.arw` and \
                            `imu_noise.vrw` from the recording; remove one or the other"
                    .into());
            }
            if !from_recording {
                if n.arw == [0.0; 3] || n.vrw == [0.0; 3] {
                    return Err("missing `imu_noise.arw` (deg/√h) and `imu_noise.vrw` (m/s/√h), \
                                or `imu_noise.from_static = true` to measure them on the \
                                static start"
                        .into());
                }
                positive("imu_noise.arw", &n.arw)?;
                positive("imu_noise.vrw", &n.vrw)?;
            }
        }
        self.check_bias_noise()?;
        positive("imu_noise.gyro_scale_std", &n.gyro_scale_std)?;
        positive("imu_noise.accel_scale_std", &n.accel_scale_std)?;
        Ok(())
    }

    /// `[filter]`: the covariance interval and the number of states.
    fn validate_filter(&self) -> Result<(), String> {
        let n = &self.imu_noise;
        let ci = self.filter.covariance_interval;
        if !(ci.is_finite() && (0.0..=1.0).contains(&ci)) {
            return Err(format!(
                "`filter.covariance_interval` (`--covariance-interval`) must be between 0 and 1 \
                 s, got {ci} (0: at every IMU sample)"
            ));
        }
        if self.filter.states != 15 && self.filter.states != 21 {
            return Err(format!("`filter.states` must be 15 or 21, got {}", self.filter.states));
        }
        if self.filter.states == 21 && n.corr_time.is_none() {
            return Err("21 states need `imu_noise.corr_time` (hours): the scale factors' \
                        instability is a Gauss–Markov σ with that correlation time"
                .into());
        }
        Ok(())
    }

    /// `[gnss]`'s lever arm and σ, and the gross-error gate.
    fn validate_gnss(&self) -> Result<(), String> {
        finite("gnss.lever_arm", &self.gnss.lever_arm)?;
        // (plausibility before the run: a lever arm in cm or mm given in m ran to a wrong
        // result that no innovation test could tell, the antenna's offset turning with
        // the vehicle being taken up by the attitude)
        let lever = self.gnss.lever_arm.iter().map(|v| v * v).sum::<f64>().sqrt();
        if lever > MAX_LEVER_ARM {
            return Err(format!(
                "`gnss.lever_arm` {:?} m is {lever:.1} m long, beyond the {MAX_LEVER_ARM} m \
                 of any vehicle's antenna from its IMU: a value in cm or mm given in m?",
                self.gnss.lever_arm
            ));
        }
        if let Some(s) = &self.gnss.position_std {
            positive("gnss.position_std", s)?;
        }
        if let Some(s) = &self.gnss.velocity_std {
            positive("gnss.velocity_std", s)?;
        }
        let g = &self.filter.gate;
        finite("filter.gate.probability", &[g.probability])?;
        if !(g.probability > 0.0 && g.probability < 0.5) {
            return Err(format!(
                "`filter.gate.probability` must lie in (0, 0.5): the chance that a consistent \
                 innovation is refused, e.g. 1e-6; got {}",
                g.probability
            ));
        }
        if g.readmit_after == 0 {
            return Err("`filter.gate.readmit_after` must be at least 1".into());
        }
        Ok(())
    }

    /// `[vehicle]`: the NHC, the odometer, ZUPT.
    fn validate_vehicle(&self) -> Result<(), String> {
        if let Some(n) = &self.vehicle.nhc {
            finite("vehicle.nhc.mounting", &n.mounting)?;
            if n.mounting.iter().any(|a| a.abs() > 180.0) {
                return Err(format!(
                    "`vehicle.nhc.mounting` {:?}: angles in degrees within ±180",
                    n.mounting
                ));
            }
            finite("vehicle.nhc.lever_arm", &n.lever_arm)?;
            if n.lever_arm.iter().any(|v| v.abs() > 100.0) {
                return Err(format!(
                    "`vehicle.nhc.lever_arm` {:?} m: a component beyond the 100 m limit",
                    n.lever_arm
                ));
            }
            positive("vehicle.nhc.std", &n.std)?;
            nonneg("vehicle.nhc.interval", &[n.interval])?;
            nonneg("vehicle.nhc.min_speed", &[n.min_speed])?;
        }
        if let Some(o) = &self.vehicle.odometer {
            finite("vehicle.odometer.lever_arm", &o.lever_arm)?;
            if o.lever_arm.iter().any(|v| v.abs() > 100.0) {
                return Err(format!(
                    "`vehicle.odometer.lever_arm` {:?} m: a component beyond the 100 m limit",
                    o.lever_arm
                ));
            }
            positive("vehicle.odometer.std", &[o.std])?;
            nonneg("vehicle.odometer.interval", &[o.interval])?;
            positive("vehicle.odometer.calibration_time", &[o.calibration_time])?;
            positive("vehicle.odometer.calibration_samples", &[o.calibration_samples])?;
        }
        if let Some(z) = &self.vehicle.zupt {
            positive("vehicle.zupt.window", &[z.window])?;
            positive("vehicle.zupt.gyro_max", &[z.gyro_max])?;
            positive("vehicle.zupt.accel_std_max", &[z.accel_std_max])?;
            positive("vehicle.zupt.velocity_std", &[z.velocity_std])?;
            nonneg("vehicle.zupt.rate_std", &[z.rate_std])?;
            nonneg("vehicle.zupt.interval", &[z.interval])?;
            positive("vehicle.zupt.max_speed", &[z.max_speed])?;
            nonneg("vehicle.zupt.speed_sigmas", &[z.speed_sigmas])?;
        }
        Ok(())
    }

    /// `filter.strategy` and `filter.streams`: names that parse, streams that exist.
    fn validate_strategies(&self) -> Result<(), String> {
        self.filter
            .strategy
            .parse::<adaptive::AnyStrategy>()
            .map_err(|e| format!("`filter.strategy`: {e}"))?;
        for (stream, name) in &self.filter.streams {
            if !STREAMS.iter().any(|s| s.name() == stream) {
                let names: Vec<_> = STREAMS.iter().map(|s| s.name()).collect();
                return Err(format!(
                    "`filter.streams`: unknown stream `{stream}`; the streams are {}",
                    names.join(", ")
                ));
            }
            name.parse::<adaptive::AnyStrategy>()
                .map_err(|e| format!("`filter.streams.{stream}`: {e}"))?;
        }
        Ok(())
    }

    /// Either the instability with its correlation time or the random walk, per sensor,
    /// each once; a random walk only with `bias_model = "random-walk"`.
    pub(crate) fn check_bias_noise(&self) -> Result<(), String> {
        let n = &self.imu_noise;
        let rw_model = n.bias_model == BiasModelName::RandomWalk;
        for (sensor, std, rw, rw_si, unit) in [
            ("gyro", n.gyro_bias_std, n.gyro_bias_rw, n.gyro_bias_rw_si, "deg/h"),
            ("accel", n.accel_bias_std, n.accel_bias_rw, n.accel_bias_rw_si, "mGal"),
        ] {
            let given: Vec<String> = [
                std.map(|_| format!("imu_noise.{sensor}_bias_std")),
                rw.map(|_| format!("imu_noise.{sensor}_bias_rw")),
                rw_si.map(|_| format!("imu_noise.{sensor}_bias_rw_si")),
            ]
            .into_iter()
            .flatten()
            .collect();
            match given.len() {
                0 => {
                    return Err(format!(
                        "missing `imu_noise.{sensor}_bias_std` ({unit}, with `corr_time`) or \
                         `imu_noise.{sensor}_bias_rw` ({unit}/√h; `_si`: SI per √s)"
                    ));
                }
                1 => {}
                _ => {
                    return Err(format!(
                        "`{}`: give the bias noise once, either as an instability with \
                         `corr_time` or as a random walk",
                        given.join("`, `")
                    ));
                }
            }
            if let Some(v) = std {
                positive(&format!("imu_noise.{sensor}_bias_std"), &v)?;
                match n.corr_time {
                    None => {
                        return Err(format!(
                            "`imu_noise.{sensor}_bias_std` needs `imu_noise.corr_time` (hours)"
                        ));
                    }
                    Some(t) => {
                        finite("imu_noise.corr_time", &[t])?;
                        if t <= 0.0 {
                            return Err(format!(
                                "`imu_noise.corr_time` must be positive (hours), got {t}"
                            ));
                        }
                    }
                }
            }
            for (key, v) in [("rw", rw), ("rw_si", rw_si)] {
                if let Some(v) = v {
                    positive(&format!("imu_noise.{sensor}_bias_{key}"), &v)?;
                    if !rw_model {
                        return Err(format!(
                            "`imu_noise.{sensor}_bias_{key}` is a random walk: it needs \
                             `bias_model = \"random-walk\"` (a Gauss–Markov model needs \
                             `{sensor}_bias_std` and `corr_time`)"
                        ));
                    }
                }
            }
        }
        Ok(())
    }
}
