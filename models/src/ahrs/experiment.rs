//! The paper's comparison: the three AHRS variants on the simulated loitering flight.
//!
//! Shared settings as in the paper: `R = 0.02·I₆`, `P₀ = 0.01·I₉`, zero initial error
//! state (attitude from the truth at t = 0, drift and acceleration zero). The paper's
//! process-noise matrices are not interpretable as per-step variances in SI units (its
//! attitude entry 0.01 would be 0.1 rad of noise per 10 ms step), so the gyro terms come
//! from the simulated sensor and the acceleration terms are: conventional — bias random
//! walk 1e-6 (m/s²)²/s; modified — random walk 0.03 (m/s²)²/s (our reading of the
//! paper's 0.03); CS-MAEKF — α = 1/60, k₁ = k₂ = 23, a_th = ±10 m/s², σ_a² floor 1.

use estimator_core::{ErrorStateFilter, FilterError, FixedNoise};
use manifolds::So3;
use nalgebra::{SMatrix, Vector3};

use super::sim::{LoiteringFlight, Sample, SensorErrors};
use super::{AccelModel, Ahrs, AhrsMeasurement, AhrsModel, AhrsState, AhrsTuning};

/// The three filters of the paper.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    /// No maneuvering-acceleration model (third block: accelerometer bias).
    Conventional,
    /// Acceleration state with fixed noise.
    Modified,
    /// Acceleration state with the adaptive current statistical model.
    CsMaekf,
    /// The modified filter with a well-tuned fixed noise (random walk 0.1 (m/s²)²/s): the
    /// control that tells whether adaptivity or the level of `Q` makes the difference.
    ModifiedTuned,
}

/// Where the filter starts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Start {
    /// The paper's shared settings: attitude from the truth, drift and acceleration zero —
    /// although the flight starts inside a 20° bank whose centripetal acceleration the
    /// acceleration state does not know (this sets every filter's maximum roll error).
    #[default]
    Paper,
    /// The same with the true initial body acceleration: a state the filter can know.
    KnownAcceleration,
}

impl Variant {
    /// The paper's three, in its order.
    pub const ALL: [Variant; 3] = [Variant::Conventional, Variant::Modified, Variant::CsMaekf];

    /// The paper's three and the tuned control.
    pub const WITH_CONTROL: [Variant; 4] =
        [Variant::Conventional, Variant::Modified, Variant::ModifiedTuned, Variant::CsMaekf];

    /// Name used in tables.
    pub fn name(&self) -> &'static str {
        match self {
            Variant::Conventional => "conventional",
            Variant::Modified => "modified",
            Variant::CsMaekf => "cs-maekf",
            Variant::ModifiedTuned => "modified, q = 0.1",
        }
    }

    /// The process model of this variant for a sensor with `errors` at `rate` Hz.
    pub fn model(&self, errors: &SensorErrors, rate: f64) -> AhrsModel {
        let tuning = AhrsTuning { gyro_psd: errors.gyro_noise.powi(2) / rate, drift_psd: 1e-10 };
        let accel = match self {
            Variant::Conventional => AccelModel::None { q: 1e-6 },
            Variant::Modified => AccelModel::RandomWalk { q: 0.03 },
            Variant::ModifiedTuned => AccelModel::RandomWalk { q: 0.1 },
            Variant::CsMaekf => return super::onboard::cs_maekf_model(errors.gyro_noise, rate),
        };
        AhrsModel { tuning, accel }
    }
}

/// Maximum and RMS of roll, pitch and yaw errors, degrees.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AttitudeErrors {
    /// Max |error| roll, pitch, yaw.
    pub max: [f64; 3],
    /// RMS roll, pitch, yaw.
    pub rms: [f64; 3],
}

fn euler_error(est: &So3, truth: &So3) -> [f64; 3] {
    let (a, b) = (est.euler(), truth.euler());
    let w = manifolds::wrap_angle;
    [w(a.0 - b.0).to_degrees(), w(a.1 - b.1).to_degrees(), w(a.2 - b.2).to_degrees()]
}

/// Run one variant over simulated samples.
pub fn run(
    variant: Variant,
    flight: &LoiteringFlight,
    errors: &SensorErrors,
    samples: &[Sample],
) -> Result<AttitudeErrors, FilterError> {
    run_with_model(&variant.model(errors, flight.rate), flight, samples)
}

/// Run a given AHRS model (e.g. another CS reading) with the paper's shared settings.
pub fn run_with_model(
    model: &AhrsModel,
    flight: &LoiteringFlight,
    samples: &[Sample],
) -> Result<AttitudeErrors, FilterError> {
    run_traced(model, flight, samples, |_, _| {})
}

/// [`run_with_model`], calling `each(t, [roll, pitch, yaw] error in degrees)` after every
/// sample (for plots).
pub fn run_traced(
    model: &AhrsModel,
    flight: &LoiteringFlight,
    samples: &[Sample],
    each: impl FnMut(f64, [f64; 3]),
) -> Result<AttitudeErrors, FilterError> {
    run_from(model, flight, samples, Start::Paper, each)
}

