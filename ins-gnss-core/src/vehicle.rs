//! Land-vehicle aiding: the non-holonomic constraint (NHC), zero-velocity and
//! zero-angular-rate updates (ZUPT, ZARU), and the stationary detector that decides when
//! the vehicle stands still.
//!
//! Frames: the IMU body frame `b` (FRD) and the vehicle frame `v` (FRD: forward along the
//! car's axis, right, down). The mounting angles are the roll, pitch and yaw of the IMU
//! body frame relative to the vehicle frame (as `R_nb` holds the body's relative to NED):
//! `C_vb = R(roll, pitch, yaw)` takes body vectors to the vehicle frame, `v_v = C_vb v_b`;
//! all zero when the IMU is mounted square.
//!
//! **NHC** (Shin 2005; Groves 2013 §16.4.3; Niu et al.): a car on a road does not slide
//! sideways or leave the ground, so at a point on the rear axle the vehicle-frame
//! velocity's lateral and vertical components are zero. With the point at lever arm `l`
//! from the IMU (body frame) and the body rate `ω = ω̃ − b_g`,
//!
//! ```text
//! v_v = C_vb (R_nbᵀ v_n + ω × l)          z = [v_v,y, v_v,z] = 0
//! H   = E C_vb [ [R_nbᵀ v_n ×],  R_nbᵀ,  0,  [l×],  0 ]      E = rows 2 and 3
//! ```
//!
//! (right attitude error `R_true = R̂ Exp(δθ)`: `Exp(δθ)ᵀ R̂ᵀ v ≈ R̂ᵀ v + [R̂ᵀ v ×] δθ`). The
//! Earth and transport rates are left out of `ω` (below 1e-4 m/s for a lever arm of 1 m).
//!
//! **ZUPT**: the velocity is zero, `z = 0 = v_n`, `H = [0, I, 0, 0, 0]`. **ZARU**: the
//! body turns with the Earth only, so the mean measured rate over the stationary window
//! is `ω̄ = b_g + R_nbᵀ ω_ie^n`, `H = [[R_nbᵀ ω_ie^n ×], 0, 0, I, 0]`: the vertical gyro
//! bias, which GNSS sees only through slow heading drift, is observed while the car
//! stands.

use estimator_core::{MeasurementJacobians, MeasurementModel, StreamId};
use manifolds::{hat, So3, R3};
use nalgebra::{Const, Matrix3, SMatrix, Vector2, Vector3};

use crate::earth::earth_rate_ned;
use crate::state::InsState;

/// The stream of [`Nhc`] updates.
pub const NHC: StreamId = StreamId::named("nhc");
/// The stream of [`Zupt`] updates.
pub const ZUPT: StreamId = StreamId::named("zupt");
/// The stream of [`Zaru`] updates.
pub const ZARU: StreamId = StreamId::named("zaru");
/// The stream of [`Odometer`] updates.
pub const ODOMETER: StreamId = StreamId::named("odometer");
/// Every vehicle-aiding stream.
pub const VEHICLE_STREAMS: [StreamId; 4] = [NHC, ZUPT, ZARU, ODOMETER];

/// `C_vb (R_nbᵀ v_n + (ω̃ − b_g) × l)`: the vehicle-frame velocity of the point at `l`.
fn point_velocity(
    c_vb: &Matrix3<f64>,
    lever: &Vector3<f64>,
    gyro: &Vector3<f64>,
    x: &InsState,
) -> Vector3<f64> {
    c_vb * (x.att.matrix().transpose() * x.vel + (gyro - x.bg).cross(lever))
}

