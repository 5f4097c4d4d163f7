//! `rtk`: the rover's RTK positions against a base station, as `ins-gnss rtk`: the
//! solutions as an array, the fix's metrics, and the comparison with another solution.

use std::path::{Path, PathBuf};

use pyo3::prelude::*;
use pyo3::types::PyDict;

use ins_gnss::rtk::{base_position, solve_files, RtkSettings, WRONG_FIX};
use ins_gnss::spp::read_pos;
use ins_gnss_core::earth::{ecef_to_geodetic, ecef_to_ned_rotation};

use crate::{fail, matrix};

/// The columns of `rtk`'s `solutions`.
pub const RTK_COLUMNS: [&str; 12] = [
    "week",
    "tow",
    "lat",
    "lon",
    "h",
    "sdn",
    "sde",
    "sdd",
    "q",
    "ratio",
    "sats",
    "fixed_ambiguities",
];

/// RTK positions of `rover` (RINEX observations, or a u-blox log) against `base` (the same,
/// or RTCM 3: a name with `.rtcm`), with the navigation files `nav`; the base position from
/// `base_position` (ECEF, m), the base file's header or its RTCM 1005/1006 message. The settings are `ins-gnss rtk`'s options, with its defaults. Returns a
/// dict: `solutions` (`N × 12`: week, time of week (s), latitude, longitude (deg), height
/// (m), σ north, east, down (m), Q (1 fixed, 2 float), the ratio (NaN: not searched), the
/// satellites, the ambiguities fixed), `metrics` (the fix's), `base` (latitude, longitude,
/// height used) and, with `against` (an RTKLIB `.pos`), the comparison with it.
#[pyfunction]
#[pyo3(signature = (
    rover, base, nav, base_position=None, static_rover=false, frequencies=2, mask=15.0,
    ratio=3.0, max_age=1.0, min_success_rate=None, partial=false, code_bias_sigma=0.3,
    code_bias_tau=60.0, hold=5, against=None
))]
#[allow(clippy::too_many_arguments)]
pub fn rtk<'py>(
    py: Python<'py>,
    rover: PathBuf,
    base: PathBuf,
    nav: Vec<PathBuf>,
    base_position: Option<Vec<f64>>,
    static_rover: bool,
    frequencies: i64,
    mask: f64,
    ratio: f64,
    max_age: f64,
    min_success_rate: Option<f64>,
    partial: bool,
    code_bias_sigma: f64,
    code_bias_tau: f64,
    hold: i64,
    against: Option<PathBuf>,
) -> PyResult<Bound<'py, PyDict>> {
    // (counts as Python's ints: a negative one is refused by name, not as an overflow)
    let count = |name: &str, v: i64, want: &str| {
        usize::try_from(v).map_err(|_| fail(format!("`{name}` = {v}: {want}")))
    };
    let settings = RtkSettings {
        static_rover,
        frequencies: count("frequencies", frequencies, "1 or 2")?,
        mask,
        ratio,
        max_age,
        min_success_rate,
        partial,
        code_bias_sigma,
        code_bias_tau,
        hold: count("hold", hold, "a count of epochs, 0 or more")?,
    };
    let opt = settings.options().map_err(|(name, why)| fail(format!("`{name}` = {why}")))?;
    let base_pos = base_position
        .map(|v| self::base_position(&v))
        .transpose()
        .map_err(|e| fail(format!("`base_position`: {e}")))?;
    let (run, theirs) = py
        .allow_threads(|| -> Result<_, String> {
            let run =
                solve_files(&rover, &base, &nav, base_pos, &opt).map_err(|e| e.to_string())?;
            let theirs = against.as_deref().map(read).transpose()?;
            Ok((run, theirs))
        })
        .map_err(fail)?;
    let mut rows = Vec::with_capacity(run.solutions.len() * RTK_COLUMNS.len());
    for s in &run.solutions {
        let (lat, lon, h) = ecef_to_geodetic(&s.pos);
        let c = ecef_to_ned_rotation(lat, lon);
        let ned = c * s.cov * c.transpose();
        rows.extend([
            f64::from(s.time.week),
            s.time.tow,
            lat.to_degrees(),
            lon.to_degrees(),
            h,
            ned[(0, 0)].sqrt(),
            ned[(1, 1)].sqrt(),
            ned[(2, 2)].sqrt(),
            if s.fixed { 1.0 } else { 2.0 },
            s.ratio,
            s.sats as f64,
            s.fixed_ambiguities as f64,
        ]);
    }
    let out = PyDict::new(py);
    out.set_item("solutions", matrix(py, rows, RTK_COLUMNS.len())?)?;
    out.set_item("columns", RTK_COLUMNS.to_vec())?;
    out.set_item("metrics", metrics_dict(py, run.metrics())?)?;
    let (lat, lon, h) = ecef_to_geodetic(&run.base);
    out.set_item("base", (lat.to_degrees(), lon.to_degrees(), h))?;
    let compared = match theirs {
        Some(theirs) => {
            let c = ins_gnss::rtk::compared(&run, &theirs);
            let d = PyDict::new(py);
            d.set_item("epochs", theirs.len())?;
            d.set_item("common", c.common)?;
            d.set_item("rms", c.rms)?;
            d.set_item("offset_ned", (c.offset.x, c.offset.y, c.offset.z))?;
            d.set_item("fixed_compared", c.fixed_compared)?;
            d.set_item("wrong_fixes", c.wrong_fixes)?;
            d.set_item("wrong_fix_limit", WRONG_FIX)?;
            Some(d)
        }
        None => None,
    };
    out.set_item("against", compared)?;
    Ok(out)
}

/// Another solution's positions (an RTKLIB `.pos`), the error a message.
fn read(path: &Path) -> Result<Vec<(f64, nalgebra::Vector3<f64>)>, String> {
    read_pos(path).map_err(|e| e.to_string())
}

/// Adds `rtk` to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(rtk, m)?)?;
    m.add("RTK_COLUMNS", RTK_COLUMNS.to_vec())?;
    Ok(())
}

/// An RTK run's fix metrics as a dict (`rtk(...)["metrics"]`, and a run's
/// `summary["rtk"]`).
pub(crate) fn metrics_dict(
    py: Python<'_>,
    m: ins_gnss::rtk::RtkMetrics,
) -> PyResult<Bound<'_, PyDict>> {
    let metrics = PyDict::new(py);
    metrics.set_item("epochs", m.epochs)?;
    metrics.set_item("solved", m.solved)?;
    metrics.set_item("fixed", m.fixed)?;
    metrics.set_item("fix_rate", m.fix_rate)?;
    metrics.set_item("time_to_first_fix", m.time_to_first_fix)?;
    metrics.set_item("refix_times", m.refix_times)?;
    metrics.set_item("ratio_fixed", m.ratio_fixed)?;
    metrics.set_item("ratio_other", m.ratio_other)?;
    metrics.set_item("failures", m.failures)?;
    Ok(metrics)
}
