//! From the datasheet units of a configuration to the filter's SI settings.

use super::*;

impl Config {
    /// The run's strategy: `default` on every stream and the strategies of
    /// `filter.streams` on theirs, behind the gross-error gate of `filter.gate` (open when
    /// `filter.gate.enabled = false`).
    pub fn strategy(
        &self,
        default: adaptive::AnyStrategy,
    ) -> Result<adaptive::GrossErrorGate<adaptive::PerStream<adaptive::AnyStrategy>>, ConfigError>
    {
        let inner = self.stream_strategies(default)?;
        let g = &self.filter.gate;
        Ok(if g.enabled {
            adaptive::GrossErrorGate::new(inner, g.probability, g.readmit_after)
                .with_mode(g.mode.into())
                .with_learning(g.learn)
                .without_learning_on(&VEHICLE_STREAMS)
        } else {
            adaptive::GrossErrorGate::disabled(inner)
        })
    }

    /// `default` on every stream, and the strategies of `filter.streams` on theirs.
    pub fn stream_strategies(
        &self,
        default: adaptive::AnyStrategy,
    ) -> Result<adaptive::PerStream<adaptive::AnyStrategy>, ConfigError> {
        let err = |message: String| ConfigError { path: PathBuf::from("filter.streams"), message };
        let mut s = adaptive::PerStream::new(default);
        // the vehicle's pseudo-measurements keep their configured noise unless named:
        // an R-estimating strategy would learn the tuning of a constraint, not a sensor
        for id in VEHICLE_STREAMS {
            s = s.with(id, adaptive::AnyStrategy::default());
        }
        for (stream, name) in &self.filter.streams {
            let id = *STREAMS
                .iter()
                .find(|s| s.name() == stream)
                .ok_or_else(|| err(format!("unknown stream `{stream}`")))?;
            s = s.with(id, name.parse().map_err(|e| err(format!("{e}")))?);
        }
        Ok(s)
    }

    /// The IMU noise in SI units.
    pub fn imu_noise(&self) -> ImuNoise {
        let n = &self.imu_noise;
        // (validated: the instability and τ are there unless a random walk is given)
        let tau_h = n.corr_time.unwrap_or(1.0);
        let noise = ImuNoise::from_datasheet(
            v3(n.arw),
            v3(n.vrw),
            v3(n.gyro_bias_std.unwrap_or_default()),
            v3(n.accel_bias_std.unwrap_or_default()),
            tau_h,
        );
        let tau = tau_h * 3600.0;
        let mut noise = noise.with_bias_model(match n.bias_model {
            BiasModelName::RandomWalk => BiasModel::RandomWalk,
            BiasModelName::GaussMarkov => BiasModel::GaussMarkov { tau },
            BiasModelName::GaussMarkovHeld => BiasModel::GaussMarkovHeld { tau },
        });
        // a random walk given as such replaces the density σ √(2/τ)
        if let Some(q) = self.gyro_bias_rw() {
            noise.gyro_bias = q;
        }
        if let Some(q) = self.accel_bias_rw() {
            noise.accel_bias = q;
        }
        noise
    }

    /// The gyro bias random walk given (`gyro_bias_rw` or `gyro_bias_rw_si`), rad/s/√s.
    pub(crate) fn gyro_bias_rw(&self) -> Option<Vector3<f64>> {
        let n = &self.imu_noise;
        n.gyro_bias_rw.map(|q| v3(q) * (DEG_PER_H / 60.0)).or(n.gyro_bias_rw_si.map(v3))
    }

    /// The accelerometer bias random walk given, m/s²/√s.
    pub(crate) fn accel_bias_rw(&self) -> Option<Vector3<f64>> {
        let n = &self.imu_noise;
        n.accel_bias_rw.map(|q| v3(q) * (MGAL / 60.0)).or(n.accel_bias_rw_si.map(v3))
    }