/// The Jacobian of [`point_velocity`] in the error state.
fn point_velocity_h(
    c_vb: &Matrix3<f64>,
    lever: &Vector3<f64>,
    x: &InsState,
) -> SMatrix<f64, 3, 15> {
    let rt = x.att.matrix().transpose();
    let mut full = SMatrix::<f64, 3, 15>::zeros();
    full.fixed_view_mut::<3, 3>(0, InsState::ATT.start()).copy_from(&(c_vb * hat(&(rt * x.vel))));
    full.fixed_view_mut::<3, 3>(0, InsState::VEL.start()).copy_from(&(c_vb * rt));
    full.fixed_view_mut::<3, 3>(0, InsState::BG.start()).copy_from(&(c_vb * hat(lever)));
    full
}

/// `C_vb` from the IMU's mounting angles (roll, pitch, yaw of the body frame relative to
/// the vehicle frame, as `R_nb` holds the body's relative to NED), rad: `v_v = C_vb v_b`.
pub fn mounting_matrix(angles: &Vector3<f64>) -> Matrix3<f64> {
    So3::from_euler(angles.x, angles.y, angles.z).matrix()
}

/// The non-holonomic constraint: lateral and vertical vehicle-frame velocity are zero at
/// the constraint point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Nhc {
    /// `C_vb`, body → vehicle frame ([`mounting_matrix`]).
    pub c_vb: Matrix3<f64>,
    /// The constraint point (e.g. the middle of the rear axle) from the IMU, body frame
    /// (FRD), m.
    pub lever_arm: Vector3<f64>,
    /// Measured angular rate at the epoch, rad/s (bias removed inside).
    pub gyro_rate: Vector3<f64>,
}

impl Nhc {
    /// The constraint point's velocity in the vehicle frame.
    pub fn vehicle_velocity(&self, x: &InsState) -> Vector3<f64> {
        point_velocity(&self.c_vb, &self.lever_arm, &self.gyro_rate, x)
    }

    fn h(&self, x: &InsState) -> SMatrix<f64, 2, 15> {
        point_velocity_h(&self.c_vb, &self.lever_arm, x).fixed_rows::<2>(1).into_owned()
    }
}

impl MeasurementModel for Nhc {
    type State = InsState;
    type Measurement = Vector2<f64>;

    fn predict(&self, x: &InsState) -> Vector2<f64> {
        let v = self.vehicle_velocity(x);
        Vector2::new(v.y, v.z)
    }

    fn jacobian(&self, x: &InsState) -> MeasurementJacobians<Const<2>, Const<15>> {
        MeasurementJacobians { H: self.h(x) }
    }

    fn stream(&self) -> StreamId {
        NHC
    }
}

/// The odometer: the forward speed of the wheel point in the vehicle frame,
/// `z = [C_vb (R_nbᵀ v + ω × l)]_x`, its `H` the first row of the NHC's. The odometer's own
/// scale factor is calibrated outside the filter ([`OdometerScale`]) and divided out of
/// `z` before the update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Odometer {
    /// `C_vb`, body → vehicle frame.
    pub c_vb: Matrix3<f64>,
    /// The wheel point from the IMU, body frame, m.
    pub lever_arm: Vector3<f64>,
    /// Measured angular rate, rad/s.
    pub gyro_rate: Vector3<f64>,
}

impl MeasurementModel for Odometer {
    type State = InsState;
    type Measurement = nalgebra::Vector1<f64>;

    fn predict(&self, x: &InsState) -> nalgebra::Vector1<f64> {
        nalgebra::Vector1::new(point_velocity(&self.c_vb, &self.lever_arm, &self.gyro_rate, x).x)
    }

    fn jacobian(&self, x: &InsState) -> MeasurementJacobians<Const<1>, Const<15>> {
        MeasurementJacobians {
            H: point_velocity_h(&self.c_vb, &self.lever_arm, x).fixed_rows::<1>(0).into_owned(),
        }
    }

    fn stream(&self) -> StreamId {
        ODOMETER
    }
}

