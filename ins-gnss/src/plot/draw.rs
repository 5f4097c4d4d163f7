//! Drawing: series split at their gaps, lines with their legends, error panels.

use super::*;

/// A series cut where it has a hole: consecutive points further apart in time than
/// `GAP_FACTOR` times the series' median spacing (an outage, a streak of refused updates)
/// are not joined.
pub(super) const GAP_FACTOR: f64 = 5.0;

/// The runs of `pts` without holes (see [`GAP_FACTOR`]).
pub(super) fn runs(pts: &[(f64, f64)]) -> Vec<&[(f64, f64)]> {
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
pub(super) fn legend<'a, CT: CoordTranslate>(
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
pub(super) fn draw_runs<'a, CT: CoordTranslate<From = (f64, f64)>>(
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
pub(super) fn draw_lines(
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
pub(super) const LEGEND_WIDTH: u32 = 170;

/// A legend drawn in the right margin of `area` (pixel coordinates), off the plotting
/// area: a swatch (a band's colour, or a line) and the label per entry.
pub(super) fn legend_beside(
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
pub(super) struct Component<'a> {
    pub(super) err: &'a Series,
    pub(super) sigma3: Series,
    pub(super) smoothed: Option<(&'a Series, Series)>,
}

pub(super) fn panel(
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
