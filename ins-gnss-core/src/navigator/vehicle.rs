//! The land-vehicle aiding in the navigator: NHC, ZUPT/ZARU on detected stops and the
//! odometer, applied at the end of each IMU sample.

use super::*;

/// The vehicle aiding's settings and bookkeeping.
#[derive(Clone, Debug, Default)]
pub(super) struct VehicleState {
    pub(super) aiding: VehicleAiding,
    pub(super) c_vb: Matrix3<f64>,
    pub(super) detector: Option<StationaryDetector>,
    pub(super) last_nhc: f64,
    pub(super) last_zupt: f64,
    pub(super) last_zaru: f64,
    /// Time judged standing (detector and speed), s.
    pub(super) stationary_time: f64,
    pub(super) last_odometer: f64,
    pub(super) odometer_scale: OdometerScale,
    /// Time of the last GNSS update (the odometer's scale is calibrated only near one).
    pub(super) last_gnss: f64,
    /// Time the odometer read motion (above [`ODOMETER_MOVING`]), and of it the time the
    /// filter's forward speed had the other sign (beyond the same speed), s.
    pub(super) odometer_reversed: (f64, f64),
}

/// A speed (m/s) at which the odometer and the filter surely tell forward from backward.
const ODOMETER_MOVING: f64 = 0.5;

/// The odometer's reading (m/s) above which its samples calibrate its scale: slower, the
/// filter's speed error is a larger part of the speed and dilutes the least-squares scale
/// (on the simulator's car, with 0.5 m/s the outages' median score was 9 % worse).
const ODOMETER_CALIBRATION_SPEED: f64 = 1.0;

