//! The generic filter for Python: the error-state Kalman filter (on a Euclidean state,
//! exactly the linear Kalman filter) with any adaptive strategy by name, its RTS smoother,
//! and the built-in kinematic models' matrices. Dimensions are compile-time in the
//! library; a call runs on the callables' cores (`callables.rs`): a compiled instance for
//! `n ≤ MAX_N`, `m ≤ MAX_M`, the dynamic heap core beyond (fixed noise or the χ² gate).

use adaptive::AnyStrategy;
use estimator_core::ProcessModel;
use nalgebra::SVector;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArrayDyn};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::{fail, matrix};

/// Largest state dimension of the compiled instances.
pub const MAX_N: usize = crate::cores::MAX_N;
/// Largest measurement dimension of the compiled instances.
pub const MAX_M: usize = crate::cores::MAX_M;

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
    strategy: String,
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
    /// Matrix `k` (`size` entries) of a constant (one matrix) or per-step sequence.
    fn at(seq: &[f64], size: usize, k: usize) -> &[f64] {
        let k = if seq.len() == size { 0 } else { k };
        &seq[k * size..(k + 1) * size]
    }
}

/// `A v` for a row-major `rows × v.len()` matrix.
fn times(a: &[f64], v: &[f64]) -> Vec<f64> {
    a.chunks(v.len()).map(|row| row.iter().zip(v).map(|(a, b)| a * b).sum()).collect()
}

/// Predict then update at every step (FilterPy's `batch_filter` order), recording for the
/// smoother. The same cores as the callables' (`callables.rs`): one of the compiled
/// instances for states of 1 to 9 and measurements of 1 to 8 rows, the heap core beyond.
fn run(p: &Problem) -> Result<Output, String> {
    let (n, m) = (p.n, p.m);
    let dynamic = n > crate::cores::MAX_N || m > crate::cores::MAX_M;
    let mut core = crate::callables::make_core(n, &p.strategy, p.smooth, None, dynamic)?;
    core.set(&p.x0, &p.P0).map_err(|e| format!("the start: {e}"))?;
    let mut x = p.x0.clone();
    let mut out = Output::default();
    for k in 0..p.steps {
        let F = Problem::at(&p.F, n * n, k);
        x = times(F, &x);
        let P = core
            .predict(&x, F, Problem::at(&p.Q, n * n, k), 1.0)
            .map_err(|e| format!("step {k}: prediction: {e}"))?;
        out.x_prior.extend(&x);
        out.P_prior.extend(&P);
        let z = &p.z[k * m..(k + 1) * m];
        let mut P_post = P;
        if z.iter().all(|v| v.is_finite()) {
            let H = Problem::at(&p.H, m * n, k);
            let y: Vec<f64> = z.iter().zip(times(H, &x)).map(|(z, h)| z - h).collect();
            let u = core
                .update(&y, H, Problem::at(&p.R, m * m, k), None)
                .map_err(|e| format!("step {k}: update: {e}"))?;
            out.nis.push(u.nis);
            out.log_likelihood.push(u.log_likelihood);
            out.verdict.push(u.verdict);
            x = u.x;
            P_post = u.P;
        } else {
            out.nis.push(f64::NAN);
            out.log_likelihood.push(f64::NAN);
            out.verdict.push("none");
        }
        out.x.extend(&x);
        out.P.extend(&P_post);
    }
    if p.smooth {
        // the smoothed estimates after every step (the first is at the start: dropped)
        let (xs, ps) = core.smooth().map_err(|e| format!("smoother: {e}"))?;
        out.xs = xs[n..].to_vec();
        out.Ps = ps[n * n..].to_vec();
    }
    Ok(out)
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
        strategy: {
            strategy.parse::<AnyStrategy>().map_err(fail)?;
            strategy.to_owned()
        },
        smooth,
    };
    let out = py.allow_threads(|| run(&p)).map_err(fail)?;
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
