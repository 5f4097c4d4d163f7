//! Python bindings, the extension module `estimator._native`. The package `estimator`
//! (`python/estimator/__init__.py`) wraps it: DataFrames in and out, column names, units.
//!
//! - `navigate`: the INS/GNSS navigator and its smoother, the same run as
//!   `ins-gnss run` (its options, start, checks, verdicts and numbers), on the files of a
//!   configuration or on arrays, its results in memory; no file is written.
//! - `evaluate`: a navigation result against a truth file, as `ins-gnss eval`.
//! - `filter`: the generic error-state Kalman filter and RTS smoother on Euclidean
//!   states, with every adaptive strategy by name, and the kinematic models' matrices.
//! - `rtk`: a rover's RTK positions against a base station, as `ins-gnss rtk`, with the
//!   fix's metrics (fix rate, time to first fix and to fix again, ratio statistics) and
//!   the wrong fixes against another solution.
//! - `ahrs`: the AHRS of the third paper (conventional, modified, CS-MAEKF) on sensor
//!   arrays, and its simulated flight.
//!
//! The runs release the GIL. Every failure is an `EstimatorError` carrying the program's
//! message, file (or array) and line (or row).
#![allow(non_snake_case)]

mod ahrs;
mod callables;
mod cores;
mod dynamic;
mod filter;
mod rtk;

use std::path::Path;
use std::sync::Arc;

use numpy::ndarray::ArrayView2;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use ins_gnss::config::Overrides;
use ins_gnss::config::{Config, ConfigKind};
use ins_gnss::run::{run_in_memory, Inputs, RunSummary, GNSS_ARRAY, IMU_ARRAY};

pyo3::create_exception!(
    _native,
    EstimatorError,
    PyValueError,
    "A run, a configuration or an input refused, with the program's message (file or array, line or row)."
);

/// An error of the library as an `EstimatorError`.
fn fail(e: impl std::fmt::Display) -> PyErr {
    EstimatorError::new_err(e.to_string())
}

/// The rows of a 2-D array, row-major, whatever its memory layout.
fn rows(a: &ArrayView2<'_, f64>) -> Arc<[f64]> {
    a.iter().copied().collect()
}

/// A row-major vector as a `rows × width` numpy array (no copy).
fn matrix<'py>(py: Python<'py>, data: Vec<f64>, width: usize) -> PyResult<Bound<'py, PyAny>> {
    let n = data.len().checked_div(width).unwrap_or(0);
    Ok(PyArray1::from_vec(py, data).reshape([n, width.max(1)])?.into_any())
}

/// The configuration: a file (`kind = "path"`) or our TOML's tables as JSON
/// (`kind = "json"`, relative paths against `base`). With arrays, `data.imu` and
/// `data.gnss` may be left out (they are files).
fn load_config(text: &str, kind: &str, base: &str, arrays: bool) -> Result<Config, String> {
    match kind {
        "path" => Config::load(Path::new(text)).map_err(|e| e.to_string()),
        "json" => {
            let mut value: serde_json::Value =
                serde_json::from_str(text).map_err(|e| format!("configuration: {e}"))?;
            if arrays && let Some(data) = value.get_mut("data").and_then(|d| d.as_object_mut()) {
                for (key, name) in [("imu", IMU_ARRAY), ("gnss", GNSS_ARRAY)] {
                    data.entry(key).or_insert_with(|| name.into());
                }
            }
            Config::parse(&value.to_string(), ConfigKind::Json, Path::new(base))
                .map_err(|e| format!("configuration: {e}"))
        }
        other => Err(format!("unknown configuration kind `{other}` (path or json)")),
    }
}

/// The summary as a dict.
fn summary_dict<'py>(
    py: Python<'py>,
    s: &RunSummary,
    warning: Option<String>,
) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("strategy", &s.strategy)?;
    d.set_item("imu_epochs", s.imu_epochs)?;
    d.set_item("gnss_epochs", s.gnss_epochs)?;
    d.set_item("accepted", s.accepted)?;
    d.set_item("inflated", s.inflated)?;
    d.set_item("deflated", s.deflated)?;
    d.set_item("rejected", s.rejected)?;
    d.set_item("span", s.span)?;
    d.set_item("gnss_span", s.gnss_span)?;
    d.set_item("wall_time", s.wall_time)?;
    d.set_item("stationary_time", s.stationary_time)?;
    d.set_item("smoothed_rows", s.smoothed.map(|(rows, _)| rows))?;
    d.set_item("backward_time", s.smoothed.map(|(_, secs)| secs))?;
    let c = s.consistency();
    d.set_item("mean_nis", c.as_ref().map(|c| c.mean_nis))?;
    d.set_item("nis_band", c.as_ref().map(|c| c.band))?;
    d.set_item("consistent", c.as_ref().map(|c| c.consistent()))?;
    d.set_item("start", s.start.clone())?;
    // RTK (`gnss.coupling = "rtk"`): the fix metrics, and the fixes the INS prediction
    // contradicted
    let rtk = match &s.rtk {
        Some(r) => {
            let m = rtk::metrics_dict(py, r.metrics.clone())?;
            m.set_item("gated", r.gated)?;
            Some(m)
        }
        None => None,
    };
    d.set_item("rtk", rtk)?;
    d.set_item("lines", s.lines())?;
    d.set_item("warning", warning)?;
    Ok(d)
}

