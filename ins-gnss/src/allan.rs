//! `ins-gnss allan`: the IMU's noise from a static record by the overlapping Allan
//! deviation (`ins_gnss_core::allan`), per axis, with the fitted white noise, bias
//! instability and rate random walk (1σ from the fit), a log-log SVG of the curves with
//! the fitted lines, and the `[imu_noise]` block to paste, in the configuration's units.

use std::fmt::Write as _;
use std::path::Path;

use plotters::prelude::*;

use crate::config::Config;
use crate::run::{Inputs, RunError};
use ins_gnss_core::allan::{AxisNoise, Term, FLICKER_FLOOR};
use ins_gnss_io::formats::ImuReader;
use ins_gnss_io::{BadLinePolicy, ImuFormat};

const DEG: f64 = 180.0 / std::f64::consts::PI;
/// The slow drift a 1 s mean of a static record may show beyond its noise: rate (rad/s,
/// 0.57 °/s) and specific force (m/s²).
pub const STATIC_RATE: f64 = 0.01;
/// See [`STATIC_RATE`].
pub const STATIC_FORCE: f64 = 0.3;
/// How many σ of a 1 s mean's white noise a static record's 1 s means may depart (the
/// largest of 3 × 86,400 Gaussian draws, a day's axes, is about 5σ).
pub const NOISE_SIGMAS: f64 = 6.0;

/// The six axes' increments (gyro x, y, z in rad; accelerometer x, y, z in m/s) and the
/// sample interval.
pub struct Record {
    /// Increments per axis.
    pub axes: [Vec<f64>; 6],
    /// Mean sample interval, s.
    pub dt: f64,
    /// What was read.
    pub source: String,
}

/// Read every IMU sample of `path`: a configuration (`.toml`, `.yaml`, `.yml`: its
/// `data.imu` with its format, rate, column map and mounting, or its ROS recording), or
/// an IMU file in KF-GINS's format (`rate` Hz, `rates` or increments); the first `first`
/// seconds when given.
pub fn read(
    path: &Path,
    rate: Option<f64>,
    rates: bool,
    first: Option<f64>,
) -> Result<Record, RunError> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    let mut reader = if matches!(ext, "toml" | "yaml" | "yml") {
        let config = Config::load(path).map_err(RunError::Config)?;
        let (config, inputs) = if config.data.ros.is_some() {
            crate::run::open_recording(&config)?
        } else {
            (config, Inputs::Files)
        };
        crate::run::open_imu(&config, &inputs)?
    } else {
        let rate = rate.ok_or_else(|| {
            RunError::NoData(format!(
                "{}: an IMU file needs its rate (--rate HZ), or give a configuration",
                path.display()
            ))
        })?;
        let format = if rates { ImuFormat::Rates } else { ImuFormat::Increments };
        ImuReader::open(path, format, rate, 5.0, BadLinePolicy::Error)?
    };
    let mut axes: [Vec<f64>; 6] = Default::default();
    let mut last = 0.0;
    let mut start = None;
    while let Some(s) = reader.next_sample()? {
        let t0 = *start.get_or_insert(s.t - s.dt);
        if first.is_some_and(|f| s.t - t0 > f) {
            break;
        }
        last = s.t;
        for i in 0..3 {
            axes[i].push(s.dtheta[i]);
            axes[i + 3].push(s.dvel[i]);
        }
    }
    let n = axes[0].len();
    let dt = start.map_or(f64::NAN, |t0| (last - t0) / n.max(1) as f64);
    Ok(Record { axes, dt, source: path.display().to_string() })
}

/// How far the record's 1 s means depart from its mean, against what rest allows, per
/// sensor (gyros, accelerometers): `(largest departure, its allowance)` of the axis whose
/// ratio is largest. At rest a 1 s mean departs by its white noise — the samples'
/// point-to-point scatter (`sd(xᵢ₊₁ − xᵢ)/√2`, which slow motion does not inflate) over
/// √(samples per second), up to [`NOISE_SIGMAS`] of it over a long record — plus a slow
/// drift of the bias below [`STATIC_RATE`] / [`STATIC_FORCE`].
pub fn motion(r: &Record) -> [(f64, f64); 2] {
    let per = ((1.0 / r.dt).round() as usize).max(1);
    let worst = |axes: &[Vec<f64>], floor: f64| {
        let mut out = (0.0, floor);
        for a in axes {
            let n = a.len().max(2) as f64;
            let mean = a.iter().sum::<f64>() / n / r.dt;
            let jitter = a.windows(2).map(|w| (w[1] - w[0]).powi(2)).sum::<f64>() / (n - 1.0);
            let white = (jitter / 2.0).sqrt() / r.dt / (per as f64).sqrt();
            let allowed = floor + NOISE_SIGMAS * white;
            for c in a.chunks_exact(per) {
                let d = (c.iter().sum::<f64>() / (per as f64 * r.dt) - mean).abs();
                if d / allowed > out.0 / out.1 {
                    out = (d, allowed);
                }
            }
        }
        out
    };
    [worst(&r.axes[..3], STATIC_RATE), worst(&r.axes[3..], STATIC_FORCE)]
}