    /// `[init]` in SI units: what it gives, converted once (the start,
    /// [`crate::start::Starter`], completes the rest from the data).
    pub fn initial_parts(&self) -> InitialParts {
        let i = &self.init;
        let d = core::f64::consts::PI / 180.0;
        InitialParts {
            attitude: i.attitude.map(|a| v3(a) * d),
            attitude_std: i.attitude_std.map(|a| v3(a) * d),
            position: i.position.map(|p| GeoPos::from_degrees(p[0], p[1], p[2])),
            position_std: i.position_std.map(v3),
            velocity: i.velocity.map(v3),
            velocity_std: i.velocity_std.map(v3),
            gyro_bias: i.gyro_bias.map(|b| v3(b) * DEG_PER_H),
            gyro_bias_std: i.gyro_bias_std.map(|b| v3(b) * DEG_PER_H),
            accel_bias: i.accel_bias.map(|b| v3(b) * MGAL),
            accel_bias_std: i.accel_bias_std.map(|b| v3(b) * MGAL),
        }
    }

    /// GNSS settings.
    pub fn gnss_config(&self) -> GnssConfig {
        GnssConfig {
            lever_arm: v3(self.gnss.lever_arm),
            use_velocity: self.gnss.use_velocity,
            pos_std: self.gnss.position_std.map(v3),
            vel_std: self.gnss.velocity_std.map(v3),
            fix_errors: self.gnss.errors.split(),
            heading: self.gnss.heading.config(),
        }
    }

    /// The scale factors' process noise in SI units (fractions), in the convention of the
    /// bias model.
    pub fn scale_factor_noise(&self) -> ScaleFactorNoise {
        let n = &self.imu_noise;
        let model = self.imu_noise().bias_model;
        ScaleFactorNoise::from_ppm(
            v3(n.gyro_scale_std),
            v3(n.accel_scale_std),
            model,
            n.corr_time.unwrap_or(1.0) * 3600.0,
        )
    }

    /// The initial scale factors and their 1σ (fractions).
    pub fn scale_init(&self) -> ScaleInit {
        let i = &self.init;
        ScaleInit {
            sg: v3(i.gyro_scale) * 1e-6,
            sa: v3(i.accel_scale) * 1e-6,
            sg_std: v3(i.gyro_scale_std) * 1e-6,
            sa_std: v3(i.accel_scale_std) * 1e-6,
        }
    }

    /// The vehicle aiding in SI units.
    pub fn vehicle_aiding(&self) -> VehicleAiding {
        let d = core::f64::consts::PI / 180.0;
        VehicleAiding {
            nhc: self.vehicle.nhc.as_ref().map(|n| NhcConfig {
                mounting: v3(n.mounting) * d,
                lever_arm: v3(n.lever_arm),
                std: nalgebra::Vector2::new(n.std[0], n.std[1]),
                interval: n.interval,
                min_speed: n.min_speed,
            }),
            zupt: self.vehicle.zupt.as_ref().map(|z| ZuptConfig {
                detector: DetectorConfig {
                    window: z.window,
                    gyro_max: z.gyro_max * d,
                    accel_std_max: z.accel_std_max,
                },
                velocity_std: z.velocity_std,
                rate_std: (z.rate_std > 0.0).then_some(z.rate_std * d),
                interval: z.interval,
                max_speed: z.max_speed,
                speed_sigmas: z.speed_sigmas,
                until: f64::INFINITY,
                zaru_only: false,
            }),
            odometer: self.vehicle.odometer.as_ref().map(|o| OdometerConfig {
                lever_arm: v3(o.lever_arm),
                std: o.std,
                interval: o.interval,
                calibration_time: o.calibration_time,
                calibration_samples: o.calibration_samples,
            }),
        }
    }

    /// The mechanization; a flat Earth's reference is `start`, the initial position.
    pub fn mechanization(&self, start: GeoPos) -> Mechanization {
        match self.filter.mechanization {
            MechanizationName::Wgs84 => Mechanization::Wgs84,
            MechanizationName::FlatEarth => Mechanization::FlatEarth { reference: start },
        }
    }