/// Run the navigator: `config` (a path, or JSON text: `kind`), on `imu` and `gnss`
/// arrays (both, or neither: the configuration's files), with the program's options.
/// Returns a dict of arrays (`nav`, `std`, `imu_errors`, `smoothed_nav`,
/// `smoothed_std`), the update columns (`updates`) and the summary (`summary`).
#[pyfunction]
#[pyo3(signature = (
    config, kind="path", base=".", imu=None, gnss=None, imu_format=None, strategy=None,
    bias_model=None, states=None, smooth=false, no_gate=false, declared_noise=false, nhc=false, zupt=false,
    odometer=false, no_vehicle=false, accept_inconsistent=false
))]
#[allow(clippy::too_many_arguments)]
fn navigate<'py>(
    py: Python<'py>,
    config: &str,
    kind: &str,
    base: &str,
    imu: Option<PyReadonlyArray2<'py, f64>>,
    gnss: Option<PyReadonlyArray2<'py, f64>>,
    imu_format: Option<&str>,
    strategy: Option<&str>,
    bias_model: Option<&str>,
    states: Option<u32>,
    smooth: bool,
    no_gate: bool,
    declared_noise: bool,
    nhc: bool,
    zupt: bool,
    odometer: bool,
    no_vehicle: bool,
    accept_inconsistent: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let inputs = match (&imu, &gnss) {
        (Some(imu), Some(gnss)) => {
            let (imu, gnss) = (imu.as_array(), gnss.as_array());
            // (an array without columns would read as one without rows)
            for (name, a, widths) in [("imu", &imu, "7 or 8"), ("gnss", &gnss, "7 or 13")] {
                if a.ncols() == 0 {
                    let message = format!("{name} has no columns ({widths} expected)");
                    return Err(PyValueError::new_err(message));
                }
            }
            Inputs::Arrays {
                imu: rows(&imu),
                imu_width: imu.ncols(),
                gnss: rows(&gnss),
                gnss_width: gnss.ncols(),
            }
        }
        (None, None) => Inputs::Files,
        _ => {
            return Err(PyValueError::new_err("give both the IMU and the GNSS arrays, or neither"));
        }
    };
    if let Some(n) = states.filter(|n| ![15, 21].contains(n)) {
        return Err(PyValueError::new_err(format!("states = {n}: 15 or 21")));
    }
    let arrays = !matches!(inputs, Inputs::Files);
    let mut cfg = load_config(config, kind, base, arrays).map_err(fail)?;
    if let Some(f) = imu_format {
        cfg.data.imu_format = serde_json::from_value(f.into())
            .map_err(|_| PyValueError::new_err(format!("imu_format `{f}`: increments or rates")))?;
    }
    let options = Overrides {
        strategy,
        bias_model,
        states,
        smooth,
        no_gate,
        declared_noise,
        nhc,
        zupt,
        odometer,
        no_vehicle,
        ..Default::default()
    };
    let (cfg, chosen) = cfg.with_options(&options).map_err(fail)?;
    let (summary, results) =
        py.allow_threads(|| run_in_memory(&cfg, chosen, &inputs)).map_err(fail)?;
    // as the program: a run judged quietly wrong is an error unless accepted
    let warning = match ins_gnss::health::assess(&summary, &cfg) {
        Ok(()) => None,
        Err(u) if accept_inconsistent => Some(u.to_string()),
        Err(u) => {
            return Err(fail(format!(
                "{u}(pass accept_inconsistent=True to keep the result, as the program's \
                 --accept-inconsistent)"
            )));
        }
    };
    let out = PyDict::new(py);
    let flat = |v: Vec<[f64; 10]>| v.into_iter().flatten().collect::<Vec<f64>>();
    let smoothed = summary.smoothed.is_some();
    out.set_item("nav", matrix(py, flat(results.nav), 10)?)?;
    out.set_item("std", matrix(py, results.std, results.std_width)?)?;
    out.set_item("imu_errors", matrix(py, results.imu_errors, results.imu_errors_width)?)?;
    if smoothed {
        out.set_item("smoothed_nav", matrix(py, flat(results.smoothed_nav), 10)?)?;
        out.set_item("smoothed_std", matrix(py, results.smoothed_std, results.std_width)?)?;
    }
    let u = PyDict::new(py);
    let col = |f: &dyn Fn(&estimator_core::UpdateSummary) -> f64| -> Vec<f64> {
        results.updates.iter().map(f).collect()
    };
    u.set_item("time", PyArray1::from_vec(py, col(&|u| u.time)))?;
    let names: Vec<&str> = results.updates.iter().map(|u| u.stream.name()).collect();
    u.set_item("stream", names)?;
    u.set_item("dim", results.updates.iter().map(|u| u.dim).collect::<Vec<_>>())?;
    u.set_item("nis", PyArray1::from_vec(py, col(&|u| u.nis)))?;
    u.set_item("nis_adapted", PyArray1::from_vec(py, col(&|u| u.nis_adapted)))?;
    let verdicts: Vec<&str> = results.updates.iter().map(|u| u.verdict.as_str()).collect();
    u.set_item("decision", verdicts)?;
    u.set_item("reason", results.updates.iter().map(|u| u.reason).collect::<Vec<_>>())?;
    u.set_item("dom", PyArray1::from_vec(py, col(&|u| u.factors.dom)))?;
    u.set_item("lambda_p", PyArray1::from_vec(py, col(&|u| u.factors.lambda_p)))?;
    u.set_item("lambda_r", PyArray1::from_vec(py, col(&|u| u.factors.lambda_r)))?;
    let fallback: Vec<bool> = results.updates.iter().map(|u| u.prior_scaling_fallback).collect();
    u.set_item("scaling_fallback", fallback)?;
    let not_helping: Vec<bool> = results.updates.iter().map(|u| u.not_helping).collect();
    u.set_item("not_helping", not_helping)?;
    out.set_item("updates", u)?;
    out.set_item("summary", summary_dict(py, &summary, warning)?)?;
    Ok(out)
}

