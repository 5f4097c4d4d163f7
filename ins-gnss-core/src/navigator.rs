//! The INS/GNSS navigator: the 15-state error-state filter driven by IMU samples, with
//! GNSS epochs applied at their exact time.
//!
//! A GNSS epoch that falls inside an IMU interval `(t − dt, t]` splits it: the increments
//! are shared linearly, the filter is propagated to the GNSS time, updated, then
//! propagated over the rest of the interval (no snapping to the nearest IMU epoch).

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

use crate::gnss::{GnssEpoch, GnssPosVel, GnssPosition};
use crate::imu::ImuNoise;
use crate::imu::ImuSample;
use crate::model::{ImuInput, InsModel, M15};
use crate::raw::atmosphere::Klobuchar;
use crate::raw::spp::{azel, code_noise_variance, corrections, Prepared, SppOptions};
use crate::raw::GpsTime;
use crate::raw::System;
use crate::scale::{InsModel21, InsState21, M21};
use crate::state::InsState;
use crate::tight::{
    Antenna, InsModelTc, InsModelTc21, InsStateTc, InsStateTc21, OnTc, Pseudorange, RangeRate, M20,
    M26,
};
use crate::vehicle::{
    mounting_matrix, Nhc, Odometer, OdometerScale, StationaryDetector, VehicleAiding, Zaru, Zupt,
};

/// 1σ of the initial state, SI units (rad, m/s, m, rad/s, m/s²).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InitialStd {
    /// Attitude (roll, pitch, yaw) error, rad.
    pub att: Vector3<f64>,
    /// Velocity error (N, E, D), m/s.
    pub vel: Vector3<f64>,
    /// Position error (N, E, D), m.
    pub pos: Vector3<f64>,
    /// Gyro bias, rad/s.
    pub bg: Vector3<f64>,
    /// Accelerometer bias, m/s².
    pub ba: Vector3<f64>,
}

impl InitialStd {
    /// The diagonal initial covariance.
    pub fn covariance(&self) -> M15 {
        let mut d = nalgebra::SVector::<f64, 15>::zeros();
        for i in 0..3 {
            d[i] = self.att[i].powi(2);
            d[3 + i] = self.vel[i].powi(2);
            d[6 + i] = self.pos[i].powi(2);
            d[9 + i] = self.bg[i].powi(2);
            d[12 + i] = self.ba[i].powi(2);
        }
        M15::from_diagonal(&d)
    }
}

/// Where the navigator starts.
#[derive(Clone, Debug, PartialEq)]
pub struct InitialState {
    /// Time of the state, s.
    pub time: f64,
    /// The state.
    pub state: InsState,
    /// Its 1σ.
    pub std: InitialStd,
}

/// The initial scale factors of a 21-state run and their 1σ (fractions).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScaleInit {
    /// Gyro scale factors.
    pub sg: Vector3<f64>,
    /// Accelerometer scale factors.
    pub sa: Vector3<f64>,
    /// 1σ of the gyro scale factors.
    pub sg_std: Vector3<f64>,
    /// 1σ of the accelerometer scale factors.
    pub sa_std: Vector3<f64>,
}

/// A navigation state the [`Navigator`] runs: the 15-state [`InsState`] or the 21-state
/// [`InsState21`]. Measurement models are written once, for [`InsState`]; each state
/// applies them its own way.
pub trait NavState: Manifold + Clone + core::fmt::Debug
where
    DefaultAllocator: DimAlloc<Self::Dim>,
{
    /// The process model.
    type Model: estimator_core::ProcessModel<State = Self, Input = ImuInput>
        + Clone
        + core::fmt::Debug;

    /// The attitude, velocity, position and biases.
    fn nav(&self) -> &InsState;

    /// The IMU noise of a model.
    fn imu_noise(model: &Self::Model) -> &ImuNoise;

    /// Update `filter` with a measurement model of the 15-state navigation state.
    fn update<A, MM, O>(
        filter: &mut ErrorStateFilter<Self, A>,
        model: &MM,
        z: &MM::Measurement,
        r: &Cov<StateDim<MM::Measurement>>,
        observer: &mut O,
    ) -> Result<UpdateSummary, FilterError>
    where
        A: NoiseStrategy,
        MM: MeasurementModel<State = InsState>,
        O: Observer,
        DefaultAllocator: FilterAlloc<Const<15>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<20>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<21>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<26>, StateDim<MM::Measurement>>;
}

/// A measurement model of the 15-state navigation state applied to a larger navigation
/// state `S` whose error state begins with those 15 (the 21-state [`InsState21`], the
/// tightly coupled [`InsStateTc`]): the same prediction from [`NavState::nav`], `H`
/// padded with zero columns for the other states.
#[derive(Debug)]
pub struct OnNav<'a, S, M> {
    model: &'a M,
    _state: PhantomData<fn() -> S>,
}