/// A vehicle-frame velocity model (the NHC, the odometer) that the mounting states of
/// [`crate::calibration`] apply to: its `C_vb`, the same model with another, and the
/// Jacobian of its prediction in a mounting correction `μ` with `C_vb = Exp(μ) C₀`.
pub trait VehicleModel: MeasurementModel<State = InsState> + Copy
where
    nalgebra::DefaultAllocator: estimator_core::FilterAlloc<Const<15>, estimator_core::StateDim<Self::Measurement>>
        + estimator_core::FilterAlloc<Const<3>, estimator_core::StateDim<Self::Measurement>>,
{
    /// The model's `C_vb`.
    fn c_vb(&self) -> Matrix3<f64>;

    /// The same model with `c_vb`.
    fn with_c_vb(&self, c_vb: Matrix3<f64>) -> Self;

    /// `∂h/∂μ` at `μ` for the model's `C₀ = self.c_vb()`: with `w = C₀ u_b` (`u_b` the
    /// point's body-frame velocity) and `Exp(μ + δ) = Exp(μ) Exp(J_r(μ) δ)`, the rows of
    /// `−Exp(μ) [w×] J_r(μ)` the model measures.
    fn mounting_jacobian(
        &self,
        x: &InsState,
        mu: &Vector3<f64>,
    ) -> nalgebra::OMatrix<f64, estimator_core::StateDim<Self::Measurement>, Const<3>>;

    /// Whether the model reads a wheel (the odometer: a reading with a scale error).
    fn wheel(&self) -> bool {
        false
    }

    /// The measured point's lever arm from the IMU (body FRD), m.
    fn lever_arm(&self) -> Vector3<f64>;

    /// The same model at lever arm `lever`.
    fn with_lever_arm(&self, lever: Vector3<f64>) -> Self;

    /// `∂h/∂l`: the rows of `C_vb [ω×]` the model measures (`ω` the bias-corrected rate).
    fn lever_jacobian(
        &self,
        x: &InsState,
    ) -> nalgebra::OMatrix<f64, estimator_core::StateDim<Self::Measurement>, Const<3>>;
}

/// `C_vb [ω×]`: the point velocity's Jacobian in its lever arm.
fn lever_rows(c_vb: &Matrix3<f64>, gyro: &Vector3<f64>, x: &InsState) -> Matrix3<f64> {
    c_vb * hat(&(gyro - x.bg))
}

/// `−Exp(μ) [w×] J_r(μ)` with `w = C₀ (R_nbᵀ v + (ω̃ − b_g) × l)`: the vehicle-frame
/// velocity's Jacobian in the mounting correction.
fn mounting_rows(
    c0: &Matrix3<f64>,
    lever: &Vector3<f64>,
    gyro: &Vector3<f64>,
    x: &InsState,
    mu: &Vector3<f64>,
) -> Matrix3<f64> {
    let w = point_velocity(c0, lever, gyro, x);
    -So3::exp(mu).matrix() * hat(&w) * manifolds::right_jacobian(mu)
}

impl VehicleModel for Nhc {
    fn c_vb(&self) -> Matrix3<f64> {
        self.c_vb
    }

    fn with_c_vb(&self, c_vb: Matrix3<f64>) -> Self {
        Self { c_vb, ..*self }
    }

    fn mounting_jacobian(&self, x: &InsState, mu: &Vector3<f64>) -> SMatrix<f64, 2, 3> {
        mounting_rows(&self.c_vb, &self.lever_arm, &self.gyro_rate, x, mu)
            .fixed_rows::<2>(1)
            .into_owned()
    }

    fn lever_arm(&self) -> Vector3<f64> {
        self.lever_arm
    }

    fn with_lever_arm(&self, lever_arm: Vector3<f64>) -> Self {
        Self { lever_arm, ..*self }
    }

    fn lever_jacobian(&self, x: &InsState) -> SMatrix<f64, 2, 3> {
        lever_rows(&self.c_vb, &self.gyro_rate, x).fixed_rows::<2>(1).into_owned()
    }
}

impl VehicleModel for Odometer {
    fn c_vb(&self) -> Matrix3<f64> {
        self.c_vb
    }

