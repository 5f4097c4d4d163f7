//! The filter core behind the Python models given as callables (FilterPy's shape, in
//! `estimator/filterpy.py`): Python evaluates the user's `fx`, `hx`, Jacobians, mean and
//! residual functions; this core takes what they give — the predicted state with `F` and
//! `Q`, the innovation with `H` (extended filter) or the sigma points' statistics
//! (unscented filter) — and runs the library's prediction and update on it, so every
//! noise strategy, the gate, the verdict, the report and the RTS smoother apply. The
//! state is Euclidean (`R^n`); the dimensions are compile-time in the library, and a core
//! is built for `n ≤ MAX_N` with updates of `m ≤ MAX_M` (dispatched at run time).

use adaptive::AnyStrategy;
use estimator_core::{
    ErrorStateFilter, FixedLagSmoother, Lag, MeasurementJacobians, MeasurementModel,
    ProcessJacobians, ProcessModel, ReplaySmoother, RtsSmoother,
};
use nalgebra::{Const, SMatrix, SVector};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArrayDyn};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

use crate::cores::{from_bytes, to_bytes, Core, Updated, MAX_M, MAX_N};
use crate::fail;

/// A prediction computed by the caller: the predicted state, the transition `F` (the
/// Jacobian, or the sigma points' statistical one) and the process noise `Q`, so that
/// `P⁻ = F P Fᵀ + Q`.
struct GivenStep<const N: usize> {
    x: SVector<f64, N>,
    F: SMatrix<f64, N, N>,
    Q: SMatrix<f64, N, N>,
}

impl<const N: usize> ProcessModel for GivenStep<N> {
    type State = SVector<f64, N>;
    type Input = ();

    fn propagate(&self, _x: &SVector<f64, N>, _u: &(), _dt: f64) -> SVector<f64, N> {
        self.x
    }

    fn jacobians(&self, _x: &SVector<f64, N>, _u: &(), _dt: f64) -> ProcessJacobians<Const<N>> {
        ProcessJacobians { Phi: self.F, Q: self.Q }
    }
}

/// A measurement linearised by the caller: the innovation `y = residual(z, h(x))` and
/// `H` (for the unscented filter, the statistical `H̃ = P_xzᵀ P⁻¹`).
struct Given<const M: usize, const N: usize> {
    y: SVector<f64, M>,
    H: SMatrix<f64, M, N>,
}

impl<const M: usize, const N: usize> MeasurementModel for Given<M, N> {
    type State = SVector<f64, N>;
    type Measurement = SVector<f64, M>;

    fn predict(&self, _x: &SVector<f64, N>) -> SVector<f64, M> {
        SVector::zeros()
    }

    fn jacobian(&self, _x: &SVector<f64, N>) -> MeasurementJacobians<Const<M>, Const<N>> {
        MeasurementJacobians { H: self.H }
    }

    fn innovation(
        &self,
        _x: &SVector<f64, N>,
        _z: &SVector<f64, M>,
    ) -> (SVector<f64, M>, MeasurementJacobians<Const<M>, Const<N>>) {
        (self.y, MeasurementJacobians { H: self.H })
    }
}

fn rowmajor<const R: usize, const C: usize>(m: &SMatrix<f64, R, C>) -> Vec<f64> {
    m.transpose().iter().copied().collect()
}

#[derive(serde::Serialize, serde::Deserialize)]
struct Filter<const N: usize> {
    f: ErrorStateFilter<SVector<f64, N>, AnyStrategy>,
    /// The smoother that records the predictions, if one was asked for.
    rec: Option<ReplaySmoother<SVector<f64, N>>>,
    /// The fixed-lag smoother's lag (to start it again).
    lag: Option<usize>,
}

fn recorder<const N: usize>(
    smooth: bool,
    lag: Option<usize>,
) -> Option<ReplaySmoother<SVector<f64, N>>> {
    match (smooth, lag) {
        (true, _) => Some(ReplaySmoother::Interval(RtsSmoother::new())),
        (false, Some(k)) => Some(ReplaySmoother::FixedLag(FixedLagSmoother::new(Lag::Steps(k)))),
        (false, None) => None,
    }
}