/// A record at rest, or why not.
pub fn check_static(r: &Record) -> Result<(), String> {
    let [(w, wa), (f, fa)] = motion(r);
    if w <= wa && f <= fa {
        return Ok(());
    }
    Err(format!(
        "{}: the record moves (a 1 s mean departs from the record's mean by {:.3} °/s and \
         {:.3} m/s², where rest allows {:.3} °/s and {:.3} m/s²: the sensors' own noise and a \
         slow drift): the Allan deviation of a moving IMU measures its motion, not its \
         noise — give a static record",
        r.source,
        w * DEG,
        f,
        wa * DEG,
        fa
    ))
}

/// The analysis of every axis.
pub fn analyse_record(r: &Record) -> Result<Vec<AxisNoise>, String> {
    ins_gnss_core::allan::analyse_axes(&r.axes, r.dt)
        .into_iter()
        .map(|f| f.map_err(|e| format!("{}: {e}", r.source)))
        .collect()
}

const NAMES: [&str; 6] = ["gyro x", "gyro y", "gyro z", "accel x", "accel y", "accel z"];

fn term(t: Option<Term>, scale: f64, unit: &str, missing: &str) -> String {
    match t {
        Some(t) => format!("{:.4} ± {:.4} {unit}", t.value * scale, t.sigma * scale),
        None => missing.to_string(),
    }
}

/// The report: per axis the three terms in the configuration's units, `σ·√dt` of the
/// samples (what `imu_noise.from_static` measures), and the `[imu_noise]` block.
pub fn report(r: &Record, fits: &[AxisNoise]) -> String {
    let mut s = String::new();
    let span = fits.first().map_or(0.0, |f| f.span);
    let _ = writeln!(
        s,
        "{}: {} samples, {:.3} s apart, {:.1} min",
        r.source,
        r.axes[0].len(),
        r.dt,
        span / 60.0
    );
    let units = [
        (DEG * 60.0, "deg/√h", DEG * 3600.0, "deg/h", DEG * 3600.0 * 60.0, "deg/h/√h"),
        (60.0, "m/s/√h", 1e5, "mGal", 1e5 * 60.0, "mGal/√h"),
    ];
    for (i, f) in fits.iter().enumerate() {
        let (ws, wu, bs, bu, ks, ku) = units[i / 3];
        let a = &r.axes[i];
        let mean = a.iter().sum::<f64>() / a.len() as f64;
        let sd = (a.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / a.len() as f64).sqrt();
        let longest = f.curve.iter().rev().find(|p| span / p.tau >= 9.0).map_or(0.0, |p| p.tau);
        let _ = writeln!(
            s,
            "  {:8} white {}; instability {}; rate random walk {}; minimum at τ = {:.0} s; \
             σ·√dt of the samples {:.4} {wu}",
            NAMES[i],
            term(f.white, ws, wu, "not resolved"),
            term(
                f.instability,
                bs,
                bu,
                &format!(
                    "not observable in {:.0} min (the curve still falls at τ = {longest:.0} s; \
                     record ≥ 2 h at rest)",
                    span / 60.0
                )
            ),
            term(f.rate_random_walk, ks, ku, "not observable"),
            f.tau_min,
            sd / r.dt.sqrt() * ws,
        );
    }
    s.push_str(&imu_noise_block(fits));
    s
}

/// The `[imu_noise]` block (TOML, the configuration's units); a term the record does not
/// resolve is left as a comment.
pub fn imu_noise_block(fits: &[AxisNoise]) -> String {
    let list = |k: usize, pick: &dyn Fn(&AxisNoise) -> Option<Term>, scale: f64| {
        let v: Option<Vec<String>> = fits[k..k + 3]
            .iter()
            .map(|f| pick(f).map(|t| format!("{:.4e}", t.value * scale)))
            .collect();
        v.map(|v| format!("[{}]", v.join(", ")))
    };
    let mut s = String::from("\n[imu_noise]\n");
    let mut line = |key: &str, v: Option<String>, why: &str| {
        match v {
            Some(v) => s.push_str(&format!("{key} = {v}\n")),
            None => s.push_str(&format!("# {key}: {why}\n")),
        };
    };
    line("arw", list(0, &|f| f.white, DEG * 60.0), "not resolved on every gyro axis");
    line("vrw", list(3, &|f| f.white, 60.0), "not resolved on every accelerometer axis");
    line(
        "gyro_bias_std",
        list(0, &|f| f.instability, DEG * 3600.0),
        "bias instability not observable in this record",
    );
    line(
        "accel_bias_std",
        list(3, &|f| f.instability, 1e5),
        "bias instability not observable in this record",
    );
    let taus: Vec<f64> =
        fits.iter().filter(|f| f.instability.is_some()).map(|f| f.tau_min).collect();
    if !taus.is_empty() {
        let mut t = taus.clone();
        t.sort_by(f64::total_cmp);
        s.push_str(&format!(
            "corr_time = {:.3}  # h: the median τ of the curves' minima\n",
            t[t.len() / 2] / 3600.0
        ));
    }
    if let Some(v) = list(0, &|f| f.rate_random_walk, DEG * 3600.0 * 60.0) {
        s.push_str(&format!(
            "# gyro_bias_rw = {v}  # deg/h/√h, with bias_model = \"random-walk\"\n"
        ));
    }
    if let Some(v) = list(3, &|f| f.rate_random_walk, 1e5 * 60.0) {
        s.push_str(&format!("# accel_bias_rw = {v}  # mGal/√h\n"));
    }
    s
}

