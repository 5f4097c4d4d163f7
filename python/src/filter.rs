//! The generic filter for Python: the error-state Kalman filter (on a Euclidean state,
//! exactly the linear Kalman filter) with any adaptive strategy by name, its RTS smoother,
//! and the built-in kinematic models' matrices. Dimensions are compile-time in the
//! library; a call dispatches on its `(n, m)` to one of the instances built here
//! (`n ≤ MAX_N`, `m ≤ MAX_M`).

use adaptive::AnyStrategy;
use estimator_core::linear::{LinearMeasurement, LinearProcess};
use estimator_core::{ErrorStateFilter, ProcessModel, RtsSmoother};
use nalgebra::{SMatrix, SVector};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArrayDyn};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::{fail, matrix};

/// Largest state dimension of the instances built.
pub const MAX_N: usize = 9;
/// Largest measurement dimension of the instances built.
pub const MAX_M: usize = 6;

/// One run's inputs, row-major; `F`, `Q`, `H`, `R` hold one matrix (constant) or one per
/// step.
struct Problem {
    n: usize,
    m: usize,
    steps: usize,
    x0: Vec<f64>,
    P0: Vec<f64>,
    F: Vec<f64>,
    Q: Vec<f64>,
    H: Vec<f64>,
    R: Vec<f64>,
    /// `steps × m`; a row with a NaN is a step without a measurement.
    z: Vec<f64>,
    strategy: AnyStrategy,
    smooth: bool,
}

/// One run's outputs, row-major.
#[derive(Default)]
struct Output {
    x: Vec<f64>,
    P: Vec<f64>,
    x_prior: Vec<f64>,
    P_prior: Vec<f64>,
    nis: Vec<f64>,
    log_likelihood: Vec<f64>,
    verdict: Vec<&'static str>,
    xs: Vec<f64>,
    Ps: Vec<f64>,
}

impl Problem {
    /// Matrix `k` of a constant (one matrix) or per-step sequence.
    fn at<const R: usize, const C: usize>(seq: &[f64], k: usize) -> SMatrix<f64, R, C> {
        let size = R * C;
        let k = if seq.len() == size { 0 } else { k };
        SMatrix::from_row_slice(&seq[k * size..(k + 1) * size])
    }
}

fn push<const R: usize, const C: usize>(out: &mut Vec<f64>, m: &SMatrix<f64, R, C>) {
    // row-major, as numpy
    out.extend(m.transpose().iter());
}

/// Predict then update at every step (FilterPy's `batch_filter` order), recording for the
/// smoother.
fn run<const N: usize, const M: usize>(p: &Problem) -> Result<Output, String> {
    let x0 = SVector::<f64, N>::from_row_slice(&p.x0);
    let P0 = SMatrix::<f64, N, N>::from_row_slice(&p.P0);
    let mut f = ErrorStateFilter::new(x0, P0, p.strategy.clone()).map_err(|e| e.to_string())?;
    let mut rts = RtsSmoother::new();
    let mut out = Output::default();
    let ln2pi = (2.0 * std::f64::consts::PI).ln();
    for k in 0..p.steps {
        let process = LinearProcess::<N> { F: Problem::at(&p.F, k), Q: Problem::at(&p.Q, k) };
        let step = if p.smooth {
            rts.predict(&mut f, &process, &(), 1.0)
        } else {
            f.predict(&process, &(), 1.0)
        };
        step.map_err(|e| format!("step {k}: prediction: {e}"))?;
        push(&mut out.x_prior, f.state());
        push(&mut out.P_prior, &f.covariance());
        let z = &p.z[k * M..(k + 1) * M];
        if z.iter().all(|v| v.is_finite()) {
            let sensor = LinearMeasurement::<M, N>::new(Problem::at(&p.H, k));
            let R = Problem::at::<M, M>(&p.R, k);
            let report = f
                .update(&sensor, &SVector::<f64, M>::from_row_slice(z), &R)
                .map_err(|e| format!("step {k}: update: {e}"))?;
            // ln det S from its Cholesky factor (S was checked positive definite)
            let ln_det = nalgebra::linalg::Cholesky::new(report.S)
                .map_or(f64::NAN, |c| 2.0 * c.l_dirty().diagonal().map(f64::ln).sum());
            out.nis.push(report.nis);
            out.log_likelihood.push(-0.5 * (M as f64 * ln2pi + ln_det + report.nis));
            out.verdict.push(report.verdict.as_str());
        } else {
            out.nis.push(f64::NAN);
            out.log_likelihood.push(f64::NAN);
            out.verdict.push("none");
        }
        push(&mut out.x, f.state());
        push(&mut out.P, &f.covariance());
    }
    if p.smooth {
        // the smoothed estimates after every step (the first is at the start: dropped)
        for s in rts.smooth(&f).map_err(|e| format!("smoother: {e}"))?.iter().skip(1) {
            push(&mut out.xs, &s.x);
            push(&mut out.Ps, &s.p);
        }
    }
    Ok(out)
}