/// A navigation result (`N × 10`: `t`, latitude, longitude (deg), height (m), velocity
/// N E D (m/s), roll, pitch, yaw (deg)) against a truth file, as `ins-gnss eval`:
/// the statistics as JSON text.
#[pyfunction]
#[pyo3(signature = (nav, truth, skip=0.0))]
fn evaluate<'py>(
    py: Python<'py>,
    nav: PyReadonlyArray2<'py, f64>,
    truth: &str,
    skip: f64,
) -> PyResult<(String, Bound<'py, PyAny>)> {
    let nav = nav.as_array();
    if nav.ncols() != 10 {
        return Err(PyValueError::new_err(format!("nav has {} columns, 10 expected", nav.ncols())));
    }
    let d = std::f64::consts::PI / 180.0;
    let records: Vec<_> = nav
        .rows()
        .into_iter()
        .map(|r| ins_gnss_io::NavRecord {
            week: 0.0,
            t: r[0],
            pos: ins_gnss_core::GeoPos::from_degrees(r[1], r[2], r[3]),
            vel: nalgebra::Vector3::new(r[4], r[5], r[6]),
            att: nalgebra::Vector3::new(r[7] * d, r[8] * d, r[9] * d),
        })
        .collect();
    let truth = Path::new(truth);
    let ev = py.allow_threads(|| -> Result<_, String> {
        let reference = ins_gnss::eval::read_reference(truth).map_err(|e| e.to_string())?;
        Ok(ins_gnss::eval::evaluate_records_per_epoch(&records, &reference, skip))
    });
    let ev = ev.map_err(fail)?;
    let rows: Vec<f64> = ev.epochs.iter().flatten().copied().collect();
    let json = serde_json::to_string(&ev).map_err(fail)?;
    Ok((json, matrix(py, rows, 10)?))
}

/// A truth or reference file (11-column navigation, `t lat lon h`, plain or `.gz`/`.zst`/
/// `.xz`) as rows `t, lat, lon (deg), h (m), vN, vE, vD (m/s; NaN without), roll, pitch,
/// yaw (deg; NaN without)`.
#[pyfunction]
fn read_truth<'py>(py: Python<'py>, path: &str) -> PyResult<Bound<'py, PyAny>> {
    let path = Path::new(path);
    let recs = py.allow_threads(|| ins_gnss::eval::read_reference(path)).map_err(fail)?;
    let r = 180.0 / std::f64::consts::PI;
    let rows: Vec<f64> = recs
        .iter()
        .flat_map(|n| {
            [
                n.t,
                n.pos.lat * r,
                n.pos.lon * r,
                n.pos.h,
                n.vel.x,
                n.vel.y,
                n.vel.z,
                n.att.x * r,
                n.att.y * r,
                n.att.z * r,
            ]
        })
        .collect();
    matrix(py, rows, 10)
}

/// The extension module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("EstimatorError", m.py().get_type::<EstimatorError>())?;
    m.add_function(wrap_pyfunction!(navigate, m)?)?;
    m.add_function(wrap_pyfunction!(evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(read_truth, m)?)?;
    filter::register(m)?;
    callables::register(m)?;
    ahrs::register(m)?;
    rtk::register(m)?;
    Ok(())
}