impl<'a, S, M> OnNav<'a, S, M> {
    /// `model` on the state `S`.
    pub fn new(model: &'a M) -> Self {
        Self { model, _state: PhantomData }
    }
}

impl<S, M> Clone for OnNav<'_, S, M> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<S, M> Copy for OnNav<'_, S, M> {}

/// `h` with zero columns appended up to `C`.
fn pad<R: DimName, C: DimName, St: RawStorage<f64, R, Const<15>>>(
    h: &Matrix<f64, R, Const<15>, St>,
) -> OMatrix<f64, R, C>
where
    DefaultAllocator: Allocator<R, C>,
{
    OMatrix::<f64, R, C>::from_fn(|r, c| if c < 15 { h[(r, c)] } else { 0.0 })
}

impl<S, M> MeasurementModel for OnNav<'_, S, M>
where
    S: NavState,
    M: MeasurementModel<State = InsState>,
    DefaultAllocator: DimAlloc<S::Dim>
        + FilterAlloc<Const<15>, StateDim<M::Measurement>>
        + FilterAlloc<S::Dim, StateDim<M::Measurement>>,
{
    type State = S;
    type Measurement = M::Measurement;

    fn predict(&self, x: &S) -> M::Measurement {
        self.model.predict(x.nav())
    }

    fn jacobian(&self, x: &S) -> JacobiansOf<Self> {
        MeasurementJacobians { H: pad(&self.model.jacobian(x.nav()).H) }
    }

    fn innovation(
        &self,
        x: &S,
        z: &M::Measurement,
    ) -> (Tangent<M::Measurement>, JacobiansOf<Self>) {
        let (r, j) = self.model.innovation(x.nav(), z);
        (r, MeasurementJacobians { H: pad(&j.H) })
    }

    fn stream(&self) -> StreamId {
        self.model.stream()
    }
}

impl NavState for InsState {
    type Model = InsModel;

    fn nav(&self) -> &InsState {
        self
    }

    fn imu_noise(model: &InsModel) -> &ImuNoise {
        &model.noise
    }

    fn update<A, MM, O>(
        filter: &mut ErrorStateFilter<Self, A>,
        model: &MM,
        z: &MM::Measurement,
        r: &Cov<StateDim<MM::Measurement>>,
        observer: &mut O,
    ) -> Result<UpdateSummary, FilterError>
    where
        A: NoiseStrategy,
        MM: MeasurementModel<State = InsState>,
        O: Observer,
        DefaultAllocator: FilterAlloc<Const<15>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<20>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<21>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<26>, StateDim<MM::Measurement>>,
    {
        filter.update_observed(model, z, r, observer).map(|r| r.summary())
    }
}

impl NavState for InsState21 {
    type Model = InsModel21;

    fn nav(&self) -> &InsState {
        &self.nav
    }

    fn imu_noise(model: &InsModel21) -> &ImuNoise {
        &model.base.noise
    }

    fn update<A, MM, O>(
        filter: &mut ErrorStateFilter<Self, A>,
        model: &MM,
        z: &MM::Measurement,
        r: &Cov<StateDim<MM::Measurement>>,
        observer: &mut O,
    ) -> Result<UpdateSummary, FilterError>
    where
        A: NoiseStrategy,
        MM: MeasurementModel<State = InsState>,
        O: Observer,
        DefaultAllocator: FilterAlloc<Const<15>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<20>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<21>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<26>, StateDim<MM::Measurement>>,
    {
        filter.update_observed(&OnNav::<Self, MM>::new(model), z, r, observer).map(|r| r.summary())
    }
}

impl NavState for InsStateTc {
    type Model = InsModelTc;

    fn nav(&self) -> &InsState {
        &self.nav
    }

    fn imu_noise(model: &InsModelTc) -> &ImuNoise {
        &model.base.noise
    }

    fn update<A, MM, O>(
        filter: &mut ErrorStateFilter<Self, A>,
        model: &MM,
        z: &MM::Measurement,
        r: &Cov<StateDim<MM::Measurement>>,
        observer: &mut O,
    ) -> Result<UpdateSummary, FilterError>
    where
        A: NoiseStrategy,
        MM: MeasurementModel<State = InsState>,
        O: Observer,
        DefaultAllocator: FilterAlloc<Const<15>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<20>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<21>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<26>, StateDim<MM::Measurement>>,
    {
        filter.update_observed(&OnNav::<Self, MM>::new(model), z, r, observer).map(|r| r.summary())
    }
}

impl NavState for InsStateTc21 {
    type Model = InsModelTc21;

    fn nav(&self) -> &InsState {
        &self.nav.nav
    }

    fn imu_noise(model: &InsModelTc21) -> &ImuNoise {
        &model.base.base.noise
    }

