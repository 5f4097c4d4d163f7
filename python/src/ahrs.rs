//! The AHRS of the third paper (conventional, modified and CS-MAEKF filters) on sensor
//! arrays, and its simulated loitering flight, for Python.

use adaptive::AnyStrategy;
use estimator_core::ErrorStateFilter;
use manifolds::So3;
use models::ahrs::experiment::Variant;
use models::ahrs::sim::{LoiteringFlight, SensorErrors};
use models::ahrs::{Ahrs, AhrsMeasurement, AhrsState};
use nalgebra::{SMatrix, Vector3};
use numpy::{PyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::{fail, matrix};

/// A variant by name: `conventional`, `modified`, `modified-tuned` or `cs-maekf`.
fn parse_variant(name: &str) -> PyResult<Variant> {
    Ok(match name.to_ascii_lowercase().as_str() {
        "conventional" => Variant::Conventional,
        "modified" => Variant::Modified,
        "modified-tuned" => Variant::ModifiedTuned,
        "cs-maekf" | "csmaekf" => Variant::CsMaekf,
        other => {
            return Err(PyValueError::new_err(format!(
                "AHRS variant `{other}`: conventional, modified, modified-tuned or cs-maekf"
            )));
        }
    })
}

fn vector3(name: &str, v: &[f64]) -> PyResult<Vector3<f64>> {
    match v {
        [x, y, z] => Ok(Vector3::new(*x, *y, *z)),
        _ => Err(PyValueError::new_err(format!("{name} needs 3 numbers, not {}", v.len()))),
    }
}

/// Run the AHRS over `N × 3` arrays of gyro (mean rate over each interval, rad/s),
/// accelerometer (specific force, m/s²) and magnetometer readings (the unit of `m_n`) at
/// `rate` Hz, from the attitude `att0` (roll, pitch, yaw, rad) with zero drift and
/// acceleration, `P0 = p0·I₉`, `R = r·I₆`. Returns arrays: `att` (roll, pitch, yaw, rad),
/// `drift` (rad/s), `acc` (m/s²), `sigma` (the 9 error states' 1σ), `nis`, `verdict`.
#[pyfunction]
#[pyo3(signature = (
    gyro, accel, mag, rate, att0, m_n, g_n=vec![0.0, 0.0, 9.80665], variant="cs-maekf",
    gyro_noise=0.005, p0=0.01, r=0.02, strategy="fixed"
))]
#[allow(clippy::too_many_arguments)]
fn ahrs<'py>(
    py: Python<'py>,
    gyro: PyReadonlyArray2<'py, f64>,
    accel: PyReadonlyArray2<'py, f64>,
    mag: PyReadonlyArray2<'py, f64>,
    rate: f64,
    att0: Vec<f64>,
    m_n: Vec<f64>,
    g_n: Vec<f64>,
    variant: &str,
    gyro_noise: f64,
    p0: f64,
    r: f64,
    strategy: &str,
) -> PyResult<Bound<'py, PyDict>> {
    let (gyro, accel, mag) = (gyro.as_array(), accel.as_array(), mag.as_array());
    let n = gyro.nrows();
    if [gyro.shape(), accel.shape(), mag.shape()].iter().any(|s| *s != [n, 3]) {
        return Err(PyValueError::new_err("gyro, accel and mag must be N × 3 arrays of one N"));
    }
    if !(rate.is_finite() && rate > 0.0) {
        return Err(PyValueError::new_err(format!("rate {rate} Hz: positive")));
    }
    let att0 = vector3("att0", &att0)?;
    let meas = AhrsMeasurement { g_n: vector3("g_n", &g_n)?, m_n: vector3("m_n", &m_n)? };
    let errors = SensorErrors { gyro_noise, ..Default::default() };
    let model = parse_variant(variant)?.model(&errors, rate);
    let strategy: AnyStrategy = strategy.parse().map_err(fail)?;
    let row = |a: &numpy::ndarray::ArrayView2<'_, f64>, k: usize| {
        Vector3::new(a[(k, 0)], a[(k, 1)], a[(k, 2)])
    };
    let run = || -> Result<_, String> {
        let x0 = AhrsState {
            att: So3::from_euler(att0.x, att0.y, att0.z),
            bg: Vector3::zeros(),
            acc: Vector3::zeros(),
        };
        let f = ErrorStateFilter::new(x0, SMatrix::<f64, 9, 9>::identity() * p0, strategy)
            .map_err(|e| e.to_string())?;
        let mut ahrs = Ahrs::from_filter(f, model, meas, r, rate);
        let (mut att, mut drift, mut acc) = (Vec::new(), Vec::new(), Vec::new());
        let (mut sigma, mut nis, mut verdict) = (Vec::new(), Vec::new(), Vec::new());
        for k in 0..n {
            ahrs.predict(&row(&gyro, k)).map_err(|e| format!("sample {k}: prediction: {e}"))?;
            let report = ahrs
                .update(&row(&accel, k), &row(&mag, k))
                .map_err(|e| format!("sample {k}: update: {e}"))?;
            let x = ahrs.state();
            let (roll, pitch, yaw) = x.att.euler();
            att.extend([roll, pitch, yaw]);
            drift.extend(x.bg.iter());
            acc.extend(x.acc.iter());
            sigma.extend(ahrs.filter().sigma().iter());
            nis.push(report.nis);
            verdict.push(report.verdict.as_str());
        }
        Ok((att, drift, acc, sigma, nis, verdict))
    };
    let (att, drift, acc, sigma, nis, verdict) = py.allow_threads(run).map_err(fail)?;
    let d = PyDict::new(py);
    d.set_item("att", matrix(py, att, 3)?)?;
    d.set_item("drift", matrix(py, drift, 3)?)?;
    d.set_item("acc", matrix(py, acc, 3)?)?;
    d.set_item("sigma", matrix(py, sigma, 9)?)?;
    d.set_item("nis", PyArray1::from_vec(py, nis))?;
    d.set_item("verdict", verdict)?;
    Ok(d)
}