impl<const N: usize> Filter<N> {
    fn update_m<const M: usize>(
        &mut self,
        y: &[f64],
        H: &[f64],
        R: &[f64],
        Pzz: Option<&[f64]>,
    ) -> Result<Updated, String> {
        let y = SVector::<f64, M>::from_row_slice(y);
        let R = SMatrix::<f64, M, M>::from_row_slice(R);
        let (H, R_used) = match Pzz {
            None => (SMatrix::<f64, M, N>::from_row_slice(H), R),
            Some(pzz) => {
                // statistical linear regression of the points: H̃ = P_xzᵀ P⁻¹ and the noise
                // R + Ω, Ω = P_zz − H̃ P_xz (the points' linearisation error), so that
                // S = H̃ P H̃ᵀ + R + Ω = P_zz + R and K = P H̃ᵀ S⁻¹ = P_xz S⁻¹
                let pxz = SMatrix::<f64, N, M>::from_row_slice(H);
                let pzz = SMatrix::<f64, M, M>::from_row_slice(pzz);
                let chol = self
                    .f
                    .covariance()
                    .into_owned()
                    .cholesky()
                    .ok_or("the covariance P is not positive definite")?;
                let h = chol.solve(&pxz).transpose();
                let mut total = pzz - h * pxz + R;
                total = (total + total.transpose()) * 0.5;
                (h, total)
            }
        };
        let (report, K) = self
            .f
            .update_with_gain(
                &Given { y, H },
                &SVector::zeros(),
                &R_used,
                &mut estimator_core::NoObserver,
            )
            .map_err(|e| e.to_string())?;
        Ok(Updated {
            x: self.f.state().iter().copied().collect(),
            P: rowmajor(&self.f.covariance()),
            K: K.map_or_else(|| vec![0.0; N * M], |k| rowmajor(&k)),
            S: rowmajor(&report.S),
            nis: report.nis,
            nis_adapted: report.nis_adapted,
            log_likelihood: report.log_likelihood,
            verdict: report.verdict.as_str(),
        })
    }
}

macro_rules! update_dispatch {
    ($self:ident, $m:expr, $y:ident, $H:ident, $R:ident, $Pzz:ident, [$($mm:literal),*]) => {
        match $m {
            $($mm => $self.update_m::<$mm>($y, $H, $R, $Pzz),)*
            m => Err(format!(
                "a measurement of {m} rows on a filter made for at most {MAX_M}: make it with \
                 dim_z = {m} (larger measurements run on the dynamic core)"
            )),
        }
    };
}

impl<const N: usize> Core for Filter<N> {
    fn set(&mut self, x: &[f64], P: &[f64]) -> Result<(), String> {
        self.f.set_state(SVector::from_row_slice(x)).map_err(|e| format!("x: {e}"))?;
        self.f.set_covariance(SMatrix::from_row_slice(P)).map_err(|e| format!("P: {e}"))
    }

    fn predict(&mut self, x: &[f64], F: &[f64], Q: &[f64], dt: f64) -> Result<Vec<f64>, String> {
        let step = GivenStep {
            x: SVector::from_row_slice(x),
            F: SMatrix::from_row_slice(F),
            Q: SMatrix::from_row_slice(Q),
        };
        match &mut self.rec {
            Some(rec) => rec.predict(&mut self.f, &step, &(), dt),
            None => self.f.predict(&step, &(), dt),
        }
        .map_err(|e| e.to_string())?;
        Ok(rowmajor(&self.f.covariance()))
    }

    fn update(
        &mut self,
        y: &[f64],
        H: &[f64],
        R: &[f64],
        Pzz: Option<&[f64]>,
    ) -> Result<Updated, String> {
        update_dispatch!(self, y.len(), y, H, R, Pzz, [1, 2, 3, 4, 5, 6, 7, 8])
    }

    fn smooth(&self) -> Result<(Vec<f64>, Vec<f64>), String> {
        let s = match &self.rec {
            Some(rec) => rec.smooth(&self.f),
            None => return Err("the filter was made without smooth or lag".into()),
        }
        .map_err(|e| e.to_string())?;
        let xs = s.iter().flat_map(|e| e.x.iter().copied()).collect();
        let ps = s.iter().flat_map(|e| rowmajor(&e.p)).collect();
        Ok((xs, ps))
    }

    fn strategy(&self) -> &'static str {
        estimator_core::NoiseStrategy::name(self.f.strategy())
    }

    fn save(&self) -> Result<Vec<u8>, String> {
        to_bytes(self)
    }

    fn restore(&mut self, state: &[u8]) -> Result<(), String> {
        *self = from_bytes(state)?;
        Ok(())
    }

    fn reset_history(&mut self) {
        if self.rec.is_some() {
            self.rec = recorder(self.lag.is_none(), self.lag);
        }
    }
}

fn build<const N: usize>(
    strategy: AnyStrategy,
    smooth: bool,
    lag: Option<usize>,
) -> Result<Box<dyn Core>, String> {
    let f = ErrorStateFilter::new(SVector::<f64, N>::zeros(), SMatrix::identity(), strategy)
        .map_err(|e| e.to_string())?;
    if smooth && lag.is_some() {
        return Err("smooth and lag: one smoother or the other".into());
    }
    Ok(Box::new(Filter { f, rec: recorder(smooth, lag), lag }))
}