    fn update<A, MM, O>(
        filter: &mut ErrorStateFilter<Self, A>,
        model: &MM,
        z: &MM::Measurement,
        r: &Cov<StateDim<MM::Measurement>>,
        observer: &mut O,
    ) -> Result<UpdateSummary, FilterError>
    where
        A: NoiseStrategy,
        MM: MeasurementModel<State = InsState>,
        O: Observer,
        DefaultAllocator: FilterAlloc<Const<15>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<20>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<21>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<26>, StateDim<MM::Measurement>>,
    {
        filter.update_observed(&OnNav::<Self, MM>::new(model), z, r, observer).map(|r| r.summary())
    }
}

/// How GNSS epochs are used.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GnssConfig {
    /// Antenna lever arm (FRD), m.
    pub lever_arm: Vector3<f64>,
    /// Use the velocity of epochs that have one (6-D update) instead of position only.
    pub use_velocity: bool,
    /// Replace the file's position σ (N, E, D), m.
    pub pos_std: Option<Vector3<f64>>,
    /// Replace the file's velocity σ, m/s.
    pub vel_std: Option<Vector3<f64>>,
}

impl Default for GnssConfig {
    fn default() -> Self {
        Self { lever_arm: Vector3::zeros(), use_velocity: true, pos_std: None, vel_std: None }
    }
}

/// A failure of the navigator, with the time it happened.
#[derive(Clone, Debug, PartialEq)]
pub enum NavError {
    /// The filter refused a GNSS epoch or its update produced a non-finite result.
    Measurement {
        /// Time of the epoch, s.
        t: f64,
        /// What the filter said.
        source: FilterError,
    },
    /// The filter's prediction over an IMU interval failed (a non-finite result, noise
    /// that is not a covariance).
    Filter {
        /// Time, s.
        t: f64,
        /// What the filter said.
        source: FilterError,
    },
    /// A sample or epoch earlier than the navigator's time.
    TimeWentBackwards {
        /// The offending time, s.
        t: f64,
        /// The navigator's time, s.
        now: f64,
    },
    /// A sample with a non-finite value or a non-positive interval.
    BadSample {
        /// Time, s.
        t: f64,
        /// What is wrong.
        what: &'static str,
    },
}

impl fmt::Display for NavError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NavError::Filter { t, source } => write!(f, "at t = {t:.6} s: {source}"),
            NavError::Measurement { t, source } => {
                write!(f, "at the GNSS epoch t = {t:.6} s: {source}")
            }
            NavError::TimeWentBackwards { t, now } => {
                write!(f, "time went backwards: {t:.6} s after {now:.6} s")
            }
            NavError::BadSample { t, what } => write!(f, "at t = {t:.6} s: {what}"),
        }
    }
}

impl std::error::Error for NavError {}

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
    sats: Vec<(crate::raw::Sat, f64, Vector3<f64>, f64, f64)>,
}

/// The vehicle aiding's settings and bookkeeping.
#[derive(Clone, Debug, Default)]
struct VehicleState {
    aiding: VehicleAiding,
    c_vb: Matrix3<f64>,
    detector: Option<StationaryDetector>,
    last_nhc: f64,
    last_zupt: f64,
    last_zaru: f64,
    /// Time judged standing (detector and speed), s.
    stationary_time: f64,
    last_odometer: f64,
    odometer_scale: OdometerScale,
    /// Time of the last GNSS update (the odometer's scale is calibrated only near one).
    last_gnss: f64,
}

impl<A: NoiseStrategy> Navigator<A, InsState> {
    /// A 15-state navigator at `init`, with process model `model`, strategy and GNSS
    /// settings.
    pub fn new(
        init: &InitialState,
        model: InsModel,
        strategy: A,
        gnss: GnssConfig,
    ) -> Result<Self, NavError> {
        Self::from_parts(
            init.state.clone(),
            init.std.covariance(),
            init.time,
            model,
            strategy,
            gnss,
        )
    }
}

impl<A: NoiseStrategy> Navigator<A, InsState21> {
    /// A 21-state navigator at `init` with the scale factors of `scale`.
    pub fn new21(
        init: &InitialState,
        scale: &ScaleInit,
        model: InsModel21,
        strategy: A,
        gnss: GnssConfig,
    ) -> Result<Self, NavError> {
        let x = InsState21 { nav: init.state.clone(), sg: scale.sg, sa: scale.sa };
        let mut p = M21::zeros();
        let p15: M15 = init.std.covariance();
        p.fixed_view_mut::<15, 15>(0, 0).copy_from(&p15);
        for k in 0..3 {
            p[(15 + k, 15 + k)] = scale.sg_std[k].powi(2);
            p[(18 + k, 18 + k)] = scale.sa_std[k].powi(2);
        }
        Self::from_parts(x, p, init.time, model, strategy, gnss)
    }
}