    fn with_c_vb(&self, c_vb: Matrix3<f64>) -> Self {
        Self { c_vb, ..*self }
    }

    fn mounting_jacobian(&self, x: &InsState, mu: &Vector3<f64>) -> SMatrix<f64, 1, 3> {
        mounting_rows(&self.c_vb, &self.lever_arm, &self.gyro_rate, x, mu)
            .fixed_rows::<1>(0)
            .into_owned()
    }

    fn wheel(&self) -> bool {
        true
    }

    fn lever_arm(&self) -> Vector3<f64> {
        self.lever_arm
    }

    fn with_lever_arm(&self, lever_arm: Vector3<f64>) -> Self {
        Self { lever_arm, ..*self }
    }

    fn lever_jacobian(&self, x: &InsState) -> SMatrix<f64, 1, 3> {
        lever_rows(&self.c_vb, &self.gyro_rate, x).fixed_rows::<1>(0).into_owned()
    }
}

/// The odometer's scale `r` (reading = r × true speed), calibrated against the filter's
/// forward speed while GNSS keeps that speed right: an exponentially weighted least
/// squares `r = Σ w v_odo v̂ / Σ w v̂²` over the samples the caller picks, with time constant
/// `tau`. Outside the filter (a cascade): the filter does not carry the scale's
/// uncertainty, which the odometer's σ must cover.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OdometerScale {
    sxy: f64,
    sxx: f64,
    weight: f64,
}

impl Default for OdometerScale {
    fn default() -> Self {
        Self { sxy: 0.0, sxx: 0.0, weight: 0.0 }
    }
}

impl OdometerScale {
    /// Add a pair (odometer reading, filter forward speed) after `dt` seconds, forgetting
    /// with time constant `tau`.
    pub fn add(&mut self, reading: f64, forward: f64, dt: f64, tau: f64) {
        let w = (-dt / tau.max(1e-3)).exp();
        self.sxy = w * self.sxy + reading * forward;
        self.sxx = w * self.sxx + forward * forward;
        self.weight = w * self.weight + 1.0;
    }

    /// The calibrated scale once at least `min_weight` samples count, else `None`.
    pub fn scale(&self, min_weight: f64) -> Option<f64> {
        (self.weight >= min_weight && self.sxx > 0.0).then(|| self.sxy / self.sxx)
    }
}

/// Odometer settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OdometerConfig {
    /// The wheel point from the IMU, body frame, m.
    pub lever_arm: Vector3<f64>,
    /// 1σ of the scale-corrected forward speed, m/s.
    pub std: f64,
    /// Time between updates, s.
    pub interval: f64,
    /// Time constant of the scale calibration, s.
    pub calibration_time: f64,
    /// Samples (the wheels turning, with GNSS) before the calibrated scale is used; until
    /// then the odometer is not used.
    pub calibration_samples: f64,
}

impl Default for OdometerConfig {
    fn default() -> Self {
        Self {
            lever_arm: Vector3::zeros(),
            std: 0.1,
            interval: 0.1,
            calibration_time: 120.0,
            calibration_samples: 500.0,
        }
    }
}

/// Zero velocity: `z = v_n = 0`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Zupt;

impl MeasurementModel for Zupt {
    type State = InsState;
    type Measurement = R3;

    fn predict(&self, x: &InsState) -> R3 {
        x.vel
    }

    fn jacobian(&self, _x: &InsState) -> MeasurementJacobians<Const<3>, Const<15>> {
        let mut H = SMatrix::<f64, 3, 15>::zeros();
        H.fixed_view_mut::<3, 3>(0, InsState::VEL.start()).copy_from(&Matrix3::identity());
        MeasurementJacobians { H }
    }

    fn stream(&self) -> StreamId {
        ZUPT
    }
}

/// Zero angular rate: the mean measured rate while standing is the gyro bias plus the
/// Earth rate in the body frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Zaru;

impl Zaru {
    fn earth_rate_body(x: &InsState) -> Vector3<f64> {
        x.att.matrix().transpose() * earth_rate_ned(x.pos.lat)
    }
}

