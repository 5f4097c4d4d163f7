//! A library user's own attitude filter, written against the traits alone: state
//! `(So3, R3)` (attitude `R_nb` and gyro bias), a 100 Hz gyro as the input, and two
//! direction measurements at 10 Hz — gravity from the accelerometer and the magnetic
//! field from the magnetometer, each a unit vector in R³ with `R = σ² I₃`, as FilterPy
//! users write them (so `H P Hᵀ` has rank 2: the direction's own axis is not observable).
//!
//! Knobs for what the strategies exist for and what they must survive: a magnetic
//! disturbance (the magnetometer's noise a multiple of its declared value for a while),
//! 60° magnetometer outliers, a wrong declared noise.
#![allow(dead_code, non_snake_case)]

use estimator_core::{
    ErrorStateFilter, FilterError, MeasurementJacobians, MeasurementModel, NoiseStrategy,
    ProcessJacobians, ProcessModel, StreamId,
};
use manifolds::{hat, right_jacobian, Manifold, So3};
use nalgebra::{Matrix3, SMatrix, Unit, Vector3};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;

/// Attitude (body → nav) and gyro bias (rad/s).
pub type Att = (So3, Vector3<f64>);

/// `R ← R Exp((ω − b) dt)`, `b` a random walk.
#[derive(Clone, Copy, Debug)]
pub struct Gyro {
    /// Gyro white noise, rad/s/√Hz.
    pub arw: f64,
    /// Bias random walk, rad/s/√s.
    pub bias_walk: f64,
}

impl ProcessModel for Gyro {
    type State = Att;
    type Input = Vector3<f64>;

    fn propagate(&self, x: &Att, w: &Vector3<f64>, dt: f64) -> Att {
        (x.0 * So3::exp(&((w - x.1) * dt)), x.1)
    }

    // δθ' = Exp(−ω̂dt) δθ − J_r(ω̂dt) dt (δb + n_g),  δb' = δb + n_b
    fn jacobians(&self, x: &Att, w: &Vector3<f64>, dt: f64) -> ProcessJacobians<nalgebra::U6> {
        let phi = (w - x.1) * dt;
        let mut Phi = SMatrix::<f64, 6, 6>::identity();
        Phi.fixed_view_mut::<3, 3>(0, 0).copy_from(&So3::exp(&phi).matrix().transpose());
        let jr = right_jacobian(&phi);
        Phi.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-jr * dt));
        let mut Q = SMatrix::<f64, 6, 6>::zeros();
        let qg = jr * jr.transpose() * (self.arw * self.arw * dt);
        Q.fixed_view_mut::<3, 3>(0, 0).copy_from(&qg);
        Q.fixed_view_mut::<3, 3>(3, 3)
            .copy_from(&(Matrix3::identity() * (self.bias_walk * self.bias_walk * dt)));
        ProcessJacobians { Phi, Q }
    }
}

/// A reference direction seen in the body: `h(x) = R_nbᵀ d_n`, a unit vector in R³.
#[derive(Clone, Copy, Debug)]
pub struct Direction {
    /// The direction in the navigation frame (unit).
    pub d_n: Vector3<f64>,
    /// The stream the measurement belongs to.
    pub stream: StreamId,
}

impl MeasurementModel for Direction {
    type State = Att;
    type Measurement = Vector3<f64>;

    fn predict(&self, x: &Att) -> Vector3<f64> {
        x.0.inverse().rotate(&self.d_n)
    }

    // h(R Exp(δθ)) = (I − [δθ×]) Rᵀd = h + [h×] δθ
    fn jacobian(&self, x: &Att) -> MeasurementJacobians<nalgebra::U3, nalgebra::U6> {
        let h = self.predict(x);
        let mut H = SMatrix::<f64, 3, 6>::zeros();
        H.fixed_view_mut::<3, 3>(0, 0).copy_from(&hat(&h));
        MeasurementJacobians { H }
    }

    fn stream(&self) -> StreamId {
        self.stream
    }
}