impl<A: NoiseStrategy, S: NavState> Navigator<A, S>
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    /// A navigator at state `x0` with covariance `p0` at time `time`.
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
                Ok(())
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

    /// The vehicle aiding at the end of an IMU sample: ZUPT (and ZARU) while the detector
    /// says the vehicle stands, otherwise NHC.
    fn aid<O: Observer, R: StepRecorder<S, ImuInput>>(
        &mut self,
        imu: &ImuSample,
        observer: &mut O,
        out: &mut Vec<UpdateSummary>,
        recorder: &mut R,
    ) -> Result<(), NavError> {
        let t = imu.t;
        let err = |source| NavError::Measurement { t, source };
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
        if let (Some(o), Some(reading)) = (v.aiding.odometer, imu.odometer) {
            let model = Odometer { c_vb: v.c_vb, lever_arm: o.lever_arm, gyro_rate: imu.rate() };
            let forward = model.predict(self.filter.state().nav())[0];
            // calibrate the scale while GNSS keeps the forward speed right
            if t - v.last_gnss <= 1.5 && forward > 1.0 {
                v.odometer_scale.add(reading, forward, imu.dt, o.calibration_time);
            }
            let scale = v.odometer_scale.scale(o.calibration_samples);
            if let (Some(k), true) = (scale, t - v.last_odometer >= o.interval - TIME_EPSILON) {
                v.last_odometer = t;
                let z = nalgebra::Vector1::new(reading / k);
                let r = nalgebra::Matrix1::new(o.std * o.std);
                recorder.before_update(&self.filter);
                let report =
                    S::update::<A, Odometer, O>(&mut self.filter, &model, &z, &r, observer);
                out.push(report.map_err(err)?);
            }
        }
        // the filter's speed must be consistent with rest: below `max_speed` plus three of
        // its σ (tight while GNSS holds the velocity, wide in an outage, when a stop is
        // most worth taking)
        let filter = &self.filter;
        let zupt = v.aiding.zupt.filter(|z| {
            stationary && {
                // (the σ only when standing: this runs at every IMU sample)
                let sigma = filter.sigma();
                let speed_sigma = (sigma[3].powi(2) + sigma[4].powi(2) + sigma[5].powi(2)).sqrt();
                speed < z.max_speed + z.speed_sigmas * speed_sigma
            }
        });
        if let (Some(z), Some(d)) = (zupt, &v.detector) {
            v.stationary_time += imu.dt;
            if t - v.last_zupt >= z.interval - TIME_EPSILON {
                v.last_zupt = t;
                let r = Matrix3::identity() * z.velocity_std.powi(2);
                recorder.before_update(&self.filter);
                let report = S::update::<A, Zupt, O>(
                    &mut self.filter,
                    &Zupt,
                    &Vector3::zeros(),
                    &r,
                    observer,
                );
                out.push(report.map_err(err)?);
            }
            if let Some(rate_std) = z.rate_std {
                if t - v.last_zaru >= d.config().window - TIME_EPSILON {
                    v.last_zaru = t;
                    // the window mean's own white noise, ARW²/window, plus the configured σ
                    let window = d.config().window.max(1e-3);
                    let arw = S::imu_noise(&self.model).arw;
                    let r = diag3(&arw.map(|a| a * a / window + rate_std * rate_std));
                    let mean = d.mean_rate();
                    recorder.before_update(&self.filter);
                    let report =
                        S::update::<A, Zaru, O>(&mut self.filter, &Zaru, &mean, &r, observer);
                    out.push(report.map_err(err)?);
                }
            }
            return Ok(());
        }
        if let Some(n) = v.aiding.nhc {
            if t - v.last_nhc >= n.interval - TIME_EPSILON && speed >= n.min_speed {
                v.last_nhc = t;
                let model = Nhc { c_vb: v.c_vb, lever_arm: n.lever_arm, gyro_rate: imu.rate() };
                let r = diag2(&n.std.component_mul(&n.std));
                let z = nalgebra::Vector2::zeros();
                recorder.before_update(&self.filter);
                let report = S::update::<A, Nhc, O>(&mut self.filter, &model, &z, &r, observer);
                out.push(report.map_err(err)?);
            }
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
        recorder.before_predict(&self.filter, &input, s.dt, mark);
        self.filter
            .predict(&self.model, &input, s.dt)
            .map_err(|source| NavError::Filter { t: s.t, source })?;
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
        let err = |source| NavError::Measurement { t: g.t, source };
        self.vehicle.last_gnss = g.t;
        // the file's covariance (its correlations included), unless the configuration
        // states the σ
        let r_pos = match self.gnss.pos_std {
            Some(s) => diag3(&s.component_mul(&s)),
            None => g.position_covariance(),
        };
        let lever = self.gnss.lever_arm;
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
                S::update::<A, GnssPosVel, O>(&mut self.filter, &model, &(g.pos, v), &r, observer)
                    .map_err(err)
            }
            _ => {
                let model = GnssPosition { lever_arm: lever };
                S::update::<A, GnssPosition, O>(&mut self.filter, &model, &g.pos, &r_pos, observer)
                    .map_err(err)
            }
        }
    }
}