/// The curves on log-log axes (gyros in deg/h, accelerometers in m/s²) with the fitted
/// model dashed; written beside, then moved onto `path`.
pub fn plot(path: &Path, fits: &[AxisNoise]) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<std::io::Error>| x.to_string();
    let tmp = ins_gnss_io::formats::partial_path(path);
    {
        let root = SVGBackend::new(&tmp, (900, 1000)).into_drawing_area();
        root.fill(&WHITE).map_err(e)?;
        let areas = root.split_evenly((2, 1));
        for (panel, (area, (scale, unit))) in
            areas.iter().zip([(DEG * 3600.0, "deg/h"), (1.0, "m/s²")]).enumerate()
        {
            let fits = &fits[panel * 3..panel * 3 + 3];
            let pts: Vec<(f64, f64)> = fits
                .iter()
                .flat_map(|f| f.curve.iter().map(|p| (p.tau, p.adev * scale)))
                .filter(|p| p.1 > 0.0)
                .collect();
            if pts.is_empty() {
                continue;
            }
            let (t0, t1) =
                pts.iter().fold((f64::MAX, 0.0_f64), |a, p| (a.0.min(p.0), a.1.max(p.0)));
            let (y0, y1) =
                pts.iter().fold((f64::MAX, 0.0_f64), |a, p| (a.0.min(p.1), a.1.max(p.1)));
            let title =
                if panel == 0 { "gyro Allan deviation" } else { "accelerometer Allan deviation" };
            let mut chart = ChartBuilder::on(area)
                .caption(title, ("sans-serif", 20))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d((t0..t1).log_scale(), (y0 / 2.0..y1 * 2.0).log_scale())
                .map_err(e)?;
            chart.configure_mesh().x_desc("τ (s)").y_desc(unit).draw().map_err(e)?;
            for (k, f) in fits.iter().enumerate() {
                let colour = Palette99::pick(k).to_rgba();
                let curve: Vec<(f64, f64)> =
                    f.curve.iter().map(|p| (p.tau, p.adev * scale)).filter(|p| p.1 > 0.0).collect();
                chart
                    .draw_series(LineSeries::new(curve, colour.stroke_width(2)))
                    .map_err(e)?
                    .label(NAMES[panel * 3 + k])
                    .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], colour));
                let model = |t: f64| {
                    let w = f.white.map_or(0.0, |v| v.value * v.value / t);
                    let b = f.instability.map_or(0.0, |v| FLICKER_FLOOR * v.value * v.value);
                    let k = f.rate_random_walk.map_or(0.0, |v| v.value * v.value * t / 3.0);
                    (w + b + k).sqrt() * scale
                };
                let fitted: Vec<(f64, f64)> =
                    f.curve.iter().map(|p| (p.tau, model(p.tau))).filter(|p| p.1 > 0.0).collect();
                chart
                    .draw_series(DashedLineSeries::new(fitted, 6, 4, colour.stroke_width(1)))
                    .map_err(e)?;
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()
                .map_err(e)?;
        }
        root.present().map_err(e)?;
    }
    std::fs::rename(&tmp, path).map_err(|x| format!("{}: {x}", path.display()))
}

/// `ins-gnss allan`: read (the first `first` seconds when given), refuse a moving record,
/// analyse, print, plot.
pub fn run(
    path: &Path,
    rate: Option<f64>,
    rates: bool,
    first: Option<f64>,
    svg: Option<&Path>,
) -> Result<String, String> {
    let r = read(path, rate, rates, first).map_err(|e| e.to_string())?;
    if !(r.dt.is_finite() && r.dt > 0.0) || r.axes[0].len() < ins_gnss_core::allan::MIN_SAMPLES {
        return Err(format!(
            "{}: {} samples — the Allan deviation needs at least {} at rest (minutes for the \
             white noise, hours for the bias instability)",
            r.source,
            r.axes[0].len(),
            ins_gnss_core::allan::MIN_SAMPLES
        ));
    }
    check_static(&r)?;
    let fits = analyse_record(&r)?;
    if let Some(p) = svg {
        plot(p, &fits)?;
    }
    Ok(report(&r, &fits))
}