/// [`run_traced`] from the chosen [`Start`].
pub fn run_from(
    model: &AhrsModel,
    flight: &LoiteringFlight,
    samples: &[Sample],
    start: Start,
    mut each: impl FnMut(f64, [f64; 3]),
) -> Result<AttitudeErrors, FilterError> {
    let meas = AhrsMeasurement { g_n: flight.g_n, m_n: flight.m_n };
    let acc = match start {
        Start::Paper => Vector3::zeros(),
        Start::KnownAcceleration => flight.body_acceleration(0.0),
    };
    let x0 = AhrsState { att: flight.attitude(0.0), bg: Vector3::zeros(), acc };
    let p0 = SMatrix::<f64, 9, 9>::identity() * super::onboard::P0;
    let filter = ErrorStateFilter::new(x0, p0, FixedNoise)?;
    let mut ahrs = Ahrs::from_filter(filter, model.clone(), meas, super::onboard::R, flight.rate);
    let (mut max, mut sq) = ([0.0_f64; 3], [0.0_f64; 3]);
    for s in samples {
        ahrs.step(&s.gyro, &s.accel, &s.mag)?;
        let e = euler_error(&ahrs.state().att, &s.att);
        each(s.t, e);
        for k in 0..3 {
            max[k] = max[k].max(e[k].abs());
            sq[k] += e[k] * e[k];
        }
    }
    let n = samples.len().max(1) as f64;
    Ok(AttitudeErrors { max, rms: [(sq[0] / n).sqrt(), (sq[1] / n).sqrt(), (sq[2] / n).sqrt()] })
}

/// Run all three variants on one seed.
pub fn run_seed(
    flight: &LoiteringFlight,
    errors: &SensorErrors,
    seed: u64,
) -> Result<[AttitudeErrors; 3], FilterError> {
    let samples = flight.simulate(errors, seed);
    Ok([
        run(Variant::Conventional, flight, errors, &samples)?,
        run(Variant::Modified, flight, errors, &samples)?,
        run(Variant::CsMaekf, flight, errors, &samples)?,
    ])
}

/// The paper's three filters and the tuned control on one seed, from `start`.
pub fn run_seed_with_control(
    flight: &LoiteringFlight,
    errors: &SensorErrors,
    seed: u64,
    start: Start,
) -> Result<[AttitudeErrors; 4], FilterError> {
    let samples = flight.simulate(errors, seed);
    let run =
        |v: Variant| run_from(&v.model(errors, flight.rate), flight, &samples, start, |_, _| {});
    Ok([
        run(Variant::Conventional)?,
        run(Variant::Modified)?,
        run(Variant::ModifiedTuned)?,
        run(Variant::CsMaekf)?,
    ])
}

/// Single against double precision on one sample sequence: the same model and start in
/// `Ahrs<f64>` and `Ahrs<f32>` (the samples and the start rounded to `f32`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrecisionDifference {
    /// Samples run (all of them unless the `f32` filter failed).
    pub samples: usize,
    /// Largest angle between the two filters' attitudes, degrees.
    pub max_deg: f64,
    /// RMS of that angle over the samples, degrees.
    pub rms_deg: f64,
    /// Smallest eigenvalue of the `f32` covariance at the checks, relative to its largest.
    pub min_relative_eigenvalue: f64,
    /// Whether the `f32` covariance had a Cholesky factor (in `f32`) at every check and was
    /// exactly symmetric.
    pub positive_definite: bool,
    /// The sample at which the `f32` filter returned an error, if it did.
    pub failed_at: Option<usize>,
}

/// Run `model` in `f64` and in `f32` over `samples` with the paper's settings and update
/// `form`, comparing the attitudes after every sample and checking the `f32` covariance
/// every `check_every` samples (see [`PrecisionDifference`]).
pub fn f32_against_f64(
    model: &AhrsModel,
    flight: &LoiteringFlight,
    samples: &[Sample],
    form: estimator_core::UpdateForm,
    check_every: usize,
) -> Result<PrecisionDifference, FilterError> {
    use manifolds::Manifold;
    let meas = AhrsMeasurement { g_n: flight.g_n, m_n: flight.m_n };
    let meas32 =
        AhrsMeasurement { g_n: flight.g_n.map(|v| v as f32), m_n: flight.m_n.map(|v| v as f32) };
    let att0 = flight.attitude(0.0);
    let mut a64 = Ahrs::<f64>::new(model.clone(), meas, att0, flight.rate)?.with_update_form(form);
    let mut a32 = Ahrs::<f32>::new(model.clone(), meas32, att0.cast::<f32>(), flight.rate)?
        .with_update_form(form);
    let mut out = PrecisionDifference {
        samples: 0,
        max_deg: 0.0,
        rms_deg: 0.0,
        min_relative_eigenvalue: f64::INFINITY,
        positive_definite: true,
        failed_at: None,
    };
    let mut sq = 0.0;
    for (k, s) in samples.iter().enumerate() {
        a64.step(&s.gyro, &s.accel, &s.mag)?;
        let f = |v: &Vector3<f64>| v.map(|x| x as f32);
        if a32.step(&f(&s.gyro), &f(&s.accel), &f(&s.mag)).is_err() {
            out.failed_at = Some(k);
            out.positive_definite = false;
            break;
        }
        let d = a32.state().att.cast::<f64>().ominus(&a64.state().att).norm().to_degrees();
        out.max_deg = out.max_deg.max(d);
        sq += d * d;
        out.samples = k + 1;
        if (k + 1) % check_every.max(1) == 0 || k + 1 == samples.len() {
            let p = a32.filter().covariance_raw();
            out.positive_definite &= (*p).cholesky().is_some() && p == &p.transpose();
            let eig = p.map(|v| v as f64).symmetric_eigenvalues();
            let (lo, hi) = (eig.min(), eig.max());
            out.min_relative_eigenvalue = out.min_relative_eigenvalue.min(lo / hi);
        }
    }
    out.rms_deg = (sq / out.samples.max(1) as f64).sqrt();
    Ok(out)
}

impl LoiteringFlight {
    /// The same loiter flown `repeats` times over (its acceleration segments repeated): a
    /// flight of `repeats` times the duration.
    pub fn repeated(&self, repeats: usize) -> LoiteringFlight {
        let mut f = self.clone();
        f.segments = (0..repeats).flat_map(|_| self.segments.iter().copied()).collect();
        f
    }
}
