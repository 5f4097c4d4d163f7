//! SVG plots of a run: position and attitude errors with ±3σ envelopes, forward and,
//! when the run smoothed, smoothed (stationary periods shaded when ZUPT ran), and the
//! adaptation factors, and the trajectory in plan view with the GNSS fixes and outages. Reads the run's output files and the truth; writes
//! `errors_position.svg`, `errors_attitude.svg` and `adaptation.svg`.

use std::path::{Path, PathBuf};

use plotters::prelude::*;

use crate::columns::TruthColumns;
use crate::eval::{errors, interpolate, RefReader, MAX_REFERENCE_GAP};
use ins_gnss_core::earth::geodetic_to_local_ned;
use ins_gnss_core::GeoPos;
use ins_gnss_io::formats::open;
use ins_gnss_io::{NavReader, NumericLines};

mod data;
mod draw;
mod plan;

use data::*;
use draw::*;
use plan::*;

/// One line of a panel: label, points, colour, and whether it is a ±y envelope (drawn as
/// a shaded band between −y and +y) rather than a line.
type Line<'a> = (&'a str, &'a [(f64, f64)], RGBColor, bool);

/// Several runs side by side: one panel per entry of `panels` (title, unit), each with
/// one line per labelled series (e.g. the absolute heading error of each strategy), in
/// the order of `labels`. Series longer than 1,000 points are decimated. Writes `path`.
pub fn comparison(
    path: &Path,
    panels: &[(&str, &str)],
    labels: &[&str],
    series: &[Vec<Series>],
) -> Result<(), String> {
    comparison_about(path, panels, labels, series, false)
}

/// [`comparison`] with each panel's y range from 0 up, or symmetric about 0 when
/// `symmetric` (signed values: offsets, errors).
pub fn comparison_about(
    path: &Path,
    panels: &[(&str, &str)],
    labels: &[&str],
    series: &[Vec<Series>],
    symmetric: bool,
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
        draw_lines(&areas[k], title, unit, &lines, symmetric, &[])?;
    }
    root.present().map_err(e)?;
    drop(root);
    publish(path)
}

/// Where a plot is drawn before it replaces `path` (an earlier plot is never left half
/// overwritten).
fn partial(path: &Path) -> PathBuf {
    ins_gnss_io::formats::partial_path(path)
}

/// Move a finished plot into place.
fn publish(path: &Path) -> Result<(), String> {
    ins_gnss_io::formats::publish(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// Every file [`write_all`] can write.
pub const FILES: [&str; 4] =
    ["errors_position.svg", "errors_attitude.svg", "adaptation.svg", "trajectory.svg"];

/// The adaptation factors λ_P and λ_R of each update over time (`adaptation.svg`,
/// written as a partial file; the caller publishes it).
fn adaptation_plot(p: &Path, ups: &[(f64, f64, f64, f64)]) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<std::io::Error>| x.to_string();
    let tmp = partial(p);
    let root = SVGBackend::new(&tmp, (1000, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(e)?;
    let (t0, t1) = (
        ups.first().map(|u| u.0).unwrap_or(0.0),
        ups.last().map(|u| u.0).unwrap_or(1.0).max(ups.first().map(|u| u.0 + 1.0).unwrap_or(1.0)),
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
        let pts: Series = ups.iter().filter(|u| finite(pick(u))).map(|u| (u.0, pick(u))).collect();
        // no line across an outage or a streak of refused updates
        draw_runs(&mut chart, &pts, label, ShapeStyle::from(colour).stroke_width(1))?;
    }
    legend(&mut chart, SeriesLabelPosition::UpperRight)?;
    root.present().map_err(e)?;
    Ok(())
}

/// A result's error series against the truth and its σ rows (`nav` and `std`, files of
/// `out_dir`), from `from` on when there is a skip (`None`: from its own start plus the
/// skip, as the tables count), and that time.
#[allow(clippy::type_complexity)]
fn series_from(
    out_dir: &Path,
    (nav, std): (&str, &str),
    truth: &Path,
    columns: Option<&TruthColumns>,
    skip: f64,
    from: Option<f64>,
) -> Result<([Series; 6], Vec<Vec<f64>>, f64), String> {
    let mut e = error_series(&out_dir.join(nav), truth, columns)?;
    let mut s = read_columns(&out_dir.join(std))?;
    let from = from.unwrap_or_else(|| {
        let start = e.iter().filter_map(|s| s.first().map(|p| p.0)).fold(f64::INFINITY, f64::min);
        start + skip
    });
    if skip > 0.0 && from.is_finite() {
        for x in e.iter_mut() {
            x.retain(|p| p.0 >= from);
        }
        s.retain(|r| r[0] >= from);
    }
    Ok((e, s, from))
}

/// Write the plots of the run in `out_dir` against `truth`; returns the files written.
pub fn write_all(
    out_dir: &Path,
    truth: &Path,
    columns: Option<&TruthColumns>,
    fixes: &[(f64, GeoPos)],
    skip: f64,
) -> Result<Vec<PathBuf>, String> {
    // the time panels start after the skip, as the tables do
    let (errs, std, from) =
        series_from(out_dir, ("nav.txt", "std.txt"), truth, columns, skip, None)?;
    let s3 = |std: &[Vec<f64>], col: usize| -> Series {
        std.iter().map(|r| (r[0], 3.0 * r[col])).collect()
    };
    // the smoother's, when the run smoothed
    let smoothed = match out_dir.join("nav_smoothed.txt").is_file() {
        true => {
            let files = ("nav_smoothed.txt", "std_smoothed.txt");
            let (e, s, _) = series_from(out_dir, files, truth, columns, skip, Some(from))?;
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
    adaptation_plot(&p, &ups)?;
    publish(&p)?;
    written.push(p);

    let p = out_dir.join("trajectory.svg");
    plan_view(&p, out_dir, truth, columns, fixes)?;
    written.push(p);
    Ok(written)
}

#[cfg(feature = "unit-tests")]
#[doc(hidden)]
pub mod tests {
    use super::*;

    pub fn series_are_cut_at_holes_only() {
        // 10 Hz with a 3 s hole and a 0.3 s one (3 samples: joined)
        let mut pts: Series = (0..50).map(|k| (k as f64 * 0.1, 1.0)).collect();
        pts.extend((80..120).map(|k| (k as f64 * 0.1, 1.0)));
        pts.extend((123..130).map(|k| (k as f64 * 0.1, 1.0)));
        let r = runs(&pts);
        assert_eq!(r.len(), 2);
        assert_eq!((r[0].len(), r[1].len()), (50, 47));
    }

    pub fn the_decimator_keeps_a_bounded_even_sample() {
        let mut d = Decimator::new(100);
        for k in 0..100_000 {
            d.push(k);
        }
        assert!((100..=200).contains(&d.items.len()), "{}", d.items.len());
        let gaps: Vec<i32> = d.items.windows(2).map(|w| w[1] - w[0]).collect();
        assert!(gaps.iter().all(|g| *g == gaps[0]), "evenly spaced");
    }
}
