//! SVG plots of a run: position and attitude errors with ±3σ envelopes, forward and,
//! when the run smoothed, smoothed (stationary periods shaded when ZUPT ran), and the
//! adaptation factors. Reads the run's output files and the truth; writes
//! `errors_position.svg`, `errors_attitude.svg` and `adaptation.svg`.

use std::path::{Path, PathBuf};

use plotters::prelude::*;

use crate::columns::TruthColumns;
use crate::eval::{errors, RefReader};
use ins_gnss_core::io::formats::open;
use ins_gnss_core::io::{NavReader, NumericLines};

type Series = Vec<(f64, f64)>;

/// Points kept per series: a plot has no use for more, and a day at the IMU rate would
/// not fit in memory as points.
const MAX_POINTS: usize = 4000;

/// Every `stride`-th item pushed, the stride doubling (and every other kept item dropped)
/// whenever more than `2 · limit` are kept: between `limit` and `2 · limit` items spread
/// evenly over any number pushed, in bounded memory.
struct Decimator<T> {
    items: Vec<T>,
    stride: usize,
    seen: usize,
    limit: usize,
}

impl<T> Decimator<T> {
    fn new(limit: usize) -> Self {
        Self { items: Vec::new(), stride: 1, seen: 0, limit }
    }

    fn push(&mut self, item: T) {
        if self.seen.is_multiple_of(self.stride) {
            self.items.push(item);
            if self.items.len() > 2 * self.limit {
                let mut k = 0;
                self.items.retain(|_| {
                    k += 1;
                    k % 2 == 1
                });
                self.stride *= 2;
            }
        }
        self.seen += 1;
    }
}

fn read_columns(path: &Path) -> Result<Vec<Vec<f64>>, String> {
    let mut lines = NumericLines::new(open(path).map_err(|e| e.to_string())?, path);
    let mut out = Decimator::new(MAX_POINTS);
    while let Some(r) = lines.next_record().map_err(|e| e.to_string())? {
        out.push(r.to_vec());
    }
    Ok(out.items)
}

fn read_updates(path: &Path) -> Result<Vec<(f64, f64, f64, f64)>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        if f.len() < 10 {
            return Err(format!("{}:{}: expected 10 columns", path.display(), i + 1));
        }
        let num = |s: &str| s.trim().parse::<f64>().unwrap_or(f64::NAN);
        out.push((num(f[0]), num(f[7]), num(f[8]), num(f[9])));
    }
    Ok(out)
}

/// The stationary periods of a run: the spans of its ZUPT updates (rows of stream
/// `zupt` in `updates.csv` less than a second apart form one period).
fn stationary_periods(path: &Path) -> Result<Vec<(f64, f64)>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut out: Vec<(f64, f64)> = Vec::new();
    for line in text.lines().skip(1) {
        let mut f = line.split(',');
        let (Some(t), Some("zupt")) = (f.next(), f.next()) else { continue };
        let Ok(t) = t.trim().parse::<f64>() else { continue };
        match out.last_mut() {
            Some(last) if t - last.1 < 1.0 => last.1 = t,
            _ => out.push((t, t)),
        }
    }
    Ok(out)
}

/// Errors of the result against the truth, decimated to 4,000–8,000 points.
fn error_series(
    result: &Path,
    truth: &Path,
    columns: Option<&TruthColumns>,
) -> Result<[Series; 6], String> {
    let mut res = NavReader::open(result).map_err(|e| e.to_string())?;
    let map = columns.map(TruthColumns::map).transpose()?;
    let mut tru = RefReader::open(truth, map.as_ref()).map_err(|e| e.to_string())?;
    let mut all = Decimator::<(f64, [f64; 6])>::new(MAX_POINTS);
    let mut t_rec = tru.next_record().map_err(|e| e.to_string())?;
    while let Some(r) = res.next_record().map_err(|e| e.to_string())? {
        while let Some(t) = &t_rec {
            if t.t >= r.t - 1e-6 {
                break;
            }
            t_rec = tru.next_record().map_err(|e| e.to_string())?;
        }
        if let Some(t) = &t_rec {
            if (t.t - r.t).abs() < 1e-6 {
                let (dp, _, da) = errors(&r, t);
                all.push((r.t, [dp.x, dp.y, dp.z, da.x, da.y, da.z]));
            }
        }
    }
    let mut out: [Series; 6] = Default::default();
    for (t, e) in &all.items {
        for k in 0..6 {
            out[k].push((*t, e[k]));
        }
    }
    Ok(out)
}

/// One line of a panel: label, points, colour, and whether its mirror image (−y) is drawn
/// too (a ±3σ envelope).
type Line<'a> = (&'a str, &'a [(f64, f64)], RGBColor, bool);