/// Gravity's direction, up in NED being −z: the accelerometer at rest reads `−g` rotated.
pub fn gravity() -> Direction {
    Direction { d_n: Vector3::new(0.0, 0.0, -1.0), stream: StreamId::named("accel-dir") }
}

/// The magnetic field's direction at 60° dip, north and down.
pub fn magnetic() -> Direction {
    let dip = 60f64.to_radians();
    Direction { d_n: Vector3::new(dip.cos(), 0.0, dip.sin()), stream: StreamId::named("mag-dir") }
}

#[derive(Clone, Debug)]
pub struct Scenario {
    /// Seconds simulated.
    pub duration: f64,
    /// Gyro rate, Hz.
    pub imu_hz: f64,
    /// Aiding rate, Hz (both directions).
    pub aid_hz: f64,
    /// Gyro white noise, rad/s/√Hz, and bias walk, rad/s/√s (true = declared).
    pub arw: f64,
    pub bias_walk: f64,
    /// Initial bias σ per axis (rad/s), drawn for the truth and declared in P0.
    pub bias_sigma: f64,
    /// Initial attitude σ per axis (rad), drawn and declared.
    pub att_sigma: f64,
    /// Declared direction σ (unit vector), accelerometer and magnetometer.
    pub sigma_acc: f64,
    pub sigma_mag: f64,
    /// True σ as a multiple of the declared one, outside the disturbance.
    pub true_sigma_factor: f64,
    /// The magnetometer's true σ is `disturbance_factor ×` its declared value in
    /// `[disturbance.0, disturbance.1)` s.
    pub disturbance: (f64, f64),
    pub disturbance_factor: f64,
    /// Magnetometer outliers: this many, each the field rotated by `outlier_deg`.
    pub outliers: usize,
    pub outlier_deg: f64,
    /// Angular rate amplitude, rad/s.
    pub rate: f64,
    pub seed: u64,
}

impl Default for Scenario {
    fn default() -> Self {
        Self {
            duration: 200.0,
            imu_hz: 100.0,
            aid_hz: 10.0,
            arw: 0.005,
            bias_walk: 1e-5,
            bias_sigma: 0.009,
            att_sigma: 5f64.to_radians(),
            sigma_acc: 0.02,
            sigma_mag: 0.03,
            true_sigma_factor: 1.0,
            disturbance: (0.0, 0.0),
            disturbance_factor: 1.0,
            outliers: 0,
            outlier_deg: 60.0,
            rate: 0.5,
            seed: 1,
        }
    }
}

impl Scenario {
    /// The case: the magnetometer's noise 10× its declared value for a minute
    /// (60–120 s) and six 60° magnetometer outliers.
    pub fn disturbed(seed: u64) -> Self {
        Self {
            disturbance: (60.0, 120.0),
            disturbance_factor: 10.0,
            outliers: 6,
            seed,
            ..Self::default()
        }
    }

    pub fn clean(seed: u64) -> Self {
        Self { seed, ..Self::default() }
    }
}

/// A random case of the corpus the property tests and `examples/attitude_corpus.rs` draw:
/// 30 s at 50 Hz, the true direction σ 0.3–3× the declared one, the magnetometer's noise
/// 1–20× for 10–20 s, 0–7 magnetometer outliers of 60°, angular rates 0.05–1.5 rad/s.
pub fn corpus_case(rng: &mut StdRng) -> Scenario {
    Scenario {
        duration: 30.0,
        imu_hz: 50.0,
        true_sigma_factor: rng.random_range(0.3..3.0),
        disturbance: (10.0, 20.0),
        disturbance_factor: rng.random_range(1.0..20.0),
        outliers: rng.random_range(0..8),
        rate: rng.random_range(0.05..1.5),
        seed: rng.random_range(0..10_000),
        ..Scenario::default()
    }
}

/// One aiding epoch: both directions as measured.
#[derive(Clone, Debug)]
pub struct Aid {
    pub acc: Vector3<f64>,
    pub mag: Vector3<f64>,
}

