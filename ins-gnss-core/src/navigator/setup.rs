//! What a navigator starts from and is configured with: the initial state and its σ, the
//! GNSS measurement settings, and the errors a navigator reports.

use super::*;

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

/// What a navigator starts from, typed by the state it starts: the INS's initial state
/// alone (the 15-state [`InsState`]), or with what the state adds to it. The one
/// constructor, [`Navigator::new`], takes any of these:
///
/// | start | state |
/// |---|---|
/// | `&InitialState` | [`InsState`] (15) |
/// | `(&InitialState, &ScaleInit)` | [`InsState21`] (21: the IMU's scale factors) |
/// | `(&InitialState, &ClockInit)` | [`InsStateTc`] (20: tight coupling, the receiver clock and inter-system biases) |
/// | `(&InitialState, &ScaleInit, &ClockInit)` | [`InsStateTc21`] (26) |
///
/// Other states (the calibration's, the fixes' persisting error) start from a state and
/// its covariance, [`Navigator::from_parts`].
pub trait NavStart
where
    DefaultAllocator: DimAlloc<<Self::State as Manifold>::Dim>,
{
    /// The state this start begins.
    type State: NavState;

    /// The time of the start, s.
    fn time(&self) -> f64;

    /// The state and its covariance at [`NavStart::time`].
    fn state_and_covariance(&self) -> (Self::State, Cov<<Self::State as Manifold>::Dim>);
}

impl NavStart for &InitialState {
    type State = InsState;

    fn time(&self) -> f64 {
        self.time
    }

    fn state_and_covariance(&self) -> (InsState, M15) {
        (self.state.clone(), self.std.covariance())
    }
}

/// The scale factors' block of a covariance whose first 21 rows are a [`InsState21`]'s.
fn scale_block<D: DimName>(p: &mut OMatrix<f64, D, D>, scale: &ScaleInit)
where
    DefaultAllocator: Allocator<D, D>,
{
    for k in 0..3 {
        p[(15 + k, 15 + k)] = scale.sg_std[k].powi(2);
        p[(18 + k, 18 + k)] = scale.sa_std[k].powi(2);
    }
}

/// The receiver clock's and the inter-system biases' block of a tightly coupled state's
/// covariance (`clock`: the clock's first row; `isb`: the biases' rows).
fn clock_block<D: DimName>(
    p: &mut OMatrix<f64, D, D>,
    clock: &ClockInit,
    c0: usize,
    isb: core::ops::Range<usize>,
) where
    DefaultAllocator: Allocator<D, D>,
{
    p[(c0, c0)] = clock.std.0.powi(2);
    p[(c0 + 1, c0 + 1)] = clock.std.1.powi(2);
    for k in isb {
        p[(k, k)] = clock.isb_std.powi(2);
    }
}

/// The INS's initial covariance in the first 15 rows and columns of a larger one.
fn ins_block<D: DimName>(init: &InitialState) -> OMatrix<f64, D, D>
where
    DefaultAllocator: Allocator<D, D>,
{
    let mut p = OMatrix::<f64, D, D>::zeros();
    p.fixed_view_mut::<15, 15>(0, 0).copy_from(&init.std.covariance());
    p
}

impl NavStart for (&InitialState, &ScaleInit) {
    type State = InsState21;

    fn time(&self) -> f64 {
        self.0.time
    }

    fn state_and_covariance(&self) -> (InsState21, M21) {
        let (init, scale) = *self;
        let x = InsState21 { nav: init.state.clone(), sg: scale.sg, sa: scale.sa };
        let mut p = ins_block(init);
        scale_block(&mut p, scale);
        (x, p)
    }
}

impl NavStart for (&InitialState, &ClockInit) {
    type State = InsStateTc;

    fn time(&self) -> f64 {
        self.0.time
    }

    fn state_and_covariance(&self) -> (InsStateTc, M20) {
        let (init, clock) = *self;
        let x = InsStateTc {
            nav: init.state.clone(),
            clock: manifolds::R2::new(clock.clock.0, clock.clock.1),
            isb: Vector3::zeros(),
        };
        let mut p = ins_block(init);
        clock_block(&mut p, clock, InsStateTc::CLOCK.start(), InsStateTc::ISB.range());
        (x, p)
    }
}

impl NavStart for (&InitialState, &ScaleInit, &ClockInit) {
    type State = InsStateTc21;

    fn time(&self) -> f64 {
        self.0.time
    }

    fn state_and_covariance(&self) -> (InsStateTc21, M26) {
        let (init, scale, clock) = *self;
        let x = InsStateTc21 {
            nav: InsState21 { nav: init.state.clone(), sg: scale.sg, sa: scale.sa },
            clock: manifolds::R2::new(clock.clock.0, clock.clock.1),
            isb: Vector3::zeros(),
        };
        let mut p = ins_block(init);
        scale_block(&mut p, scale);
        clock_block(&mut p, clock, InsStateTc21::CLOCK.start(), InsStateTc21::ISB.range());
        (x, p)
    }
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
    /// How the fixes' error splits into a persisting part (states of a navigation state
    /// that carries them, [`InsStateFe`](crate::fix_error::InsStateFe)) and white noise;
    /// ignored by the other states.
    pub fix_errors: FixErrorSplit,
    /// The headings of two antennas ([`AntennaHeading`](crate::heading::AntennaHeading)
    /// on the epochs): how they are used; `None`: ignored.
    pub heading: Option<crate::heading::HeadingConfig>,
}

impl Default for GnssConfig {
    fn default() -> Self {
        Self {
            lever_arm: Vector3::zeros(),
            use_velocity: true,
            pos_std: None,
            vel_std: None,
            fix_errors: FixErrorSplit::default(),
            heading: None,
        }
    }
}

/// How a fix's declared position error splits into a persisting Gauss–Markov part, the
/// states of [`fix_error`](crate::fix_error), and white noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixErrorSplit {
    /// The persisting part's share of the declared variance (0–1), the prior of the
    /// split: the white part is `(1 − share)` of the declared variance times the factor
    /// learned from the fixes' residuals, the persisting part's variance `κ` times the
    /// white part's, `κ` from `share / (1 − share)` and the innovations' whiteness
    /// ([`FixSplitLearner`](crate::fix_error::FixSplitLearner)). Ignored when `sigma` is
    /// given.
    pub share: f64,
    /// The persisting part's correlation time, s.
    pub tau: f64,
    /// The persisting part's σ (N, E, D), m, stated apart from the declared σ, which is
    /// then the white noise's (`None`: the share of the declared σ).
    pub sigma: Option<Vector3<f64>>,
    /// Whether both parts follow the noise scale learned from the fixes' innovations
    /// ([`FixSplitLearner`](crate::fix_error::FixSplitLearner)); with `sigma` given, the
    /// white part only (the persisting part is the one stated).
    pub learn: bool,
}

impl Default for FixErrorSplit {
    fn default() -> Self {
        Self { share: FIX_ERROR_SHARE, tau: FIX_ERROR_TAU, sigma: None, learn: true }
    }
}

/// The default share of a fix's declared variance taken as persisting.
pub const FIX_ERROR_SHARE: f64 = 0.9;

/// The default correlation time of the fixes' persisting error, s.
pub const FIX_ERROR_TAU: f64 = 300.0;

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