    /// IMU format.
    pub fn imu_format(&self) -> ImuFormat {
        match self.data.imu_format {
            ImuFormatName::Increments => ImuFormat::Increments,
            ImuFormatName::Rates => ImuFormat::Rates,
        }
    }

    /// Bad-line policy.
    pub fn bad_lines(&self) -> BadLinePolicy {
        match self.data.bad_lines {
            PolicyName::Error => BadLinePolicy::Error,
            PolicyName::Skip => BadLinePolicy::Skip,
        }
    }
}

/// The initial state's parts in SI units (attitude as roll, pitch, heading in rad; biases
/// in rad/s and m/s²): `[init]` converted once ([`Config::initial_parts`]), then completed
/// by the start from the data. A part `None` is neither given nor found.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct InitialParts {
    /// Roll, pitch, heading, rad.
    pub attitude: Option<Vector3<f64>>,
    /// Their 1σ, rad.
    pub attitude_std: Option<Vector3<f64>>,
    /// Geodetic position.
    pub position: Option<GeoPos>,
    /// Its 1σ (north, east, down), m.
    pub position_std: Option<Vector3<f64>>,
    /// NED velocity, m/s.
    pub velocity: Option<Vector3<f64>>,
    /// Its 1σ, m/s.
    pub velocity_std: Option<Vector3<f64>>,
    /// Gyro bias, rad/s.
    pub gyro_bias: Option<Vector3<f64>>,
    /// Its 1σ, rad/s.
    pub gyro_bias_std: Option<Vector3<f64>>,
    /// Accelerometer bias, m/s².
    pub accel_bias: Option<Vector3<f64>>,
    /// Its 1σ, m/s².
    pub accel_bias_std: Option<Vector3<f64>>,
}

impl InitialParts {
    /// The initial position (the equator at sea level when neither given nor found).
    pub fn position(&self) -> GeoPos {
        self.position.unwrap_or(GeoPos::new(0.0, 0.0, 0.0))
    }

    /// The initial state at `time`: a missing value is 0, a missing accelerometer bias 1σ
    /// [`DEFAULT_ACCEL_BIAS_STD`] (the start refuses a run whose other 1σ it cannot give).
    pub fn initial_state(&self, time: f64) -> InitialState {
        let get = |v: Option<Vector3<f64>>| v.unwrap_or_default();
        let att = get(self.attitude);
        let state = InsState {
            att: So3::from_euler(att.x, att.y, att.z),
            vel: get(self.velocity),
            pos: self.position(),
            bg: get(self.gyro_bias),
            ba: get(self.accel_bias),
        };
        let std = InitialStd {
            att: get(self.attitude_std),
            vel: get(self.velocity_std),
            pos: get(self.position_std),
            bg: get(self.gyro_bias_std),
            ba: self.accel_bias_std.unwrap_or_else(|| v3(DEFAULT_ACCEL_BIAS_STD) * MGAL),
        };
        InitialState { time, state, std }
    }
}

/// The noise densities the filter uses, SI, for the run summary.
pub fn noise_echo(n: &ImuNoise) -> String {
    let f = |v: &Vector3<f64>| format!("[{:.3e}, {:.3e}, {:.3e}]", v.x, v.y, v.z);
    let bias = match n.bias_model {
        BiasModel::RandomWalk => format!(
            "bias random walk gyro {} rad/s/√s, accel {} m/s²/√s",
            f(&n.gyro_bias),
            f(&n.accel_bias)
        ),
        BiasModel::GaussMarkov { tau } | BiasModel::GaussMarkovHeld { tau } => format!(
            "bias Gauss–Markov σ gyro {} rad/s, accel {} m/s², τ {tau:.0} s",
            f(&n.gyro_bias),
            f(&n.accel_bias)
        ),
    };
    format!("noise (SI): ARW {} rad/√s, VRW {} m/s/√s; {bias}", f(&n.arw), f(&n.vrw))
}
