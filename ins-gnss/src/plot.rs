//! SVG plots of a run: position and attitude errors with ±3σ envelopes, forward and,
//! when the run smoothed, smoothed (stationary periods shaded when ZUPT ran), and the
//! adaptation factors, and the trajectory in plan view with the GNSS fixes and outages. Reads the run's output files and the truth; writes
//! `errors_position.svg`, `errors_attitude.svg` and `adaptation.svg`.

use std::path::{Path, PathBuf};

use plotters::prelude::*;

use crate::columns::TruthColumns;
use crate::eval::{errors, interpolate, RefReader, MAX_REFERENCE_GAP};
use ins_gnss_core::earth::geodetic_to_local_ned;
use ins_gnss_core::io::formats::open;
use ins_gnss_core::io::{NavReader, NumericLines};
use ins_gnss_core::position::GeoPos;

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
    if t_rec.is_some_and(|t| t.vel.x.is_nan()) {
        // a position reference (RTK fixes at a few Hz): the result interpolated at its
        // epochs, as `eval` compares them; no attitude
        let (mut a, mut b) = (res.next_record().map_err(|e| e.to_string())?, None);
        b = b.or(res.next_record().map_err(|e| e.to_string())?);
        while let Some(t) = t_rec {
            while let (Some(_), Some(rb)) = (&a, &b) {
                if rb.t >= t.t {
                    break;
                }
                a = b.take();
                b = res.next_record().map_err(|e| e.to_string())?;
            }
            if let (Some(ra), Some(rb)) = (&a, &b) {
                if ra.t <= t.t && rb.t >= t.t && rb.t - ra.t <= MAX_REFERENCE_GAP {
                    let (dp, _, _) = errors(&interpolate(ra, rb, t.t), &t);
                    all.push((t.t, [dp.x, dp.y, dp.z, f64::NAN, f64::NAN, f64::NAN]));
                }
            }
            t_rec = tru.next_record().map_err(|e| e.to_string())?;
        }
    }
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

/// One line of a panel: label, points, colour, and whether it is a ±y envelope (drawn as
/// a shaded band between −y and +y) rather than a line.
type Line<'a> = (&'a str, &'a [(f64, f64)], RGBColor, bool);

/// A series cut where it has a hole: consecutive points further apart in time than
/// `GAP_FACTOR` times the series' median spacing (an outage, a streak of refused updates)
/// are not joined.
const GAP_FACTOR: f64 = 5.0;

/// The runs of `pts` without holes (see [`GAP_FACTOR`]).
fn runs(pts: &[(f64, f64)]) -> Vec<&[(f64, f64)]> {
    if pts.len() < 3 {
        return vec![pts];
    }
    let mut steps: Vec<f64> = pts.windows(2).map(|w| w[1].0 - w[0].0).collect();
    steps.sort_by(f64::total_cmp);
    let limit = GAP_FACTOR * steps[steps.len() / 2];
    let mut out = Vec::new();
    let mut start = 0;
    for k in 1..pts.len() {
        if pts[k].0 - pts[k - 1].0 > limit {
            out.push(&pts[start..k]);
            start = k;
        }
    }
    out.push(&pts[start..]);
    out
}

/// The legend box of a chart, in the same style everywhere.
fn legend<'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, SVGBackend<'a>, CT>,
    position: SeriesLabelPosition,
) -> Result<(), String> {
    chart
        .configure_series_labels()
        .label_font(("sans-serif", 13))
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|x| x.to_string())
}