/// One epoch of raw observations for the tightly coupled navigator: the satellites at
/// their transmission times ([`crate::raw::spp::prepare`]) and the epoch's time on the
/// navigator's clock.
#[derive(Clone, Debug)]
pub struct RawEpoch {
    /// Time on the navigator's (the IMU's) clock, s.
    pub t: f64,
    /// The receiver's GPS time stamp (for the ionosphere's local time).
    pub time: GpsTime,
    /// The satellites.
    pub sats: Vec<Prepared>,
}

/// How raw observations are used.
#[derive(Clone, Debug, PartialEq)]
pub struct TightConfig {
    /// Elevation mask, models and code weighting (the single point's options).
    pub models: SppOptions,
    /// The broadcast ionosphere.
    pub klobuchar: Klobuchar,
    /// Use the Dopplers (range rates) as well as the codes.
    pub use_doppler: bool,
    /// Keep the position's and the receiver clock's covariance at least the one the
    /// epoch's satellite errors that persist from epoch to epoch (orbit and clock, code
    /// bias, atmosphere residuals) leave a single point with
    /// ([`satellite_error_floor`]): the filter absorbs such errors into its position and
    /// clock and, counting each epoch's code as new information, would otherwise shrink
    /// their σ below the error they leave.
    pub error_floor: bool,
    /// Use the carrier phases differenced in time between consecutive epochs (a velocity
    /// measurement of millimetres per second; satellites flagged for a slip, or whose
    /// phase change disagrees with their Doppler by more than [`SLIP_RATE`], are left out).
    pub carrier: bool,
    /// σ of a carrier phase, m.
    pub phase_std: f64,
}

/// A phase change (m/s over the interval) farther than this from the Doppler's range rate
/// is a cycle slip the receiver did not flag.
pub const SLIP_RATE: f64 = 2.0;

/// The longest interval a phase is differenced over, s.
pub const CARRIER_MAX_GAP: f64 = 2.5;

/// The receiver clock at the start of a tightly coupled run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClockInit {
    /// Bias `c·dt` (m) and drift `c·ḋt` (m/s), e.g. from a single point.
    pub clock: (f64, f64),
    /// Their 1σ.
    pub std: (f64, f64),
    /// 1σ of the inter-system biases, m.
    pub isb_std: f64,
}

impl<A: NoiseStrategy> Navigator<A, InsStateTc> {
    /// A tightly coupled navigator at `init` with the receiver clock of `clock`.
    pub fn new_tight(
        init: &InitialState,
        clock: &ClockInit,
        model: InsModelTc,
        strategy: A,
        gnss: GnssConfig,
    ) -> Result<Self, NavError> {
        let x = InsStateTc {
            nav: init.state.clone(),
            clock: manifolds::R2::new(clock.clock.0, clock.clock.1),
            isb: Vector3::zeros(),
        };
        let mut p = M20::zeros();
        let p15: M15 = init.std.covariance();
        p.fixed_view_mut::<15, 15>(0, 0).copy_from(&p15);
        p[(15, 15)] = clock.std.0.powi(2);
        p[(16, 16)] = clock.std.1.powi(2);
        for k in 17..20 {
            p[(k, k)] = clock.isb_std.powi(2);
        }
        Self::from_parts(x, p, init.time, model, strategy, gnss)
    }
}

impl<A: NoiseStrategy> Navigator<A, InsStateTc21> {
    /// A tightly coupled 21-state navigator (the IMU scale factors of `scale`) at `init`
    /// with the receiver clock of `clock`.
    pub fn new_tight21(
        init: &InitialState,
        scale: &ScaleInit,
        clock: &ClockInit,
        model: InsModelTc21,
        strategy: A,
        gnss: GnssConfig,
    ) -> Result<Self, NavError> {
        let x = InsStateTc21 {
            nav: InsState21 { nav: init.state.clone(), sg: scale.sg, sa: scale.sa },
            clock: manifolds::R2::new(clock.clock.0, clock.clock.1),
            isb: Vector3::zeros(),
        };
        let mut p = M26::zeros();
        let p15: M15 = init.std.covariance();
        p.fixed_view_mut::<15, 15>(0, 0).copy_from(&p15);
        for k in 0..3 {
            p[(15 + k, 15 + k)] = scale.sg_std[k].powi(2);
            p[(18 + k, 18 + k)] = scale.sa_std[k].powi(2);
        }
        let c0 = InsStateTc21::CLOCK.start();
        p[(c0, c0)] = clock.std.0.powi(2);
        p[(c0 + 1, c0 + 1)] = clock.std.1.powi(2);
        for k in InsStateTc21::ISB.range() {
            p[(k, k)] = clock.isb_std.powi(2);
        }
        Self::from_parts(x, p, init.time, model, strategy, gnss)
    }
}