pub struct Data {
    /// Gyro samples (one per IMU step).
    pub gyro: Vec<Vector3<f64>>,
    /// Truth (attitude, bias) after each IMU step.
    pub truth: Vec<Att>,
    /// Aiding after IMU step `k` when `aid[k]` is `Some`.
    pub aid: Vec<Option<Aid>>,
    pub x0: Att,
    pub p0: SMatrix<f64, 6, 6>,
}

fn gauss3(rng: &mut StdRng) -> Vector3<f64> {
    Vector3::from_fn(|_, _| rng.sample::<f64, _>(StandardNormal))
}

/// A measured unit vector: the truth plus white noise of σ per axis, normalised.
fn noisy_direction(rng: &mut StdRng, h: &Vector3<f64>, sigma: f64) -> Vector3<f64> {
    (h + gauss3(rng) * sigma).normalize()
}

pub fn simulate(sc: &Scenario) -> Data {
    let mut rng = StdRng::seed_from_u64(sc.seed);
    let dt = 1.0 / sc.imu_hz;
    let n = (sc.duration * sc.imu_hz).round() as usize;
    let every = (sc.imu_hz / sc.aid_hz).round().max(1.0) as usize;
    let mut att = So3::from_euler(0.1, -0.05, 0.7);
    let mut bias = gauss3(&mut rng) * sc.bias_sigma;
    // the filter starts off by one draw of its own P0
    let x0 = (att * So3::exp(&(gauss3(&mut rng) * sc.att_sigma)), Vector3::zeros());
    let mut p0 = SMatrix::<f64, 6, 6>::zeros();
    for i in 0..3 {
        p0[(i, i)] = sc.att_sigma.powi(2);
        p0[(i + 3, i + 3)] = sc.bias_sigma.powi(2);
    }
    let epochs = n / every;
    let outlier_epochs: Vec<usize> =
        (0..sc.outliers).map(|_| rng.random_range(0..epochs)).collect();
    let (g, m) = (gravity(), magnetic());
    let (mut gyro, mut truth, mut aid) = (Vec::new(), Vec::new(), Vec::new());
    let phase = Vector3::from_fn(|_, _| rng.random::<f64>() * std::f64::consts::TAU);
    for k in 0..n {
        let t = k as f64 * dt;
        let w = Vector3::new(
            sc.rate * (0.5 * t + phase[0]).sin(),
            0.6 * sc.rate * (0.3 * t + phase[1]).cos(),
            0.2 + 0.4 * sc.rate * (0.2 * t + phase[2]).sin(),
        );
        gyro.push(w + bias + gauss3(&mut rng) * (sc.arw / dt.sqrt()));
        att = att * So3::exp(&(w * dt));
        bias += gauss3(&mut rng) * (sc.bias_walk * dt.sqrt());
        truth.push((att, bias));
        if (k + 1) % every != 0 {
            aid.push(None);
            continue;
        }
        let epoch = (k + 1) / every - 1;
        let t_aid = (k + 1) as f64 * dt;
        let x = (att, bias);
        let mut mag_sigma = sc.sigma_mag * sc.true_sigma_factor;
        if t_aid >= sc.disturbance.0 && t_aid < sc.disturbance.1 {
            mag_sigma = sc.sigma_mag * sc.disturbance_factor;
        }
        let acc = noisy_direction(&mut rng, &g.predict(&x), sc.sigma_acc * sc.true_sigma_factor);
        let mut mag_true = m.predict(&x);
        if outlier_epochs.contains(&epoch) {
            // the field turned by 60° about an axis across it
            let axis = Unit::new_normalize(mag_true.cross(&gauss3(&mut rng)));
            mag_true =
                nalgebra::Rotation3::from_axis_angle(&axis, sc.outlier_deg.to_radians()) * mag_true;
        }
        let mag = noisy_direction(&mut rng, &mag_true, mag_sigma);
        aid.push(Some(Aid { acc, mag }));
    }
    Data { gyro, truth, aid, x0, p0 }
}

