//! The INS/GNSS navigator: the 15-state error-state filter driven by IMU samples, with
//! GNSS epochs applied at their exact time.
//!
//! A GNSS epoch that falls inside an IMU interval `(t − dt, t]` splits it: the increments
//! are shared linearly, the filter is propagated to the GNSS time, updated, then
//! propagated over the rest of the interval (no snapping to the nearest IMU epoch).
//!
//! Rooms: this file holds the navigator, its start and the IMU/GNSS loop; `state` the
//! navigation states it runs ([`NavState`], [`OnNav`]); `vehicle` the land-vehicle
//! aiding at the end of each sample; `tight` the raw epochs of tight coupling
//! ([`TightState`], [`RawEpoch`], [`TightConfig`]).

use core::fmt;
use core::marker::PhantomData;

use estimator_core::{
    Cov, DimAlloc, ErrorStateFilter, FilterAlloc, FilterError, FixedNoise, JacobiansOf, Manifold,
    MeasurementJacobians, MeasurementModel, NoiseStrategy, Observer, StateDim, StepRecorder,
    StreamId, UpdateSummary,
};
use manifolds::Tangent;
use nalgebra::allocator::Allocator;
use nalgebra::{
    Const, DefaultAllocator, DimName, Matrix, Matrix3, OMatrix, OVector, RawStorage, SMatrix,
    Vector3,
};

use crate::calibration::{InsModelCal, InsStateCal};
use crate::fix_error::{InsModel21Fe, InsModelFe, InsState21Fe, InsStateFe};
use crate::gnss::{GnssEpoch, GnssFixModel, GnssPosVel, GnssPosition};
use crate::imu::ImuNoise;
use crate::imu::ImuSample;
use crate::model::{ImuInput, InsModel, M15};
use crate::scale::{InsModel21, InsState21, M21};
use crate::state::InsState;
use crate::tight::{
    Antenna, InsModelTc, InsModelTc21, InsStateTc, InsStateTc21, OnTc, Pseudorange, RangeRate, M20,
    M26,
};
use crate::vehicle::VehicleModel;
use ::gnss::atmosphere::Klobuchar;
use ::gnss::spp::{azel, code_noise_variance, corrections, Prepared, SppOptions};
use ::gnss::GpsTime;
use ::gnss::System;

mod coarse;
mod setup;
mod state;
mod tight;
mod vehicle;

pub use setup::*;
pub use state::{NavAlloc, NavState, OnFixError, OnNav};
pub use tight::{
    satellite_error_floor, ClockInit, RawEpoch, TightConfig, TightState, CARRIER_MAX_GAP, SLIP_RATE,
};
use vehicle::VehicleState;

use crate::vehicle::{
    mounting_matrix, Nhc, Odometer, OdometerScale, StationaryDetector, VehicleAiding, Zaru, Zupt,
};

/// Two times closer than this are the same epoch, s.
pub const TIME_EPSILON: f64 = 1e-6;

/// The INS/GNSS navigator over any noise strategy, on the 15-state [`InsState`]
/// (default) or the 21-state [`InsState21`].
#[derive(Clone, Debug)]
pub struct Navigator<A: NoiseStrategy = FixedNoise, S: NavState = InsState>
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    filter: ErrorStateFilter<S, A>,
    model: S::Model,
    gnss: GnssConfig,
    prev: Option<ImuSample>,
    rate: Vector3<f64>,
    time: f64,
    vehicle: VehicleState,
    /// Tight coupling: the covariance of position (NED) and GPS clock the last raw
    /// epoch's persisting satellite errors leave a single point ([`satellite_error_floor`]).
    floor: Option<nalgebra::Matrix4<f64>>,
    /// Tight coupling: the last raw epoch's carrier phases, for the next one's
    /// time-differenced updates.
    carrier: Option<CarrierEpoch>,
    /// The covariance at a lower rate than the state (`None`: at every sample).
    coarse: Option<coarse::Coarse<S>>,
    /// The fixes' noise scale learned from their innovations (a state with the fixes'
    /// persisting error only).
    fix_split: crate::fix_error::FixSplitLearner,
    /// The last fix's time (for the split's memory).
    fix_split_time: Option<f64>,
}