/// A tightly coupled state: the 15- or 21-state INS, then the receiver clock and the
/// inter-system biases ([`InsStateTc`], [`InsStateTc21`]). The satellite models are
/// written once, for [`InsStateTc`]; each state applies them its own way.
pub trait TightState: NavState
where
    DefaultAllocator: DimAlloc<Self::Dim>,
{
    /// Update `filter` with a scalar satellite model of [`InsStateTc`]: measurement `z`,
    /// variance `r`.
    fn update_tc<A, MM, O>(
        filter: &mut ErrorStateFilter<Self, A>,
        model: &MM,
        z: f64,
        r: f64,
        observer: &mut O,
    ) -> Result<UpdateSummary, FilterError>
    where
        A: NoiseStrategy,
        MM: MeasurementModel<State = InsStateTc, Measurement = nalgebra::Vector1<f64>>,
        O: Observer;
}

impl TightState for InsStateTc {
    fn update_tc<A, MM, O>(
        filter: &mut ErrorStateFilter<Self, A>,
        model: &MM,
        z: f64,
        r: f64,
        observer: &mut O,
    ) -> Result<UpdateSummary, FilterError>
    where
        A: NoiseStrategy,
        MM: MeasurementModel<State = InsStateTc, Measurement = nalgebra::Vector1<f64>>,
        O: Observer,
    {
        let (z, r) = (nalgebra::Vector1::new(z), nalgebra::Matrix1::new(r));
        filter.update_observed(model, &z, &r, observer).map(|r| r.summary())
    }
}

impl TightState for InsStateTc21 {
    fn update_tc<A, MM, O>(
        filter: &mut ErrorStateFilter<Self, A>,
        model: &MM,
        z: f64,
        r: f64,
        observer: &mut O,
    ) -> Result<UpdateSummary, FilterError>
    where
        A: NoiseStrategy,
        MM: MeasurementModel<State = InsStateTc, Measurement = nalgebra::Vector1<f64>>,
        O: Observer,
    {
        let (z, r) = (nalgebra::Vector1::new(z), nalgebra::Matrix1::new(r));
        filter.update_observed(&OnTc(model), &z, &r, observer).map(|r| r.summary())
    }
}