macro_rules! for_m {
    ($p:expr, $n:literal, [$($m:literal),*]) => {
        match $p.m {
            $($m => run::<$n, $m>($p),)*
            m => Err(format!("measurement dimension {m}: 1 to {MAX_M}")),
        }
    };
}

/// [`run`] at the problem's dimensions.
fn dispatch(p: &Problem) -> Result<Output, String> {
    match p.n {
        1 => for_m!(p, 1, [1, 2, 3, 4, 5, 6]),
        2 => for_m!(p, 2, [1, 2, 3, 4, 5, 6]),
        3 => for_m!(p, 3, [1, 2, 3, 4, 5, 6]),
        4 => for_m!(p, 4, [1, 2, 3, 4, 5, 6]),
        5 => for_m!(p, 5, [1, 2, 3, 4, 5, 6]),
        6 => for_m!(p, 6, [1, 2, 3, 4, 5, 6]),
        7 => for_m!(p, 7, [1, 2, 3, 4, 5, 6]),
        8 => for_m!(p, 8, [1, 2, 3, 4, 5, 6]),
        9 => for_m!(p, 9, [1, 2, 3, 4, 5, 6]),
        n => Err(format!("state dimension {n}: 1 to {MAX_N}")),
    }
}

/// A constant matrix (`rows × cols`) or one per step (`steps × rows × cols`), row-major.
fn sequence(
    name: &str,
    a: &PyReadonlyArrayDyn<'_, f64>,
    rows: usize,
    cols: usize,
    steps: usize,
) -> PyResult<Vec<f64>> {
    let a = a.as_array();
    let shape = a.shape();
    let ok = shape == [rows, cols] || shape == [steps, rows, cols];
    if !ok {
        return Err(PyValueError::new_err(format!(
            "{name} has shape {shape:?}: ({rows}, {cols}) or ({steps}, {rows}, {cols}) expected"
        )));
    }
    Ok(a.iter().copied().collect())
}

/// Run the Kalman filter (and the RTS smoother) over `z` (`steps × m`, a row with a NaN
/// is a step without a measurement): at each step predict with `F`, `Q`, then update with
/// `H`, `R`. Returns a dict of arrays: `x`, `P` (posteriors), `x_prior`, `P_prior`,
/// `nis`, `log_likelihood`, `verdict`, and with `smooth` `xs`, `Ps`.
#[pyfunction]
#[pyo3(signature = (x0, P0, F, Q, H, R, z, strategy="fixed", smooth=false))]
#[allow(clippy::too_many_arguments)]
fn kalman<'py>(
    py: Python<'py>,
    x0: PyReadonlyArrayDyn<'py, f64>,
    P0: PyReadonlyArrayDyn<'py, f64>,
    F: PyReadonlyArrayDyn<'py, f64>,
    Q: PyReadonlyArrayDyn<'py, f64>,
    H: PyReadonlyArrayDyn<'py, f64>,
    R: PyReadonlyArrayDyn<'py, f64>,
    z: PyReadonlyArrayDyn<'py, f64>,
    strategy: &str,
    smooth: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let n = x0.as_array().len();
    let za = z.as_array();
    let (steps, m) = match za.shape() {
        [s, m] => (*s, *m),
        other => return Err(PyValueError::new_err(format!("z has shape {other:?}: (steps, m)"))),
    };
    let p = Problem {
        n,
        m,
        steps,
        x0: x0.as_array().iter().copied().collect(),
        P0: sequence("P0", &P0, n, n, 0)?,
        F: sequence("F", &F, n, n, steps)?,
        Q: sequence("Q", &Q, n, n, steps)?,
        H: sequence("H", &H, m, n, steps)?,
        R: sequence("R", &R, m, m, steps)?,
        z: za.iter().copied().collect(),
        strategy: strategy.parse().map_err(fail)?,
        smooth,
    };
    let out = py.allow_threads(|| dispatch(&p)).map_err(fail)?;
    let d = PyDict::new(py);
    let cube = |py, v: Vec<f64>| -> PyResult<Bound<'py, PyAny>> {
        let k = v.len() / (n * n).max(1);
        Ok(PyArray1::from_vec(py, v).reshape([k, n, n])?.into_any())
    };
    d.set_item("x", matrix(py, out.x, n)?)?;
    d.set_item("P", cube(py, out.P)?)?;
    d.set_item("x_prior", matrix(py, out.x_prior, n)?)?;
    d.set_item("P_prior", cube(py, out.P_prior)?)?;
    d.set_item("nis", PyArray1::from_vec(py, out.nis))?;
    d.set_item("log_likelihood", PyArray1::from_vec(py, out.log_likelihood))?;
    d.set_item("verdict", out.verdict)?;
    if smooth {
        d.set_item("xs", matrix(py, out.xs, n)?)?;
        d.set_item("Ps", cube(py, out.Ps)?)?;
    }
    Ok(d)
}