/// What the time-differenced carrier phase needs of the last raw epoch.
#[derive(Clone, Debug)]
struct CarrierEpoch {
    /// Time, s.
    t: f64,
    /// The antenna (ECEF) after that epoch's updates.
    anchor: Vector3<f64>,
    /// Per satellite: its phase (m), position (ECEF) and clock (s) at transmission, and
    /// the atmosphere's delay of the phase `T − I` (m).
    sats: Vec<(::gnss::Sat, f64, Vector3<f64>, f64, f64)>,
}

impl<A: NoiseStrategy, S: NavState> Navigator<A, S>
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    /// A navigator at `start` (the state is the start's: see [`NavStart`] for the
    /// starts there are), with process model `model`, noise strategy and GNSS settings.
    ///
    /// ```
    /// use estimator_core::FixedNoise;
    /// use ins_gnss_core::navigator::{InitialStd, ScaleInit};
    /// use ins_gnss_core::scale::{InsModel21, ScaleFactorNoise};
    /// use ins_gnss_core::*;
    /// use manifolds::So3;
    /// use nalgebra::Vector3;
    ///
    /// let z = Vector3::zeros();
    /// let state = InsState {
    ///     att: So3::identity(),
    ///     vel: z,
    ///     pos: GeoPos::from_degrees(30.5, 114.4, 20.0),
    ///     bg: z,
    ///     ba: z,
    /// };
    /// let std = InitialStd {
    ///     att: Vector3::repeat(0.01),
    ///     vel: Vector3::repeat(0.1),
    ///     pos: Vector3::repeat(1.0),
    ///     bg: Vector3::repeat(1e-4),
    ///     ba: Vector3::repeat(1e-3),
    /// };
    /// let init = InitialState { time: 0.0, state, std };
    /// let noise = ImuNoise::from_datasheet(Vector3::repeat(0.2), Vector3::repeat(0.4),
    ///     Vector3::repeat(10.0), Vector3::repeat(200.0), 1.0);
    /// let model = InsModel::wgs84(noise);
    /// let gnss = GnssConfig::default();
    ///
    /// // the 15-state INS
    /// let nav = Navigator::new(&init, model.clone(), FixedNoise, gnss)?;
    /// assert_eq!(nav.covariance().nrows(), 15);
    ///
    /// // the 21-state INS: the start names the scale factors' prior
    /// let scale = ScaleInit { sg: z, sa: z, sg_std: Vector3::repeat(1e-3),
    ///     sa_std: Vector3::repeat(1e-3) };
    /// let noise21 = ScaleFactorNoise { gyro: Vector3::repeat(1e-7), accel: Vector3::repeat(1e-7) };
    /// let model21 = InsModel21 { base: model, scale: noise21 };
    /// let nav21 = Navigator::new((&init, &scale), model21, FixedNoise, gnss)?;
    /// assert_eq!(nav21.covariance()[(15, 15)], 1e-6);
    /// # Ok::<(), NavError>(())
    /// ```
    pub fn new<I: NavStart<State = S>>(
        start: I,
        model: S::Model,
        strategy: A,
        gnss: GnssConfig,
    ) -> Result<Self, NavError> {
        let (x0, p0) = start.state_and_covariance();
        Self::from_parts(x0, p0, start.time(), model, strategy, gnss)
    }

    /// A navigator at state `x0` with covariance `p0` at time `time`: any state, e.g. the
    /// calibration's or the fixes' persisting error's, whose start is not a [`NavStart`].
    pub fn from_parts(
        x0: S,
        p0: Cov<S::Dim>,
        time: f64,
        model: S::Model,
        strategy: A,
        gnss: GnssConfig,
    ) -> Result<Self, NavError> {
        let filter = ErrorStateFilter::new(x0, p0, strategy)
            .map_err(|source| NavError::Filter { t: time, source })?
            .with_time(time);
        Ok(Self {
            filter,
            model,
            gnss,
            prev: None,
            rate: Vector3::zeros(),
            time,
            vehicle: VehicleState::default(),
            floor: None,
            carrier: None,
            coarse: None,
            fix_split: Default::default(),
            fix_split_time: None,
        })
    }

    /// Turn on land-vehicle aiding (NHC, ZUPT/ZARU on detected stops), applied at the end
    /// of each IMU sample.
    pub fn with_vehicle_aiding(mut self, aiding: VehicleAiding) -> Self {
        let never = f64::NEG_INFINITY;
        self.vehicle = VehicleState {
            aiding,
            c_vb: aiding
                .nhc
                .map(|n| mounting_matrix(&n.mounting))
                .unwrap_or_else(Matrix3::identity),
            detector: aiding.zupt.map(|z| StationaryDetector::new(z.detector)),
            last_nhc: never,
            last_zupt: never,
            last_zaru: never,
            stationary_time: 0.0,
            last_odometer: never,
            odometer_scale: OdometerScale::default(),
            last_gnss: never,
            odometer_reversed: (0.0, 0.0),
        };
        self
    }

    /// The stationary detector, when ZUPT is on.
    pub fn stationary_detector(&self) -> Option<&StationaryDetector> {
        self.vehicle.detector.as_ref()
    }

    /// Tight coupling with [`TightConfig::error_floor`]: the covariance of position (NED,
    /// m²) and GPS clock that the last raw epoch's persisting satellite errors leave a
    /// single point (`None` before one, or when its geometry did not fix them). The
    /// filter's own covariance does not include it; the σ a run reports does.
    pub fn satellite_floor(&self) -> Option<&nalgebra::Matrix4<f64>> {
        self.floor.as_ref()
    }

    /// The odometer's calibrated scale (reading / true speed), once calibrated.
    pub fn odometer_scale(&self) -> Option<f64> {
        let min = self.vehicle.aiding.odometer.map_or(f64::INFINITY, |o| o.calibration_samples);
        self.vehicle.odometer_scale.scale(min)
    }

    /// With the odometer: the time it read motion (above 0.5 m/s) so far, and of it the
    /// time the filter moved the other way (its forward speed beyond 0.5 m/s with the
    /// other sign), s. A filter whose heading is 180° off drives backward all along.
    pub fn odometer_reversed(&self) -> (f64, f64) {
        self.vehicle.odometer_reversed
    }

    /// Time the vehicle was judged standing — the detector said so and the filter's speed
    /// was below `max_speed` — so far, s (0 without ZUPT).
    pub fn stationary_time(&self) -> f64 {
        self.vehicle.stationary_time
    }

    /// Current time, s.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The nominal state.
    pub fn state(&self) -> &S {
        self.filter.state()
    }

    /// Attitude, velocity, position and biases (the whole state of a 15-state run).
    pub fn nav_state(&self) -> &InsState {
        self.filter.state().nav()
    }

    /// The error covariance.
    pub fn covariance(&self) -> &Cov<S::Dim> {
        self.filter.covariance_raw()
    }

    /// The underlying filter.
    pub fn filter(&self) -> &ErrorStateFilter<S, A> {
        &self.filter
    }

    /// The process model.
    pub fn model(&self) -> &S::Model {
        &self.model
    }

    /// 1σ of the error states.
    pub fn sigma(&self) -> OVector<f64, S::Dim> {
        self.filter.sigma()
    }

    /// Process one IMU sample and the GNSS epochs with `t ∈ (now, imu.t]` (sorted), each
    /// at its exact time. Returns the update summaries in order.
    pub fn process<O: Observer>(
        &mut self,
        imu: &ImuSample,
        gnss: &[GnssEpoch],
        observer: &mut O,
    ) -> Result<Vec<UpdateSummary>, NavError> {
        let mut out = Vec::new();
        self.process_into(imu, gnss, observer, &mut out)?;
        Ok(out)
    }

    /// [`process`](Self::process) appending summaries to `out` (no allocation when `out`
    /// has capacity).
    pub fn process_into<O: Observer>(
        &mut self,
        imu: &ImuSample,
        gnss: &[GnssEpoch],
        observer: &mut O,
        out: &mut Vec<UpdateSummary>,
    ) -> Result<(), NavError> {
        self.process_recorded(imu, gnss, observer, out, &mut ())
    }

    /// [`process_into`](Self::process_into) telling `recorder` of every prediction
    /// (e.g. a [`SegmentSmoother`](estimator_core::SegmentSmoother)); the prediction that
    /// ends at the sample's time is marked.
    pub fn process_recorded<O: Observer, R: StepRecorder<S, ImuInput>>(
        &mut self,
        imu: &ImuSample,
        gnss: &[GnssEpoch],
        observer: &mut O,
        out: &mut Vec<UpdateSummary>,
        recorder: &mut R,
    ) -> Result<(), NavError> {
        self.process_events(
            imu,
            gnss,
            |g| g.t,
            observer,
            out,
            recorder,
            |nav, g, obs, out, rec| {
                rec.before_update(&nav.filter);
                out.push(nav.update(g, obs)?);
                nav.update_heading(g.heading.as_ref(), obs, out, rec)
            },
        )
    }

    /// One IMU sample with the measurement events whose time (`time`) falls in its
    /// interval, each applied by `apply` at its exact time (the interval split there),
    /// then the vehicle aiding at the sample's end.
    #[allow(clippy::too_many_arguments)]
    fn process_events<O: Observer, R: StepRecorder<S, ImuInput>, E>(
        &mut self,
        imu: &ImuSample,
        events: &[E],
        time: impl Fn(&E) -> f64,
        observer: &mut O,
        out: &mut Vec<UpdateSummary>,
        recorder: &mut R,
        mut apply: impl FnMut(
            &mut Self,
            &E,
            &mut O,
            &mut Vec<UpdateSummary>,
            &mut R,
        ) -> Result<(), NavError>,
    ) -> Result<(), NavError> {
        if !(imu.t.is_finite() && imu.dt.is_finite() && imu.dt > 0.0) {
            return Err(NavError::BadSample {
                t: imu.t,
                what: "IMU time or interval not finite or not positive",
            });
        }
        if !(imu.dtheta.iter().chain(imu.dvel.iter()).all(|v| v.is_finite())) {
            return Err(NavError::BadSample { t: imu.t, what: "IMU increment is NaN or infinite" });
        }
        if imu.t < self.time + TIME_EPSILON {
            return Err(NavError::TimeWentBackwards { t: imu.t, now: self.time });
        }
        let mut rest = *imu;
        for g in events {
            let gt = time(g);
            if gt < self.time - TIME_EPSILON {
                return Err(NavError::TimeWentBackwards { t: gt, now: self.time });
            }
            if gt > imu.t + TIME_EPSILON {
                break;
            }
            if gt < rest.t - TIME_EPSILON && gt > self.time + TIME_EPSILON {
                let (first, second) = rest.split(gt);
                self.propagate(&first, recorder, false)?;
                rest = second;
            } else if gt >= rest.t - TIME_EPSILON {
                self.propagate(&rest, recorder, true)?;
                rest.dt = 0.0;
            }
            coarse::settle(&mut self.coarse, &mut self.filter, &self.model)?;
            apply(self, g, observer, out, recorder)?;
        }
        if rest.dt > 0.0 {
            self.propagate(&rest, recorder, true)?;
        }
        self.time = imu.t;
        if self.vehicle.aiding.any() {
            self.aid(imu, observer, out, recorder)?;
        }
        Ok(())
    }

    fn propagate<R: StepRecorder<S, ImuInput>>(
        &mut self,
        s: &ImuSample,
        recorder: &mut R,
        mark: bool,
    ) -> Result<(), NavError> {
        if s.dt <= 0.0 {
            return Ok(());
        }
        let input = ImuInput { prev: self.prev, cur: *s };
        // the clock on the samples' time stamps: the interval's start before (the first
        // sample's interval may begin before the start time), its end after (updates and
        // smoothed rows are reported at the filter's time)
        self.filter.set_time(s.t - s.dt);
        let err = |source| NavError::Filter { t: s.t, source };
        if self.coarse.is_some() {
            if recorder.records() {
                // the recorder stores the covariance where a stretch opens: now's
                if recorder.reads_covariance(self.filter.epoch()) {
                    coarse::settle(&mut self.coarse, &mut self.filter, &self.model)?;
                }
                recorder.before_predict(&self.filter, &input, s.dt, mark);
            }
            let full = self.coarse.as_mut().is_some_and(|c| c.add(self.filter.state(), s));
            if !full {
                // (the smoother's backward pass takes the same stretches)
                recorder.covariance_continues();
            }
            self.filter.predict_state(&self.model, &input, s.dt).map_err(err)?;
            if full {
                coarse::settle(&mut self.coarse, &mut self.filter, &self.model)?;
            }
        } else {
            recorder.before_predict(&self.filter, &input, s.dt, mark);
            self.filter.predict(&self.model, &input, s.dt).map_err(err)?;
        }
        self.filter.set_time(s.t);
        self.prev = Some(*s);
        self.rate = s.rate();
        self.time = s.t;
        Ok(())
    }

    /// Apply one GNSS epoch now (its time must be the navigator's time).
    fn update<O: Observer>(
        &mut self,
        g: &GnssEpoch,
        observer: &mut O,
    ) -> Result<UpdateSummary, NavError> {
        // the file's covariance (its correlations included), unless the configuration
        // states the σ
        let mut r_pos = match self.gnss.pos_std {
            Some(s) => diag3(&s.component_mul(&s)),
            None => g.position_covariance(),
        };
        let stream = match (self.gnss.use_velocity, g.vel) {
            (true, Some(_)) => crate::gnss::GNSS_POSITION_VELOCITY,
            _ => crate::gnss::GNSS_POSITION,
        };
        let lever = self.gnss.lever_arm;
        let mut white = None;
        if self.filter.state().fix_error().is_some() {
            r_pos = self.split_fix_error(&r_pos, stream);
            white = Some(self.fix_innovation_stats(g, &r_pos, lever));
        }
        self.vehicle.last_gnss = g.t;
        let summary = self.update_fix(g, r_pos, lever, observer)?;
        if let Some(w) = white {
            // (refused fixes too: the white factor's influence is bounded, and a cosine
            // of gross errors is noise about 0)
            let dt = match self.fix_split_time {
                Some(t0) if g.t > t0 => g.t - t0,
                _ => 1.0,
            };
            self.fix_split_time = Some(g.t);
            let memory = (-4.0 * dt / self.gnss.fix_errors.tau).exp();
            self.fix_split.push(w.map(|w| w.0), memory);
            self.fix_split.push_white(w.map(|w| w.1));
        }
        Ok(summary)
    }

    /// An epoch's moving-base heading now (its time must be the navigator's time), when
    /// it has one, the configuration uses them and the state sees the baseline with a
    /// horizontal direction; gated and adapted as the stream
    /// [`GNSS_HEADING`](crate::heading::GNSS_HEADING), its summary appended to `out`.
    pub(crate) fn update_heading<O: Observer, R: StepRecorder<S, ImuInput>>(
        &mut self,
        heading: Option<&crate::heading::AntennaHeading>,
        observer: &mut O,
        out: &mut Vec<UpdateSummary>,
        recorder: &mut R,
    ) -> Result<(), NavError> {
        use crate::heading::{heading_defined, BaselineAttitude, BaselineHeading};
        let (Some(m), Some(cfg)) = (heading, self.gnss.heading) else { return Ok(()) };
        let b = cfg.baseline;
        if !m.heading.is_finite() || !heading_defined(&b, self.filter.state().nav()) {
            return Ok(());
        }
        let err = |source| NavError::Measurement { t: m.t, source };
        let s_psi = cfg.heading_std(m);
        recorder.before_update(&self.filter);
        let report = match cfg.pitch(m) {
            Some((theta, s_theta)) if theta.is_finite() => {
                let z = nalgebra::Vector2::new(m.heading, theta);
                let r = diag2(&nalgebra::Vector2::new(s_psi * s_psi, s_theta * s_theta));
                S::update::<A, BaselineAttitude, O>(
                    &mut self.filter,
                    &BaselineAttitude { baseline: b },
                    &z,
                    &r,
                    observer,
                )
            }
            _ => {
                let z = nalgebra::Vector1::new(m.heading);
                let r = nalgebra::Matrix1::new(s_psi * s_psi);
                S::update::<A, BaselineHeading, O>(
                    &mut self.filter,
                    &BaselineHeading { baseline: b },
                    &z,
                    &r,
                    observer,
                )
            }
        };
        out.push(report.map_err(err)?);
        Ok(())
    }

    /// The fix update proper, with the position noise `r_pos`.
    fn update_fix<O: Observer>(
        &mut self,
        g: &GnssEpoch,
        r_pos: Matrix3<f64>,
        lever: Vector3<f64>,
        observer: &mut O,
    ) -> Result<UpdateSummary, NavError> {
        let err = |source| NavError::Measurement { t: g.t, source };
        let force = self.prev.map_or_else(Vector3::zeros, |p| p.specific_force());
        match (self.gnss.use_velocity, g.vel) {
            (true, Some((v, _))) => {
                let r_vel = match self.gnss.vel_std {
                    Some(s) => diag3(&s.component_mul(&s)),
                    None => g.velocity_covariance().unwrap_or_else(Matrix3::zeros),
                };
                let mut r = diag6(&nalgebra::SVector::<f64, 6>::zeros());
                r.fixed_view_mut::<3, 3>(0, 0).copy_from(&r_pos);
                r.fixed_view_mut::<3, 3>(3, 3).copy_from(&r_vel);
                let model = GnssPosVel { lever_arm: lever, gyro_rate: self.rate };
                S::update_fix::<A, GnssPosVel, O>(
                    &mut self.filter,
                    &self.model,
                    &model,
                    &(g.pos, v),
                    &r,
                    &force,
                    observer,
                )
                .map_err(err)
            }
            _ => {
                let model = GnssPosition { lever_arm: lever };
                S::update_fix::<A, GnssPosition, O>(
                    &mut self.filter,
                    &self.model,
                    &model,
                    &g.pos,
                    &r_pos,
                    &force,
                    observer,
                )
                .map_err(err)
            }
        }
    }
}