impl<A: NoiseStrategy, S: TightState> Navigator<A, S>
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    /// One IMU sample with the raw epochs of its interval (sorted): each satellite's
    /// pseudorange (and range rate) is an update of its own stream, at the epoch's time.
    pub fn process_raw<O: Observer>(
        &mut self,
        imu: &ImuSample,
        raw: &[RawEpoch],
        cfg: &TightConfig,
        observer: &mut O,
        out: &mut Vec<UpdateSummary>,
    ) -> Result<(), NavError> {
        self.process_raw_recorded(imu, raw, cfg, observer, out, &mut ())
    }

    /// [`process_raw`](Self::process_raw) telling `recorder` of every prediction and
    /// update (a smoother).
    pub fn process_raw_recorded<O: Observer, R: StepRecorder<S, ImuInput>>(
        &mut self,
        imu: &ImuSample,
        raw: &[RawEpoch],
        cfg: &TightConfig,
        observer: &mut O,
        out: &mut Vec<UpdateSummary>,
        recorder: &mut R,
    ) -> Result<(), NavError> {
        self.process_events(
            imu,
            raw,
            |e| e.t,
            observer,
            out,
            recorder,
            |nav, e, obs, out, rec| nav.update_raw(e, cfg, obs, out, rec),
        )
    }

    /// The satellites of one epoch, one update each (now: the epoch's time is the
    /// navigator's).
    fn update_raw<O: Observer, R: StepRecorder<S, ImuInput>>(
        &mut self,
        e: &RawEpoch,
        cfg: &TightConfig,
        observer: &mut O,
        out: &mut Vec<UpdateSummary>,
        recorder: &mut R,
    ) -> Result<(), NavError> {
        let err = |source| NavError::Measurement { t: e.t, source };
        self.vehicle.last_gnss = e.t;
        let lever = self.gnss.lever_arm;
        if cfg.carrier {
            self.update_carrier(e, cfg, observer, out, recorder)?;
        }
        // the persisting errors' normal equations: position (NED), a clock per system
        let mut normal = nalgebra::SMatrix::<f64, 7, 7>::zeros();
        let mut used = 0;
        for s in &e.sats {
            // the geometry at the state as it stands (earlier satellites of the epoch moved it)
            let a = Antenna::at(self.filter.state().nav(), &lever);
            let ant = a.pos;
            let d = s.state.pos - a.r;
            let (az, el) = azel(ant.lat, ant.lon, &(d / d.norm()));
            if el < cfg.models.elevation_mask {
                continue;
            }
            let (corr, var) = corrections(
                &cfg.models,
                &cfg.klobuchar,
                (ant.lat, ant.lon, ant.h),
                (az, el),
                e.time.tow,
                s,
            );
            let model = Pseudorange { sat: s, corrections: corr, lever_arm: lever };
            recorder.before_update(&self.filter);
            let report =
                S::update_tc(&mut self.filter, &model, s.range, var, observer).map_err(err)?;
            out.push(report);
            if report.verdict != estimator_core::Verdict::Rejected {
                let persisting = var - code_noise_variance(&cfg.models, el, s);
                let u = a.c_ne * (d / d.norm());
                let mut h = nalgebra::SVector::<f64, 7>::zeros();
                h.fixed_rows_mut::<3>(0).copy_from(&(-u));
                h[3 + system_column(s.sat.sys)] = 1.0;
                normal += h * h.transpose() / persisting.max(1e-6);
                used += 1;
            }
            if let (true, Some(rate)) = (cfg.use_doppler, s.range_rate) {
                let model = RangeRate { sat: s, lever_arm: lever, gyro_rate: self.rate };
                let v = cfg.models.doppler_std.powi(2);
                recorder.before_update(&self.filter);
                let report =
                    S::update_tc(&mut self.filter, &model, rate, v, observer).map_err(err)?;
                out.push(report);
            }
        }
        if cfg.error_floor && used >= 4 {
            if let Some(f) = satellite_error_floor(&normal) {
                self.floor = Some(f);
            }
        }
        if cfg.carrier {
            // this epoch's phases, for the next one
            let a = Antenna::at(self.filter.state().nav(), &lever);
            let anchor = a.r;
            let llh = (a.pos.lat, a.pos.lon, a.pos.h);
            let sats = e
                .sats
                .iter()
                .filter_map(|s| {
                    let p = s.phase?;
                    let atm = phase_atmosphere(cfg, llh, &anchor, e.time.tow, s);
                    Some((s.sat, p, s.state.pos, s.state.clock, atm))
                })
                .collect();
            self.carrier = Some(CarrierEpoch { t: e.t, anchor, sats });
        }
        Ok(())
    }

    /// The time-differenced carrier phases of epoch `e` against the last epoch's, as
    /// whitened single differences ([`crate::tight::CarrierRow`]), before the epoch's codes.
    fn update_carrier<O: Observer, R: StepRecorder<S, ImuInput>>(
        &mut self,
        e: &RawEpoch,
        cfg: &TightConfig,
        observer: &mut O,
        out: &mut Vec<UpdateSummary>,
        recorder: &mut R,
    ) -> Result<(), NavError> {
        let Some(prev) = self.carrier.take() else { return Ok(()) };
        let dt = e.t - prev.t;
        if !(dt > 0.0 && dt <= CARRIER_MAX_GAP) {
            return Ok(());
        }
        let x = self.filter.state().nav();
        let (v0, att0, ba0) = (x.vel, x.att, x.ba);
        // the interval's displacement error: Δt δv + ½ Δt² C_nb [f^b×] δθ (δv̇ = −C_nb [f^b×] δθ
        // for the body-frame attitude error), with the last sample's specific force
        let f_b = self.prev.map_or_else(Vector3::zeros, |p| p.dvel / p.dt.max(1e-9)) - x.ba;
        let a_acc = x.att.matrix() * (0.5 * dt * dt);
        let a_att = a_acc * manifolds::hat(&f_b);
        let Antenna { pos: ant, r: r_a, c_ne, .. } = Antenna::at(x, &self.gnss.lever_arm);
        // per satellite: elevation, the residual of its phase change (m), its line of sight
        let mut rows: Vec<(f64, f64, Vector3<f64>)> = Vec::with_capacity(e.sats.len());
        for s in &e.sats {
            let (Some(phase), false) = (s.phase, s.slip) else { continue };
            let Some(&(_, p0, pos0, clk0, atm0)) = prev.sats.iter().find(|p| p.0 == s.sat) else {
                continue;
            };
            let (rho, u) = crate::raw::spp::geometry(&s.state.pos, &r_a);
            let (rho0, _) = crate::raw::spp::geometry(&pos0, &prev.anchor);
            let (_, el) = azel(ant.lat, ant.lon, &u);
            if el < cfg.models.elevation_mask {
                continue;
            }
            let change = phase - p0;
            // a slip the receiver did not flag: the phase's rate far from the Doppler's
            if let Some(rate) = s.range_rate {
                if (change / dt - rate).abs() > SLIP_RATE {
                    continue;
                }
            }
            let sat_clock = crate::raw::ephemeris::C * (s.state.clock - clk0);
            let atm = phase_atmosphere(cfg, (ant.lat, ant.lon, ant.h), &r_a, e.time.tow, s);
            rows.push((el, change + sat_clock - (rho - rho0) - (atm - atm0), c_ne * u));
        }
        if rows.len() < 2 {
            return Ok(());
        }
        // single differences against the highest satellite: the receiver clock cancels
        let r = (0..rows.len()).max_by(|&a, &b| rows[a].0.total_cmp(&rows[b].0)).unwrap_or(0);
        let (_, y_r, u_r) = rows[r];
        let n = rows.len() - 1;
        let var = 2.0 * cfg.phase_std.powi(2);
        // covariance of the differences: var (I + 1 1ᵀ)
        let cov = nalgebra::DMatrix::from_fn(n, n, |i, j| if i == j { 2.0 * var } else { var });
        let Some(chol) = cov.cholesky() else { return Ok(()) };
        let mut y = nalgebra::DVector::zeros(n);
        let mut h = nalgebra::DMatrix::zeros(n, 9);
        let others = rows.iter().enumerate().filter(|(k, _)| *k != r).map(|(_, v)| v);
        for (k, (_, y_i, u_i)) in others.enumerate() {
            y[k] = y_i - y_r;
            let du = u_r - u_i;
            let (hv, ha, hb) = (du * dt, a_att.transpose() * du, a_acc.transpose() * du);
            for c in 0..3 {
                h[(k, c)] = hv[c];
                h[(k, 3 + c)] = ha[c];
                h[(k, 6 + c)] = hb[c];
            }
        }
        let l = chol.l();
        let (Some(y), Some(h)) = (l.solve_lower_triangular(&y), l.solve_lower_triangular(&h))
        else {
            return Ok(());
        };
        let err = |source| NavError::Measurement { t: e.t, source };
        for k in 0..n {
            let model = crate::tight::CarrierRow {
                h: Vector3::new(h[(k, 0)], h[(k, 1)], h[(k, 2)]),
                h_att: Vector3::new(h[(k, 3)], h[(k, 4)], h[(k, 5)]),
                h_ba: Vector3::new(h[(k, 6)], h[(k, 7)], h[(k, 8)]),
                c: 0.0,
                v0,
                att0,
                ba0,
            };
            recorder.before_update(&self.filter);
            let report =
                S::update_tc(&mut self.filter, &model, y[k], 1.0, observer).map_err(err)?;
            out.push(report);
        }
        Ok(())
    }
}