/// What a run gives.
#[derive(Clone, Debug, Default)]
pub struct Outcome {
    /// Attitude RMS after `skip` s, degrees.
    pub rms_deg: f64,
    /// Mean NEES of the 6 states after `skip` s.
    pub nees: f64,
    /// Share of the epochs after `skip` s whose NEES is beyond χ²₆ at 99 % (16.81): 1 %
    /// for a covariance that covers the error.
    pub beyond99: f64,
    /// Steps (predictions and updates) after which P had no Cholesky factor.
    pub not_pd: usize,
    /// Updates that returned an error, and the first error.
    pub errors: usize,
    pub first_error: Option<FilterError>,
    /// Updates whose subspace scaling fell back to scaling all of P⁻.
    pub fallbacks: usize,
    /// Updates reported "not helping" by the strategy.
    pub not_helping: usize,
    /// Largest bias σ (rad/s) seen.
    pub max_bias_sigma: f64,
}

/// Finite, symmetric to rounding, with a Cholesky factor and every eigenvalue above zero
/// (a Cholesky factor alone is found for some matrices with an eigenvalue of −1e-14 at a
/// condition of 1e16).
pub fn is_pd(p: &SMatrix<f64, 6, 6>) -> bool {
    let scale = p.abs().max().max(f64::MIN_POSITIVE);
    p.iter().all(|v| v.is_finite())
        && (p - p.transpose()).abs().max() <= 1e-9 * scale
        && p.cholesky().is_some()
        && p.symmetric_eigenvalues().min() > 0.0
}

/// Runs the filter with `strategy` over `data`; `skip` seconds are left out of the RMS and
/// the NEES. `check` is called with P after every step (property tests assert in it).
pub fn run<A: NoiseStrategy>(
    strategy: A,
    sc: &Scenario,
    data: &Data,
    skip: f64,
    mut check: impl FnMut(&str, usize, &SMatrix<f64, 6, 6>),
) -> Outcome {
    let model = Gyro { arw: sc.arw, bias_walk: sc.bias_walk };
    let (g, m) = (gravity(), magnetic());
    let Ra = Matrix3::identity() * sc.sigma_acc.powi(2);
    let Rm = Matrix3::identity() * sc.sigma_mag.powi(2);
    let dt = 1.0 / sc.imu_hz;
    let mut f = ErrorStateFilter::new(data.x0, data.p0, strategy).unwrap();
    let mut out = Outcome::default();
    let (mut se, mut nees, mut count, mut beyond) = (0.0, 0.0, 0usize, 0usize);
    let note = |out: &mut Outcome, e: FilterError| {
        out.errors += 1;
        out.first_error.get_or_insert(e);
    };
    for (k, w) in data.gyro.iter().enumerate() {
        if let Err(e) = f.predict(&model, w, dt) {
            note(&mut out, e);
        }
        let p = f.covariance();
        check("predict", k, &p);
        if !is_pd(&p) {
            out.not_pd += 1;
        }
        if let Some(aid) = &data.aid[k] {
            for (model, z, R) in [(&g, &aid.acc, &Ra), (&m, &aid.mag, &Rm)] {
                match f.update(model, z, R) {
                    Ok(rep) => {
                        out.fallbacks += rep.prior_scaling_fallback as usize;
                        out.not_helping += rep.not_helping as usize;
                    }
                    Err(e) => note(&mut out, e),
                }
                let p = f.covariance();
                check("update", k, &p);
                if !is_pd(&p) {
                    out.not_pd += 1;
                }
            }
        }
        let p = f.covariance();
        for i in 3..6 {
            out.max_bias_sigma = out.max_bias_sigma.max(p[(i, i)].max(0.0).sqrt());
        }
        if (k + 1) as f64 * dt >= skip {
            // true = estimate ⊕ δ: δ = truth ⊖ estimate, over both blocks
            let de = data.truth[k].ominus(f.state());
            se += de.fixed_rows::<3>(0).norm_squared();
            let e = match p.cholesky() {
                Some(c) => de.dot(&c.solve(&de)),
                None => f64::INFINITY,
            };
            nees += e;
            beyond += usize::from(e > 16.81);
            count += 1;
        }
    }
    out.rms_deg = (se / count.max(1) as f64).sqrt().to_degrees();
    out.nees = nees / count.max(1) as f64;
    out.beyond99 = beyond as f64 / count.max(1) as f64;
    out
}