/// The paper's simulated loitering flight (100 Hz, 180 s) for `seed`: arrays `t`, `gyro`,
/// `accel`, `mag` (the sensors), `att` (true roll, pitch, yaw, rad, at each sample's
/// end), `att0` (the true attitude at t = 0, the filter's start), and the flight's
/// `rate`, `g_n`, `m_n`, and the AHRS errors (max and RMS roll, pitch, yaw, deg) of the
/// library's own run of each variant on it (the paper's experiment).
#[pyfunction]
#[pyo3(signature = (seed))]
fn ahrs_flight(py: Python<'_>, seed: u64) -> PyResult<Bound<'_, PyDict>> {
    let flight = LoiteringFlight::default();
    let errors = SensorErrors::default();
    let samples = flight.simulate(&errors, seed);
    let d = PyDict::new(py);
    let col = |f: &dyn Fn(&models::ahrs::sim::Sample) -> Vector3<f64>| -> Vec<f64> {
        samples.iter().flat_map(|s| <[f64; 3]>::from(f(s))).collect()
    };
    d.set_item("t", PyArray1::from_vec(py, samples.iter().map(|s| s.t).collect()))?;
    d.set_item("gyro", matrix(py, col(&|s| s.gyro), 3)?)?;
    d.set_item("accel", matrix(py, col(&|s| s.accel), 3)?)?;
    d.set_item("mag", matrix(py, col(&|s| s.mag), 3)?)?;
    d.set_item(
        "att",
        matrix(
            py,
            col(&|s| {
                let (r, p, y) = s.att.euler();
                Vector3::new(r, p, y)
            }),
            3,
        )?,
    )?;
    let (r0, p0, y0) = flight.attitude(0.0).euler();
    d.set_item("att0", vec![r0, p0, y0])?;
    d.set_item("rate", flight.rate)?;
    d.set_item("g_n", flight.g_n.iter().copied().collect::<Vec<_>>())?;
    d.set_item("m_n", flight.m_n.iter().copied().collect::<Vec<_>>())?;
    let experiment = PyDict::new(py);
    for v in Variant::WITH_CONTROL {
        let e = models::ahrs::experiment::run(v, &flight, &errors, &samples).map_err(fail)?;
        experiment.set_item(v.name(), (e.max.to_vec(), e.rms.to_vec()))?;
    }
    d.set_item("experiment", experiment)?;
    Ok(d)
}

/// Add the functions of this module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(ahrs, m)?)?;
    m.add_function(wrap_pyfunction!(ahrs_flight, m)?)?;
    Ok(())
}