/// A series drawn as lines cut at its holes ([`runs`]), with one legend entry.
fn draw_runs<'a, CT: CoordTranslate<From = (f64, f64)>>(
    chart: &mut ChartContext<'a, SVGBackend<'a>, CT>,
    pts: &[(f64, f64)],
    label: &str,
    style: ShapeStyle,
) -> Result<(), String> {
    let mut first = true;
    for run in runs(pts) {
        let drawn = chart
            .draw_series(LineSeries::new(run.iter().copied(), style))
            .map_err(|x| x.to_string())?;
        if std::mem::take(&mut first) {
            drawn
                .label(label.to_string())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], style));
        }
    }
    Ok(())
}

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
    // the y range from the lines (the errors), not from the σ bands, which are clipped
    // to it: a converged error is not drawn as a flat line under an initial or outage σ
    let values = || lines.iter().filter(|l| !l.3).flat_map(|l| l.1.iter());
    let m = values().map(|p| p.1.abs()).filter(|v| v.is_finite()).fold(1e-6_f64, f64::max);
    let y0 = if symmetric { -m * 1.05 } else { 0.0 };
    let mut chart = ChartBuilder::on(area)
        .caption(title, ("sans-serif", 17))
        .margin(10)
        .margin_right(LEGEND_WIDTH)
        .x_label_area_size(40)
        .y_label_area_size(64)
        .build_cartesian_2d(t0..t1, y0..m * 1.05)
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc("t [s]")
        .y_desc(unit)
        .label_style(("sans-serif", 14))
        .axis_desc_style(("sans-serif", 14))
        .x_labels(8)
        .y_labels(6)
        .x_label_formatter(&|t| format!("{t:.0}"))
        .draw()
        .map_err(e)?;
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
    // envelopes first (shaded bands behind the lines), then the lines
    for (label, pts, colour, band) in lines.iter().filter(|l| l.3) {
        let c = *colour;
        let mut first = true;
        let top = m * 1.05;
        for run in runs(pts) {
            let outline: Vec<(f64, f64)> = run
                .iter()
                .map(|p| (p.0, p.1.min(top)))
                .chain(run.iter().rev().map(|p| (p.0, -p.1.min(top))))
                .collect();
            let drawn = chart
                .draw_series(std::iter::once(Polygon::new(outline, c.mix(0.18).filled())))
                .map_err(e)?;
            if std::mem::take(&mut first) && *band {
                drawn.label(*label).legend(move |(x, y)| {
                    Rectangle::new([(x, y - 5), (x + 16, y + 5)], c.mix(0.35).filled())
                });
            }
        }
    }
    for (label, pts, colour, _) in lines.iter().filter(|l| !l.3) {
        draw_runs(&mut chart, pts, label, ShapeStyle::from(*colour).stroke_width(1))?;
    }
    // the legend in the right margin, off the data
    let mut entries: Vec<(&str, RGBColor, bool)> = Vec::new();
    if !shade.is_empty() {
        entries.push(("stationary", RGBColor(200, 200, 200), true));
    }
    entries.extend(lines.iter().map(|l| (l.0, l.2, l.3)));
    legend_beside(area, &entries)
}

/// Room kept right of a time panel for its legend, px.
const LEGEND_WIDTH: u32 = 170;

/// A legend drawn in the right margin of `area` (pixel coordinates), off the plotting
/// area: a swatch (a band's colour, or a line) and the label per entry.
fn legend_beside(
    area: &DrawingArea<SVGBackend, plotters::coord::Shift>,
    entries: &[(&str, RGBColor, bool)],
) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<std::io::Error>| x.to_string();
    let x = area.dim_in_pixel().0 as i32 - LEGEND_WIDTH as i32 + 12;
    for (k, (label, colour, band)) in entries.iter().enumerate() {
        let y = 44 + 20 * k as i32;
        if *band {
            area.draw(&Rectangle::new([(x, y - 5), (x + 16, y + 5)], colour.mix(0.35).filled()))
                .map_err(e)?;
        } else {
            area.draw(&PathElement::new(vec![(x, y), (x + 16, y)], colour.stroke_width(2)))
                .map_err(e)?;
        }
        area.draw(&Text::new(label.to_string(), (x + 22, y - 7), ("sans-serif", 13))).map_err(e)?;
    }
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

/// Every file [`write_all`] can write.
pub const FILES: [&str; 4] =
    ["errors_position.svg", "errors_attitude.svg", "adaptation.svg", "trajectory.svg"];