/// A core of `n` states: one of the compiled instances, or with `dynamic` the heap core.
pub(crate) fn make_core(
    n: usize,
    strategy: &str,
    smooth: bool,
    lag: Option<usize>,
    dynamic: bool,
) -> Result<Box<dyn Core>, String> {
    let s: AnyStrategy = strategy.parse().map_err(|e| format!("{e}"))?;
    if dynamic {
        return crate::dynamic::DynFilter::new(n, strategy, smooth, lag)
            .map(|f| Box::new(f) as Box<dyn Core>);
    }
    match n {
        1 => build::<1>(s, smooth, lag),
        2 => build::<2>(s, smooth, lag),
        3 => build::<3>(s, smooth, lag),
        4 => build::<4>(s, smooth, lag),
        5 => build::<5>(s, smooth, lag),
        6 => build::<6>(s, smooth, lag),
        7 => build::<7>(s, smooth, lag),
        8 => build::<8>(s, smooth, lag),
        9 => build::<9>(s, smooth, lag),
        n => Err(format!("state dimension {n}: 1 to {MAX_N} compiled")),
    }
}

/// The filter core of the Python callables: created for a state dimension, a strategy by
/// name, and which smoother records (`smooth`: the RTS smoother over the whole run; `lag`:
/// the fixed-lag smoother over the last `lag` predictions). `m`: the largest measurement
/// it will take. States of 1 to `MAX_N` with measurements of 1 to `MAX_M` rows run on the
/// library's compiled instances; larger ones (or `dynamic=True`) on the heap core of
/// `dynamic.rs`.
#[pyclass(module = "estimator._native")]
pub struct CallableCore {
    core: Box<dyn Core>,
    n: usize,
    /// What it was made with (for pickling): strategy, smooth, lag, m, dynamic.
    made: (String, bool, Option<usize>, usize, bool),
}

fn flat(name: &str, a: &PyReadonlyArrayDyn<'_, f64>, len: usize) -> PyResult<Vec<f64>> {
    let v: Vec<f64> = a.as_array().iter().copied().collect();
    if v.len() != len {
        return Err(PyValueError::new_err(format!(
            "{name} has {} entries, {len} expected (shape {:?})",
            v.len(),
            a.as_array().shape()
        )));
    }
    Ok(v)
}

impl CallableCore {
    /// The state and covariance into the filter, their sizes checked.
    fn load(
        &mut self,
        x: &PyReadonlyArrayDyn<'_, f64>,
        P: &PyReadonlyArrayDyn<'_, f64>,
    ) -> PyResult<()> {
        let n = self.n;
        self.core.set(&flat("x", x, n)?, &flat("P", P, n * n)?).map_err(fail)
    }
}

#[pymethods]
impl CallableCore {
    #[new]
    #[pyo3(signature = (n, strategy="fixed", smooth=false, lag=None, m=1, dynamic=false))]
    fn new(
        n: usize,
        strategy: &str,
        smooth: bool,
        lag: Option<usize>,
        m: usize,
        dynamic: bool,
    ) -> PyResult<Self> {
        if n == 0 {
            return Err(PyValueError::new_err("dim_x must be at least 1"));
        }
        let dynamic = dynamic || n > MAX_N || m > MAX_M;
        let core = make_core(n, strategy, smooth, lag, dynamic).map_err(fail)?;
        Ok(Self { core, n, made: (strategy.to_owned(), smooth, lag, m, dynamic) })
    }

    /// True when this core runs on the heap (dynamic dimensions).
    #[getter]
    fn dynamic(&self) -> bool {
        self.made.4
    }

    /// The arguments it was made with, for pickle.
    fn __getnewargs__(&self) -> (usize, String, bool, Option<usize>, usize, bool) {
        let (s, smooth, lag, m, dynamic) = self.made.clone();
        (self.n, s, smooth, lag, m, dynamic)
    }