impl<A: NoiseStrategy, S: NavState> Navigator<A, S>
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    /// The vehicle aiding at the end of an IMU sample: ZUPT (and ZARU) while the detector
    /// says the vehicle stands, otherwise NHC.
    pub(super) fn aid<O: Observer, R: StepRecorder<S, ImuInput>>(
        &mut self,
        imu: &ImuSample,
        observer: &mut O,
        out: &mut Vec<UpdateSummary>,
        recorder: &mut R,
    ) -> Result<(), NavError> {
        let v = &mut self.vehicle;
        let bg = self.filter.state().nav().bg;
        let imu_says = match &mut v.detector {
            Some(d) => d.push(imu.dt, &imu.rate(), &imu.specific_force(), &bg),
            None => false,
        };
        // a wheel odometer reads exactly zero when the wheels stand
        let wheels_say =
            v.aiding.odometer.is_some() && imu.odometer.is_some_and(|r| r.abs() < 1e-3);
        let stationary = imu_says || wheels_say;
        let speed = self.filter.state().nav().vel.norm();
        self.odometer_update(imu, observer, out, recorder)?;
        if self.stop_updates(imu, stationary, speed, observer, out, recorder)? {
            return Ok(());
        }
        self.nhc_update(imu, speed, observer, out, recorder)
    }

    /// One of the vehicle's updates at `t`: the coarse alignment settled, the recorder
    /// told, `update` made on the filter (with the process model), its report pushed.
    fn vehicle_update<R: StepRecorder<S, ImuInput>>(
        &mut self,
        t: f64,
        out: &mut Vec<UpdateSummary>,
        recorder: &mut R,
        update: impl FnOnce(
            &mut ErrorStateFilter<S, A>,
            &S::Model,
        ) -> Result<UpdateSummary, FilterError>,
    ) -> Result<(), NavError> {
        coarse::settle(&mut self.coarse, &mut self.filter, &self.model)?;
        recorder.before_update(&self.filter);
        let report = update(&mut self.filter, &self.model);
        out.push(report.map_err(|source| NavError::Measurement { t, source })?);
        Ok(())
    }

    /// The odometer's reading: the reversed-reading bookkeeping, its scale calibrated
    /// while GNSS keeps the forward speed right, then used as a forward speed.
    fn odometer_update<O: Observer, R: StepRecorder<S, ImuInput>>(
        &mut self,
        imu: &ImuSample,
        observer: &mut O,
        out: &mut Vec<UpdateSummary>,
        recorder: &mut R,
    ) -> Result<(), NavError> {
        let t = imu.t;
        let v = &mut self.vehicle;
        if let (Some(o), Some(reading)) = (v.aiding.odometer, imu.odometer) {
            let model = Odometer { c_vb: v.c_vb, lever_arm: o.lever_arm, gyro_rate: imu.rate() };
            let forward = model.predict(self.filter.state().nav())[0];
            if reading.abs() > ODOMETER_MOVING {
                v.odometer_reversed.0 += imu.dt;
                if forward * reading.signum() < -ODOMETER_MOVING {
                    v.odometer_reversed.1 += imu.dt;
                }
            }
            // calibrate the scale while GNSS keeps the forward speed right, on the samples
            // above [`ODOMETER_CALIBRATION_SPEED`] chosen by the reading, not by the
            // filter's speed: samples kept for a filter's speed above a threshold near the
            // vehicle's own speed are those whose speed is over-estimated (the Husky bag
            // at 1 m/s calibrated to 0.78 that way, and its track ran 18 m from its fixes)
            if t - v.last_gnss <= 1.5 && reading.abs() > ODOMETER_CALIBRATION_SPEED {
                v.odometer_scale.add(reading, forward, imu.dt, o.calibration_time);
            }
            // (with the scale as a state, the reading is used as it is from the start)
            let scale = if S::odometer_calibrated(&self.model) {
                Some(1.0)
            } else {
                v.odometer_scale.scale(o.calibration_samples)
            };
            if let (Some(k), true) = (scale, t - v.last_odometer >= o.interval - TIME_EPSILON) {
                v.last_odometer = t;
                let z = nalgebra::Vector1::new(reading / k);
                let r = nalgebra::Matrix1::new(o.std * o.std);
                self.vehicle_update(t, out, recorder, |f, p| {
                    S::update_vehicle::<A, Odometer, O>(f, p, &model, &z, &r, observer)
                })?;
            }
        }
        Ok(())
    }

    /// ZUPT (and ZARU) while `stationary` and the filter's `speed` is consistent with
    /// rest; whether the vehicle was taken as standing (then no NHC).
    #[allow(clippy::too_many_arguments)]
    fn stop_updates<O: Observer, R: StepRecorder<S, ImuInput>>(
        &mut self,
        imu: &ImuSample,
        stationary: bool,
        speed: f64,
        observer: &mut O,
        out: &mut Vec<UpdateSummary>,
        recorder: &mut R,
    ) -> Result<bool, NavError> {
        let t = imu.t;
        let v = &mut self.vehicle;
        // the filter's speed must be consistent with rest: below `max_speed` plus three of
        // its σ (tight while GNSS holds the velocity, wide in an outage, when a stop is
        // most worth taking)
        let filter = &self.filter;
        let zupt = v.aiding.zupt.filter(|z| {
            stationary && t <= z.until + TIME_EPSILON && {
                // (the σ only when standing: this runs at every IMU sample)
                let sigma = filter.sigma();
                let speed_sigma = (sigma[3].powi(2) + sigma[4].powi(2) + sigma[5].powi(2)).sqrt();
                speed < z.max_speed + z.speed_sigmas * speed_sigma
            }
        });
        if let (Some(z), Some(d)) = (zupt, &v.detector) {
            // (the detector's window and mean rate, which the updates do not change)
            let (window, mean) = (d.config().window, d.mean_rate());
            v.stationary_time += imu.dt;
            let zaru = z.rate_std.filter(|_| t - v.last_zaru >= window - TIME_EPSILON);
            if !z.zaru_only && t - v.last_zupt >= z.interval - TIME_EPSILON {
                v.last_zupt = t;
                let r = Matrix3::identity() * z.velocity_std.powi(2);
                self.vehicle_update(t, out, recorder, |f, _| {
                    S::update::<A, Zupt, O>(f, &Zupt, &Vector3::zeros(), &r, observer)
                })?;
            }
            if let Some(rate_std) = zaru {
                self.vehicle.last_zaru = t;
                // the window mean's own white noise, ARW²/window, plus the configured σ
                let window = window.max(1e-3);
                let arw = S::imu_noise(&self.model).arw;
                let r = diag3(&arw.map(|a| a * a / window + rate_std * rate_std));
                self.vehicle_update(t, out, recorder, |f, _| {
                    S::update::<A, Zaru, O>(f, &Zaru, &mean, &r, observer)
                })?;
            }
            return Ok(true);
        }
        Ok(false)
    }

    /// NHC at its interval while the filter's `speed` is at least its minimum.
    fn nhc_update<O: Observer, R: StepRecorder<S, ImuInput>>(
        &mut self,
        imu: &ImuSample,
        speed: f64,
        observer: &mut O,
        out: &mut Vec<UpdateSummary>,
        recorder: &mut R,
    ) -> Result<(), NavError> {
        let t = imu.t;
        let v = &mut self.vehicle;
        if let Some(n) = v.aiding.nhc
            && t - v.last_nhc >= n.interval - TIME_EPSILON
            && speed >= n.min_speed
        {
            v.last_nhc = t;
            let model = Nhc { c_vb: v.c_vb, lever_arm: n.lever_arm, gyro_rate: imu.rate() };
            let r = diag2(&n.std.component_mul(&n.std));
            let z = nalgebra::Vector2::zeros();
            self.vehicle_update(t, out, recorder, |f, p| {
                S::update_vehicle::<A, Nhc, O>(f, p, &model, &z, &r, observer)
            })?;
        }
        Ok(())
    }
}