/// The atmosphere's delay of a satellite's carrier phase at the antenna `r` (ECEF, at
/// geodetic `llh`): `T − I` (the phase is advanced by the ionosphere).
fn phase_atmosphere(
    cfg: &TightConfig,
    llh: (f64, f64, f64),
    r: &Vector3<f64>,
    tow: f64,
    s: &Prepared,
) -> f64 {
    let d = s.state.pos - r;
    let azel = azel(llh.0, llh.1, &(d / d.norm()));
    let ((iono, _), (tropo, _)) =
        crate::raw::spp::atmosphere(&cfg.models, &cfg.klobuchar, llh, azel, tow, s);
    tropo - iono
}

/// The column of a system's clock in [`satellite_error_floor`]'s normal equations: GPS
/// (and any other system) 0, Galileo 1, BeiDou 2, QZSS 3.
fn system_column(sys: System) -> usize {
    crate::tight::isb_index(sys).map_or(0, |k| k + 1)
}

/// The covariance of position (NED) and GPS clock that the persisting satellite errors
/// leave a single point of the epoch's geometry: the first 4×4 block of the inverse of
/// the normal equations `Σ h hᵀ / σ²_persisting` (rows of position and a clock per
/// system; the columns of systems not seen are left out). `None` when the geometry does
/// not fix them. With errors constant per satellite, a filter that averages epochs cannot
/// do better than this: it is the σ below which its position and clock must not shrink.
pub fn satellite_error_floor(
    normal: &nalgebra::SMatrix<f64, 7, 7>,
) -> Option<nalgebra::Matrix4<f64>> {
    // the systems seen keep their clock column; the others are fixed at 0 (unit diagonal)
    let mut n = *normal;
    for k in 3..7 {
        if n[(k, k)] == 0.0 {
            n[(k, k)] = 1.0;
        }
    }
    if normal[(3, 3)] == 0.0 {
        // no GPS satellite: the GPS clock is not fixed by this epoch
        return None;
    }
    let inv = n.cholesky()?.inverse();
    Some(inv.fixed_view::<4, 4>(0, 0).into_owned())
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