    /// State, covariance, the strategy's state and the smoothing history, as bytes
    /// (every float bit for bit).
    fn __getstate__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        Ok(PyBytes::new(py, &self.core.save().map_err(fail)?))
    }

    fn __setstate__(&mut self, state: &[u8]) -> PyResult<()> {
        self.core.restore(state).map_err(fail)
    }

    /// Forget the recorded predictions: the next prediction starts a new smoothing
    /// history (a new run on the same filter).
    fn reset_history(&mut self) {
        self.core.reset_history();
    }

    /// Set the state and covariance (as the Python object holds them).
    fn set(
        &mut self,
        x: PyReadonlyArrayDyn<'_, f64>,
        P: PyReadonlyArrayDyn<'_, f64>,
    ) -> PyResult<()> {
        let n = self.n;
        self.core.set(&flat("x", &x, n)?, &flat("P", &P, n * n)?).map_err(fail)
    }

    /// From the posterior `x0`, `P0`: predict to the state `x` with transition `F` and
    /// noise `Q` (`P⁻ = λ F P Fᵀ + Q`, with the strategy's fading `λ` and process-noise
    /// adjustment); returns `P⁻`.
    #[allow(clippy::too_many_arguments)]
    fn predict<'py>(
        &mut self,
        py: Python<'py>,
        x0: PyReadonlyArrayDyn<'py, f64>,
        P0: PyReadonlyArrayDyn<'py, f64>,
        x: PyReadonlyArrayDyn<'py, f64>,
        F: PyReadonlyArrayDyn<'py, f64>,
        Q: PyReadonlyArrayDyn<'py, f64>,
        dt: f64,
    ) -> PyResult<Bound<'py, PyAny>> {
        let n = self.n;
        self.load(&x0, &P0)?;
        let (x, F, Q) = (flat("x", &x, n)?, flat("F", &F, n * n)?, flat("Q", &Q, n * n)?);
        let p = self.core.predict(&x, &F, &Q, dt).map_err(fail)?;
        Ok(PyArray1::from_vec(py, p).reshape([n, n])?.into_any())
    }

    /// At the prior `x0`, `P0`: update with innovation `y` and Jacobian `H` (`m × n`),
    /// noise `R`; with `Pzz`, `H` is the points' cross-covariance `P_xz` (`n × m`) and
    /// `Pzz` their spread of `h` (without `R`). Returns a dict: `x`, `P`, `K`, `S`, `nis`,
    /// `nis_adapted`, `log_likelihood`, `verdict`.
    #[pyo3(signature = (x0, P0, y, H, R, Pzz=None))]
    #[allow(clippy::too_many_arguments)]
    fn update<'py>(
        &mut self,
        py: Python<'py>,
        x0: PyReadonlyArrayDyn<'py, f64>,
        P0: PyReadonlyArrayDyn<'py, f64>,
        y: PyReadonlyArrayDyn<'py, f64>,
        H: PyReadonlyArrayDyn<'py, f64>,
        R: PyReadonlyArrayDyn<'py, f64>,
        Pzz: Option<PyReadonlyArrayDyn<'py, f64>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let n = self.n;
        self.load(&x0, &P0)?;
        let y: Vec<f64> = y.as_array().iter().copied().collect();
        let m = y.len();
        let H = flat(if Pzz.is_some() { "Pxz" } else { "H" }, &H, m * n)?;
        let R = flat("R", &R, m * m)?;
        let pzz = match &Pzz {
            Some(p) => Some(flat("Pzz", p, m * m)?),
            None => None,
        };
        let u = self.core.update(&y, &H, &R, pzz.as_deref()).map_err(fail)?;
        let d = PyDict::new(py);
        d.set_item("x", PyArray1::from_vec(py, u.x))?;
        d.set_item("P", PyArray1::from_vec(py, u.P).reshape([n, n])?)?;
        d.set_item("K", PyArray1::from_vec(py, u.K).reshape([n, m])?)?;
        d.set_item("S", PyArray1::from_vec(py, u.S).reshape([m, m])?)?;
        d.set_item("nis", u.nis)?;
        d.set_item("nis_adapted", u.nis_adapted)?;
        d.set_item("log_likelihood", u.log_likelihood)?;
        d.set_item("verdict", u.verdict)?;
        Ok(d)
    }

    /// The smoother over the recorded predictions: `(xs, Ps)`, the smoothed states at the
    /// start and after every prediction (RTS), or over the last `lag` predictions
    /// (fixed lag: the oldest is `x(t − lag | t)`).
    fn smooth<'py>(&self, py: Python<'py>) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyAny>)> {
        let n = self.n;
        let (xs, ps) = self.core.smooth().map_err(fail)?;
        let k = xs.len() / n;
        Ok((
            PyArray1::from_vec(py, xs).reshape([k, n])?.into_any(),
            PyArray1::from_vec(py, ps).reshape([k, n, n])?.into_any(),
        ))
    }

    /// The strategy's name.
    #[getter]
    fn strategy(&self) -> &'static str {
        self.core.strategy()
    }
}

/// Add the class of this module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<CallableCore>()?;
    m.add("CALLABLE_MAX_N", MAX_N)?;
    m.add("CALLABLE_MAX_M", MAX_M)?;
    Ok(())
}