/// `(F, Q)` of a built-in kinematic model over one step `dt` on `axes` axes (1 to 3):
/// `cv` (white acceleration, `q` m²/s³ per axis), `ca` (white jerk, `q` m²/s⁵) or `singer`
/// (Markov acceleration of frequency `alpha` 1/s and variance `q` (m/s²)²). The state is
/// the positions of every axis, then the velocities (then the accelerations).
#[pyfunction]
#[pyo3(signature = (name, dt, q, axes=1, alpha=None))]
fn kinematic<'py>(
    py: Python<'py>,
    name: &str,
    dt: f64,
    q: f64,
    axes: usize,
    alpha: Option<f64>,
) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
    use models::kinematic::{ConstantAcceleration, ConstantVelocity, Singer};
    if !(dt.is_finite() && dt > 0.0) {
        return Err(PyValueError::new_err(format!("dt = {dt} s: finite and positive")));
    }
    if !(q.is_finite() && q >= 0.0) {
        return Err(PyValueError::new_err(format!("q = {q}: finite and not negative")));
    }
    if let Some(a) = alpha.filter(|a| !(a.is_finite() && *a > 0.0)) {
        return Err(PyValueError::new_err(format!("alpha = {a} 1/s: finite and positive")));
    }

    fn pair<PM: ProcessModel<Input = ()>>(pm: &PM, x: &PM::State, dt: f64) -> (Vec<f64>, usize)
    where
        nalgebra::DefaultAllocator: estimator_core::DimAlloc<estimator_core::StateDim<PM::State>>,
    {
        let j = pm.jacobians(x, &(), dt);
        let n = j.Phi.nrows();
        let mut v: Vec<f64> = j.Phi.transpose().iter().copied().collect();
        v.extend(j.Q.transpose().iter());
        (v, n)
    }
    macro_rules! axes {
        ($($d:literal),*) => {
            match (name.to_ascii_lowercase().as_str(), axes) {
                $(
                    ("cv", $d) => Ok(pair(
                        &ConstantVelocity::<$d> { q: SVector::repeat(q) },
                        &Default::default(),
                        dt,
                    )),
                    ("ca", $d) => Ok(pair(
                        &ConstantAcceleration::<$d> { q: SVector::repeat(q) },
                        &Default::default(),
                        dt,
                    )),
                    ("singer", $d) => match alpha {
                        Some(alpha) => Ok(pair(
                            &Singer::<$d> { alpha, sigma2: SVector::repeat(q) },
                            &Default::default(),
                            dt,
                        )),
                        None => Err("singer needs alpha (1/s)".to_string()),
                    },
                )*
                (other, d) => Err(format!("model `{other}` on {d} axes: cv, ca or singer on 1 to 3")),
            }
        };
    }
    let (v, n) = axes!(1, 2, 3).map_err(PyValueError::new_err)?;
    let (f, q) = v.split_at(n * n);
    Ok((matrix(py, f.to_vec(), n)?, matrix(py, q.to_vec(), n)?))
}

/// Add the functions of this module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(kalman, m)?)?;
    m.add_function(wrap_pyfunction!(kinematic, m)?)?;
    m.add("MAX_N", MAX_N)?;
    m.add("MAX_M", MAX_M)?;
    Ok(())
}