/// Draw `lines` in one panel; the y range is symmetric about 0 when `symmetric`, else
/// from 0 up; the time spans of `shade` (stationary periods) shaded grey behind.
fn draw_lines(
    area: &DrawingArea<SVGBackend, plotters::coord::Shift>,
    title: &str,
    unit: &str,
    lines: &[Line<'_>],
    symmetric: bool,
    shade: &[(f64, f64)],
) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<std::io::Error>| x.to_string();
    let points = || lines.iter().flat_map(|l| l.1.iter());
    let t0 = points().map(|p| p.0).fold(f64::INFINITY, f64::min);
    let t0 = if t0.is_finite() { t0 } else { 0.0 };
    let t1 = points().map(|p| p.0).fold(t0 + 1.0, f64::max);
    let m = points().map(|p| p.1.abs()).filter(|v| v.is_finite()).fold(1e-6_f64, f64::max);
    let y0 = if symmetric { -m * 1.05 } else { 0.0 };
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 16))
        .margin(8)
        .x_label_area_size(28)
        .y_label_area_size(56)
        .build_cartesian_2d(t0..t1, y0..m * 1.05)
        .map_err(e)?;
    chart.configure_mesh().x_desc("t [s]").y_desc(unit).draw().map_err(e)?;
    let grey = RGBColor(200, 200, 200).mix(0.5).filled();
    for (k, (a, b)) in shade.iter().enumerate() {
        let rect = Rectangle::new([(*a, y0), (*b, m * 1.05)], grey);
        let drawn = chart.draw_series(std::iter::once(rect)).map_err(e)?;
        if k == 0 {
            drawn.label("stationary").legend(move |(x, y)| {
                Rectangle::new([(x, y - 5), (x + 16, y + 5)], RGBColor(200, 200, 200).filled())
            });
        }
    }
    for (label, pts, colour, mirror) in lines {
        let c = *colour;
        chart
            .draw_series(LineSeries::new(pts.iter().copied(), c))
            .map_err(e)?
            .label(*label)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], c));
        if *mirror {
            chart.draw_series(LineSeries::new(pts.iter().map(|p| (p.0, -p.1)), c)).map_err(e)?;
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(e)?;
    Ok(())
}

/// The error and ±3σ of one component, forward and (when the run smoothed) smoothed.
struct Component<'a> {
    err: &'a Series,
    sigma3: Series,
    smoothed: Option<(&'a Series, Series)>,
}

fn panel(
    area: &DrawingArea<SVGBackend, plotters::coord::Shift>,
    title: &str,
    unit: &str,
    c: &Component<'_>,
    shade: &[(f64, f64)],
) -> Result<(), String> {
    let mut lines =
        vec![("error", c.err.as_slice(), BLUE, false), ("±3σ", c.sigma3.as_slice(), RED, true)];
    if let Some((err, sigma3)) = &c.smoothed {
        lines.push(("smoothed error", err.as_slice(), RGBColor(0, 150, 0), false));
        lines.push(("smoothed ±3σ", sigma3.as_slice(), RGBColor(230, 140, 0), true));
    }
    draw_lines(area, title, unit, &lines, true, shade)
}

/// Several runs side by side: one panel per entry of `panels` (title, unit), each with
/// one line per labelled series (e.g. the absolute heading error of each strategy), in
/// the order of `labels`. Series longer than 1,000 points are decimated. Writes `path`.
pub fn comparison(
    path: &Path,
    panels: &[(&str, &str)],
    labels: &[&str],
    series: &[Vec<Series>],
) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<std::io::Error>| x.to_string();
    let tmp = partial(path);
    let root = SVGBackend::new(&tmp, (1000, 320 * panels.len() as u32)).into_drawing_area();
    root.fill(&WHITE).map_err(e)?;
    let areas = root.split_evenly((panels.len(), 1));
    for (k, (title, unit)) in panels.iter().enumerate() {
        let decimated: Vec<Series> = series
            .get(k)
            .map(|lines| {
                lines
                    .iter()
                    .map(|l| l.iter().step_by((l.len() / 1000).max(1)).copied().collect())
                    .collect()
            })
            .unwrap_or_default();
        let lines: Vec<Line<'_>> = decimated
            .iter()
            .zip(labels)
            .enumerate()
            .map(|(i, (l, name))| (*name, l.as_slice(), Palette99::pick(i).to_rgba().rgb(), false))
            .map(|(n, l, (r, g, b), m)| (n, l, RGBColor(r, g, b), m))
            .collect();
        draw_lines(&areas[k], title, unit, &lines, false, &[])?;
    }
    root.present().map_err(e)?;
    drop(root);
    publish(path)
}