/// Write the plots of the run in `out_dir` against `truth`; returns the files written.
pub fn write_all(
    out_dir: &Path,
    truth: &Path,
    columns: Option<&TruthColumns>,
    fixes: &[(f64, GeoPos)],
    skip: f64,
) -> Result<Vec<PathBuf>, String> {
    let mut errs = error_series(&out_dir.join("nav.txt"), truth, columns)?;
    let mut std = read_columns(&out_dir.join("std.txt"))?;
    // the time panels start after the skip, as the tables do
    let start = errs.iter().filter_map(|s| s.first().map(|p| p.0)).fold(f64::INFINITY, f64::min);
    let from = start + skip;
    if skip > 0.0 && from.is_finite() {
        for s in errs.iter_mut() {
            s.retain(|p| p.0 >= from);
        }
        std.retain(|r| r[0] >= from);
    }
    let s3 = |std: &[Vec<f64>], col: usize| -> Series {
        std.iter().map(|r| (r[0], 3.0 * r[col])).collect()
    };
    // the smoother's, when the run smoothed
    let smoothed = match out_dir.join("nav_smoothed.txt").is_file() {
        true => {
            let mut e = error_series(&out_dir.join("nav_smoothed.txt"), truth, columns)?;
            let mut s = read_columns(&out_dir.join("std_smoothed.txt"))?;
            if skip > 0.0 && from.is_finite() {
                for x in e.iter_mut() {
                    x.retain(|p| p.0 >= from);
                }
                s.retain(|r| r[0] >= from);
            }
            Some((e, s))
        }
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
    // (a position reference has no attitude to plot)
    let attitude = errs[3].iter().any(|p| p.1.is_finite());
    if attitude {
        let tmp = partial(&p);
        let root = SVGBackend::new(&tmp, (1000, 900)).into_drawing_area();
        root.fill(&WHITE).map_err(e)?;
        let areas = root.split_evenly((3, 1));
        for (k, name) in ["roll", "pitch", "yaw"].iter().enumerate() {
            let title = format!("attitude error, {name}");
            panel(&areas[k], &title, "deg", &component(3 + k, 7 + k), &still)?;
        }
        root.present().map_err(e)?;
        drop(root);
        publish(&p)?;
        written.push(p);
    } else if p.exists() {
        // an earlier run's attitude plot would not belong to this result
        std::fs::remove_file(&p).map_err(|e| format!("{}: {e}", p.display()))?;
    }

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
            .caption("adaptation factors (λ_P on P⁻, λ_R on R)", ("sans-serif", 17))
            .margin(10)
            .margin_right(36)
            .x_label_area_size(40)
            .y_label_area_size(64)
            .build_cartesian_2d(t0..t1, (0.01f64..top * 1.2).log_scale())
            .map_err(e)?;
        chart.configure_mesh().x_desc("t [s]").y_desc("factor").draw().map_err(e)?;
        let finite = |v: f64| v.is_finite() && v > 0.0;
        for (label, colour, pick) in [
            ("λ_P", BLUE, (|u: &(f64, f64, f64, f64)| u.2) as fn(&(f64, f64, f64, f64)) -> f64),
            ("λ_R", RED, |u| u.3),
        ] {
            let pts: Series =
                ups.iter().filter(|u| finite(pick(u))).map(|u| (u.0, pick(u))).collect();
            // no line across an outage or a streak of refused updates
            draw_runs(&mut chart, &pts, label, ShapeStyle::from(colour).stroke_width(1))?;
        }
        legend(&mut chart, SeriesLabelPosition::UpperRight)?;
        root.present().map_err(e)?;
    }
    publish(&p)?;
    written.push(p);

    let p = out_dir.join("trajectory.svg");
    plan_view(&p, out_dir, truth, columns, fixes)?;
    written.push(p);
    Ok(written)
}