impl MeasurementModel for Zaru {
    type State = InsState;
    type Measurement = R3;

    fn predict(&self, x: &InsState) -> R3 {
        x.bg + Self::earth_rate_body(x)
    }

    fn jacobian(&self, x: &InsState) -> MeasurementJacobians<Const<3>, Const<15>> {
        let mut H = SMatrix::<f64, 3, 15>::zeros();
        H.fixed_view_mut::<3, 3>(0, InsState::ATT.start())
            .copy_from(&hat(&Self::earth_rate_body(x)));
        H.fixed_view_mut::<3, 3>(0, InsState::BG.start()).copy_from(&Matrix3::identity());
        MeasurementJacobians { H }
    }

    fn stream(&self) -> StreamId {
        ZARU
    }
}

/// Thresholds of the [`StationaryDetector`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DetectorConfig {
    /// Window length, s. Default 1.
    pub window: f64,
    /// Largest bias-corrected angular rate magnitude inside the window, rad/s.
    /// Default 0.5°/s.
    pub gyro_max: f64,
    /// Largest standard deviation of the specific-force magnitude inside the window,
    /// m/s². Default 0.05.
    pub accel_std_max: f64,
}

impl Default for DetectorConfig {
    fn default() -> Self {
        Self { window: 1.0, gyro_max: 0.5f64.to_radians(), accel_std_max: 0.05 }
    }
}

/// A windowed stationary detector on IMU statistics: the vehicle stands when, over the
/// last `window` seconds, every bias-corrected angular rate is below `gyro_max` and the
/// specific-force magnitude's standard deviation is below `accel_std_max` (an engine's
/// vibration passes; a car rolling at walking pace does not — its wheels shake the
/// accelerometers). A ring buffer sized at the first sample: no allocation afterwards.
#[derive(Clone, Debug)]
pub struct StationaryDetector {
    config: DetectorConfig,
    /// `(|ω − b_g|, |f|, ω)` of the samples in the window.
    buf: Vec<(f64, f64, Vector3<f64>)>,
    head: usize,
    len: usize,
    stationary: bool,
}

impl StationaryDetector {
    /// A detector with the given thresholds.
    pub fn new(config: DetectorConfig) -> Self {
        Self { config, buf: Vec::new(), head: 0, len: 0, stationary: false }
    }

    /// The thresholds.
    pub fn config(&self) -> &DetectorConfig {
        &self.config
    }

    /// Add one sample's mean rate (raw, rad/s), specific force (m/s²) and the current gyro
    /// bias estimate; returns whether the vehicle stands now.
    pub fn push(
        &mut self,
        dt: f64,
        rate: &Vector3<f64>,
        force: &Vector3<f64>,
        bg: &Vector3<f64>,
    ) -> bool {
        if self.buf.is_empty() {
            let n = ((self.config.window / dt.max(1e-6)).ceil() as usize).clamp(2, 100_000);
            self.buf = vec![(0.0, 0.0, Vector3::zeros()); n];
        }
        let cap = self.buf.len();
        let idx = (self.head + self.len) % cap;
        self.buf[idx] = ((rate - bg).norm(), force.norm(), *rate);
        if self.len < cap {
            self.len += 1;
        } else {
            self.head = (self.head + 1) % cap;
        }
        self.stationary = self.len == cap && self.decide();
        self.stationary
    }

    fn samples(&self) -> impl Iterator<Item = &(f64, f64, Vector3<f64>)> {
        let cap = self.buf.len();
        (0..self.len).map(move |k| &self.buf[(self.head + k) % cap])
    }

    fn decide(&self) -> bool {
        if self.samples().any(|s| s.0 > self.config.gyro_max) {
            return false;
        }
        let n = self.len as f64;
        let mean = self.samples().map(|s| s.1).sum::<f64>() / n;
        let var = self.samples().map(|s| (s.1 - mean).powi(2)).sum::<f64>() / (n - 1.0);
        var.sqrt() <= self.config.accel_std_max
    }