/// Where a plot is drawn before it replaces `path` (an earlier plot is never left half
/// overwritten).
fn partial(path: &Path) -> PathBuf {
    ins_gnss_core::io::formats::partial_path(path)
}

/// Move a finished plot into place.
fn publish(path: &Path) -> Result<(), String> {
    std::fs::rename(partial(path), path).map_err(|e| format!("{}: {e}", path.display()))
}

/// Write the plots of the run in `out_dir` against `truth`; returns the files written.
pub fn write_all(
    out_dir: &Path,
    truth: &Path,
    columns: Option<&TruthColumns>,
) -> Result<Vec<PathBuf>, String> {
    let errs = error_series(&out_dir.join("nav.txt"), truth, columns)?;
    let std = read_columns(&out_dir.join("std.txt"))?;
    let s3 = |std: &[Vec<f64>], col: usize| -> Series {
        std.iter().map(|r| (r[0], 3.0 * r[col])).collect()
    };
    // the smoother's, when the run smoothed
    let smoothed = match out_dir.join("nav_smoothed.txt").is_file() {
        true => Some((
            error_series(&out_dir.join("nav_smoothed.txt"), truth, columns)?,
            read_columns(&out_dir.join("std_smoothed.txt"))?,
        )),
        false => None,
    };
    let component = |k: usize, col: usize| Component {
        err: &errs[k],
        sigma3: s3(&std, col),
        smoothed: smoothed.as_ref().map(|(e, s)| (&e[k], s3(s, col))),
    };
    let still = stationary_periods(&out_dir.join("updates.csv"))?;
    let e = |x: DrawingAreaErrorKind<std::io::Error>| x.to_string();
    let mut written = Vec::new();

    let p = out_dir.join("errors_position.svg");
    {
        let tmp = partial(&p);
        let root = SVGBackend::new(&tmp, (1000, 900)).into_drawing_area();
        root.fill(&WHITE).map_err(e)?;
        let areas = root.split_evenly((3, 1));
        for (k, name) in ["north", "east", "down"].iter().enumerate() {
            let title = format!("position error, {name}");
            panel(&areas[k], &title, "m", &component(k, 1 + k), &still)?;
        }
        root.present().map_err(e)?;
    }
    publish(&p)?;
    written.push(p);

    let p = out_dir.join("errors_attitude.svg");
    {
        let tmp = partial(&p);
        let root = SVGBackend::new(&tmp, (1000, 900)).into_drawing_area();
        root.fill(&WHITE).map_err(e)?;
        let areas = root.split_evenly((3, 1));
        for (k, name) in ["roll", "pitch", "yaw"].iter().enumerate() {
            let title = format!("attitude error, {name}");
            panel(&areas[k], &title, "deg", &component(3 + k, 7 + k), &still)?;
        }
        root.present().map_err(e)?;
    }
    publish(&p)?;
    written.push(p);

    let ups = read_updates(&out_dir.join("updates.csv"))?;
    let p = out_dir.join("adaptation.svg");
    {
        let tmp = partial(&p);
        let root = SVGBackend::new(&tmp, (1000, 600)).into_drawing_area();
        root.fill(&WHITE).map_err(e)?;
        let (t0, t1) = (
            ups.first().map(|u| u.0).unwrap_or(0.0),
            ups.last()
                .map(|u| u.0)
                .unwrap_or(1.0)
                .max(ups.first().map(|u| u.0 + 1.0).unwrap_or(1.0)),
        );
        let top = ups
            .iter()
            .flat_map(|u| [u.2, u.3])
            .filter(|v| v.is_finite())
            .fold(2.0_f64, f64::max)
            .min(1e3);
        let mut chart = ChartBuilder::on(&root)
            .caption("adaptation factors (λ_P on P⁻, λ_R on R)", ("sans-serif", 16))
            .margin(8)
            .x_label_area_size(28)
            .y_label_area_size(56)
            .build_cartesian_2d(t0..t1, (0.01f64..top * 1.2).log_scale())
            .map_err(e)?;
        chart.configure_mesh().x_desc("t [s]").y_desc("factor").draw().map_err(e)?;
        let finite = |v: f64| v.is_finite() && v > 0.0;
        chart
            .draw_series(LineSeries::new(
                ups.iter().filter(|u| finite(u.2)).map(|u| (u.0, u.2)),
                &BLUE,
            ))
            .map_err(e)?
            .label("λ_P");
        chart
            .draw_series(LineSeries::new(
                ups.iter().filter(|u| finite(u.3)).map(|u| (u.0, u.3)),
                &RED,
            ))
            .map_err(e)?
            .label("λ_R");
        chart.configure_series_labels().border_style(BLACK).draw().map_err(e)?;
        root.present().map_err(e)?;
    }
    publish(&p)?;
    written.push(p);
    Ok(written)
}