/// The plan view (north against east, metres from the first truth point) of the estimate,
/// the smoothed estimate when there is one, the truth and the GNSS fixes, with the
/// estimate drawn red inside the GNSS outages (holes in the fixes longer than
/// [`GAP_FACTOR`] of their usual interval). Writes `path` (`trajectory.svg`).
fn plan_view(
    path: &Path,
    out_dir: &Path,
    truth: &Path,
    columns: Option<&TruthColumns>,
    fixes: &[(f64, GeoPos)],
) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<std::io::Error>| x.to_string();
    let map = columns.map(TruthColumns::map).transpose()?;
    let mut tru = RefReader::open(truth, map.as_ref()).map_err(|e| e.to_string())?;
    let mut truth_pts = Decimator::new(MAX_POINTS);
    let mut origin = None;
    while let Some(r) = tru.next_record().map_err(|e| e.to_string())? {
        let o = *origin.get_or_insert(r.pos.tuple());
        let d = geodetic_to_local_ned(o, r.pos.tuple());
        truth_pts.push((r.t, d.y, d.x));
    }
    let Some(origin) = origin else { return Err(format!("{}: no record", truth.display())) };
    let read = |name: &str| -> Result<Vec<(f64, f64, f64)>, String> {
        let mut r = NavReader::open(&out_dir.join(name)).map_err(|e| e.to_string())?;
        let mut pts = Decimator::new(MAX_POINTS);
        while let Some(rec) = r.next_record().map_err(|e| e.to_string())? {
            let d = geodetic_to_local_ned(origin, rec.pos.tuple());
            pts.push((rec.t, d.y, d.x));
        }
        Ok(pts.items)
    };
    let estimate = read("nav.txt")?;
    let smoothed = match out_dir.join("nav_smoothed.txt").is_file() {
        true => Some(read("nav_smoothed.txt")?),
        false => None,
    };
    let fix_pts: Vec<(f64, f64, f64)> = fixes
        .iter()
        .map(|(t, p)| {
            let d = geodetic_to_local_ned(origin, p.tuple());
            (*t, d.y, d.x)
        })
        .collect();
    // outages: holes in the fixes
    let outages: Vec<(f64, f64)> = {
        let times: Series = fix_pts.iter().map(|f| (f.0, 0.0)).collect();
        let r = runs(&times);
        r.windows(2).map(|w| (w[0][w[0].len() - 1].0, w[1][0].0)).collect()
    };
    let all = || truth_pts.items.iter().chain(&estimate).chain(&fix_pts);
    let (mut e0, mut e1, mut n0, mut n1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for p in all() {
        (e0, e1, n0, n1) = (e0.min(p.1), e1.max(p.1), n0.min(p.2), n1.max(p.2));
    }
    // equal scales on both axes
    let half = ((e1 - e0).max(n1 - n0) * 0.55).max(1.0);
    let (ec, nc) = ((e0 + e1) / 2.0, (n0 + n1) / 2.0);
    let tmp = partial(path);
    {
        let root = SVGBackend::new(&tmp, (900, 900)).into_drawing_area();
        root.fill(&WHITE).map_err(e)?;
        let mut chart = ChartBuilder::on(&root)
            .caption("trajectory (plan view)", ("sans-serif", 17))
            .margin(10)
            .margin_right(36)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(ec - half..ec + half, nc - half..nc + half)
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_desc("east [m]")
            .y_desc("north [m]")
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.0}"))
            .label_style(("sans-serif", 14))
            .axis_desc_style(("sans-serif", 14))
            .draw()
            .map_err(e)?;
        let line = |chart: &mut ChartContext<'_, SVGBackend, _>,
                    pts: &[(f64, f64, f64)],
                    label: &str,
                    style: ShapeStyle|
         -> Result<(), String> {
            chart
                .draw_series(LineSeries::new(pts.iter().map(|p| (p.1, p.2)), style))
                .map_err(e)?
                .label(label.to_string())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], style));
            Ok(())
        };
        if !fix_pts.is_empty() {
            let step = (fix_pts.len() / MAX_POINTS).max(1);
            let c = RGBColor(230, 140, 0);
            chart
                .draw_series(
                    fix_pts.iter().step_by(step).map(|p| Circle::new((p.1, p.2), 2, c.filled())),
                )
                .map_err(e)?
                .label("GNSS fixes")
                .legend(move |(x, y)| Circle::new((x + 8, y), 3, c.filled()));
        }
        line(&mut chart, &truth_pts.items, "truth", ShapeStyle::from(BLACK).stroke_width(2))?;
        line(&mut chart, &estimate, "estimate", ShapeStyle::from(BLUE).stroke_width(1))?;
        if let Some(s) = &smoothed {
            line(&mut chart, s, "smoothed", ShapeStyle::from(RGBColor(0, 150, 0)).stroke_width(1))?;
        }
        let red = ShapeStyle::from(RED).stroke_width(3);
        for (k, (a, b)) in outages.iter().enumerate() {
            let inside: Vec<(f64, f64)> =
                estimate.iter().filter(|p| p.0 > *a && p.0 < *b).map(|p| (p.1, p.2)).collect();
            let drawn = chart.draw_series(LineSeries::new(inside, red)).map_err(e)?;
            if k == 0 {
                drawn
                    .label("estimate in a GNSS outage")
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], red));
            }
        }
        legend(&mut chart, SeriesLabelPosition::UpperRight)?;
        root.present().map_err(e)?;
    }
    publish(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn series_are_cut_at_holes_only() {
        // 10 Hz with a 3 s hole and a 0.3 s one (3 samples: joined)
        let mut pts: Series = (0..50).map(|k| (k as f64 * 0.1, 1.0)).collect();
        pts.extend((80..120).map(|k| (k as f64 * 0.1, 1.0)));
        pts.extend((123..130).map(|k| (k as f64 * 0.1, 1.0)));
        let r = runs(&pts);
        assert_eq!(r.len(), 2);
        assert_eq!((r[0].len(), r[1].len()), (50, 47));
    }

    #[test]
    fn the_decimator_keeps_a_bounded_even_sample() {
        let mut d = Decimator::new(100);
        for k in 0..100_000 {
            d.push(k);
        }
        assert!((100..=200).contains(&d.items.len()), "{}", d.items.len());
        let gaps: Vec<i32> = d.items.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(gaps.iter().all(|g| *g == gaps[0]), "evenly spaced");
    }
}