    /// Whether the last sample was judged stationary.
    pub fn is_stationary(&self) -> bool {
        self.stationary
    }

    /// Mean raw angular rate over the window (the ZARU measurement), rad/s.
    pub fn mean_rate(&self) -> Vector3<f64> {
        let n = self.len.max(1) as f64;
        self.samples().fold(Vector3::zeros(), |a, s| a + s.2) / n
    }
}

/// Vehicle-aiding settings for the [`Navigator`](crate::Navigator).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct VehicleAiding {
    /// The non-holonomic constraint, when on.
    pub nhc: Option<NhcConfig>,
    /// ZUPT and ZARU on detected stops, when on.
    pub zupt: Option<ZuptConfig>,
    /// The odometer (the IMU samples' `odometer` speeds), when on.
    pub odometer: Option<OdometerConfig>,
}

impl VehicleAiding {
    /// True when any aiding is on.
    pub fn any(&self) -> bool {
        self.nhc.is_some() || self.zupt.is_some() || self.odometer.is_some()
    }
}

/// NHC settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NhcConfig {
    /// Mounting angles (roll, pitch, yaw) of the IMU relative to the vehicle, rad.
    pub mounting: Vector3<f64>,
    /// Constraint point from the IMU (body frame FRD), m.
    pub lever_arm: Vector3<f64>,
    /// 1σ of the lateral and vertical velocity, m/s.
    pub std: Vector2<f64>,
    /// Time between updates, s (0: every IMU sample).
    pub interval: f64,
    /// Applied only above this speed, m/s.
    pub min_speed: f64,
}

impl Default for NhcConfig {
    fn default() -> Self {
        Self {
            mounting: Vector3::zeros(),
            lever_arm: Vector3::zeros(),
            std: Vector2::new(0.1, 0.1),
            interval: 0.1,
            min_speed: 0.0,
        }
    }
}

/// ZUPT/ZARU settings. The vehicle stands when the [`StationaryDetector`] says so, or,
/// with the odometer on, when the odometer reads zero.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZuptConfig {
    /// The stationary detector's thresholds.
    pub detector: DetectorConfig,
    /// 1σ of the zero velocity, m/s.
    pub velocity_std: f64,
    /// 1σ of the zero angular rate beyond the window mean's white noise (which the
    /// navigator adds from the model's ARW: `ARW²/window` per axis), rad/s; `None`: no
    /// ZARU.
    pub rate_std: Option<f64>,
    /// Time between updates while stationary, s.
    pub interval: f64,
    /// Applied only while the filter's own speed is below this plus `speed_sigmas` times
    /// its σ, m/s: a second opinion for sensors whose rest and smooth cruising look alike
    /// to the detector. Default 0.3.
    pub max_speed: f64,
    /// How many of the speed's σ widen `max_speed` (so that a stop in a GNSS outage, when
    /// the speed estimate has drifted, is still taken). Default 3; 0 for a detector that
    /// fires while the vehicle creeps.
    pub speed_sigmas: f64,
    /// The last time (s) at which a stop is taken: `f64::INFINITY` for the whole run; the
    /// end of a static start for the aiding the start turns on over it.
    pub until: f64,
    /// ZARU alone (no ZUPT): what the start turns on over a static start, to hold the
    /// heading (the zero velocity there changed how single-point fixes' wander was
    /// learned: one seed of the everyday corpus 1.88 → 2.89 m).
    pub zaru_only: bool,
}

impl Default for ZuptConfig {
    fn default() -> Self {
        Self {
            detector: DetectorConfig::default(),
            velocity_std: 0.02,
            rate_std: Some(0.01f64.to_radians()),
            interval: 0.1,
            max_speed: 0.3,
            speed_sigmas: 3.0,
            until: f64::INFINITY,
            zaru_only: false,
        }
    }
}