impl<A: NoiseStrategy, S: NavState> Navigator<A, S>
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    /// On a state with the fixes' persisting error: set its σ from a fix's declared
    /// position covariance `r` ([`FixErrorSplit`]) and the σ factor the strategy learned on
    /// the fixes, and return the white noise's covariance.
    fn split_fix_error(&mut self, r: &Matrix3<f64>, stream: StreamId) -> Matrix3<f64> {
        let split = self.gnss.fix_errors;
        let (fix, r_w) = match split.sigma {
            // (the persisting part as stated; the declared σ is then the white part's,
            // its scale learned from the residuals when `learn`)
            Some(sigma) => {
                let r_w = if split.learn { r * self.fix_split.white() } else { *r };
                (crate::fix_error::FixErrorModel { sigma, tau: split.tau }, r_w)
            }
            None => {
                let share = split.share.clamp(0.0, 1.0);
                let r_w = r * (1.0 - share);
                // σ_b² = κ r: the declared ratio share / (1 − share), times what the
                // innovations' whiteness says, on the white part as the gate applies it
                let _ = stream;
                let mut kappa = share / (1.0 - share).max(1e-9);
                let mut r_w = r_w;
                if split.learn {
                    kappa *= self.fix_split.factor();
                    r_w *= self.fix_split.white();
                }
                let sigma = Vector3::new(r_w[(0, 0)], r_w[(1, 1)], r_w[(2, 2)])
                    .map(|v| (v.max(0.0) * kappa).sqrt());
                (crate::fix_error::FixErrorModel { sigma, tau: split.tau }, r_w)
            }
        };
        S::set_fix_error(&mut self.model, fix);
        r_w
    }

    /// The fix's position innovation `ν = z ⊖ p̂_a − b̂` before the update, whitened by its
    /// covariance `S = H P⁻ Hᵀ + R_w` (`r_w`: the white part as applied), and the white
    /// part's residual-based `q` at the learned factor
    /// ([`FixSplitLearner::white`](crate::fix_error::FixSplitLearner::white)); `None` when
    /// a covariance is not positive definite.
    fn fix_innovation_stats(
        &self,
        g: &GnssEpoch,
        r_w: &Matrix3<f64>,
        lever: Vector3<f64>,
    ) -> Option<(Vector3<f64>, f64)> {
        let (b, f) = self.filter.state().fix_error()?;
        let (res, j) =
            GnssPosition { lever_arm: lever }.innovation(self.filter.state().nav(), &g.pos);
        let nu = res - b;
        let p = self.filter.covariance_raw();
        let p_nn = M15::from_fn(|r, c| p[(r, c)]);
        let p_nf = SMatrix::<f64, 15, 3>::from_fn(|r, c| p[(r, f + c)]);
        let p_ff = Matrix3::from_fn(|r, c| p[(f + r, f + c)]);
        let h = &j.H;
        let hn = h * p_nf;
        let hph = h * p_nn * h.transpose() + hn + hn.transpose() + p_ff;
        let white = (hph + r_w).cholesky()?.l().solve_lower_triangular(&nu)?;
        // q at the learned factor λ (the applied r_w is the declared one times white()):
        // R = λ R₀, S = HPHᵀ + R, q = λ (uᵀ R u + tr(S⁻¹ HPHᵀ)) / 3
        let (applied, learned) = (self.fix_split.white(), self.fix_split.learned_white());
        let r = r_w * (learned / applied);
        let chol = (hph + r).cholesky()?;
        let u = chol.solve(&nu);
        let q = learned * (u.dot(&(r * u)) + chol.solve(&hph).trace()) / 3.0;
        Some((white, q))
    }

    /// The same navigator with the fixes' noise prior scaled: `factor` on the declared
    /// variance of both parts of the split (what a white model's innovations showed of
    /// the declared σ), as the white part's learned factor starts.
    pub fn with_fix_noise_prior(mut self, factor: f64) -> Self {
        self.fix_split = crate::fix_error::FixSplitLearner::with_white_prior(factor);
        self
    }

    /// The model of the fixes' persisting error now (a state that carries it).
    pub fn fix_error_model(&self) -> Option<crate::fix_error::FixErrorModel> {
        S::fix_error_model(&self.model)
    }

    /// The split of the fixes' error learned so far (a state with the fixes' persisting
    /// error).
    pub fn fix_split(&self) -> Option<&crate::fix_error::FixSplitLearner> {
        self.filter.state().fix_error().map(|_| &self.fix_split)
    }
}

// Outside the navigator's generic impl: there, the where-clause on the state's dimension
// hides nalgebra's allocator impls from these constructors.
fn diag2(d: &nalgebra::Vector2<f64>) -> nalgebra::Matrix2<f64> {
    nalgebra::Matrix2::from_diagonal(d)
}

fn diag3(d: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::from_diagonal(d)
}

fn diag6(d: &nalgebra::SVector<f64, 6>) -> SMatrix<f64, 6, 6> {
    SMatrix::<f64, 6, 6>::from_diagonal(d)
}
