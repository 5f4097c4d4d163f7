//! The trajectory in plan view, with the GNSS fixes and the outages.

use super::*;

/// What the plan view draws: points (time, east, north; metres from the first truth
/// point) of the truth, the estimate, the smoothed estimate and the fixes, and the GNSS
/// outages (from, to).
struct PlanData {
    truth_pts: Vec<(f64, f64, f64)>,
    estimate: Vec<(f64, f64, f64)>,
    smoothed: Option<Vec<(f64, f64, f64)>>,
    fix_pts: Vec<(f64, f64, f64)>,
    outages: Vec<(f64, f64)>,
}

impl PlanData {
    fn read(
        out_dir: &Path,
        truth: &Path,
        columns: Option<&TruthColumns>,
        fixes: &[(f64, GeoPos)],
    ) -> Result<Self, String> {
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
        Ok(Self { truth_pts: truth_pts.items, estimate, smoothed, fix_pts, outages })
    }
}

/// The plan view (north against east, metres from the first truth point) of the estimate,
/// the smoothed estimate when there is one, the truth and the GNSS fixes, with the
/// estimate drawn red inside the GNSS outages (holes in the fixes longer than
/// [`GAP_FACTOR`] of their usual interval). Writes `path` (`trajectory.svg`).
pub(super) fn plan_view(
    path: &Path,
    out_dir: &Path,
    truth: &Path,
    columns: Option<&TruthColumns>,
    fixes: &[(f64, GeoPos)],
) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<std::io::Error>| x.to_string();
    let PlanData { truth_pts, estimate, smoothed, fix_pts, outages } =
        PlanData::read(out_dir, truth, columns, fixes)?;
    let all = || truth_pts.iter().chain(&estimate).chain(&fix_pts);
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
        line(&mut chart, &truth_pts, "truth", ShapeStyle::from(BLACK).stroke_width(2))?;
        line(&mut chart, &estimate, "estimate", ShapeStyle::from(BLUE).stroke_width(1))?;
        if let Some(s) = &smoothed {
            line(&mut chart, s, "smoothed", ShapeStyle::from(RGBColor(0, 150, 0)).stroke_width(1))?;
        }
        draw_outages(&mut chart, &estimate, &outages)?;
        legend(&mut chart, SeriesLabelPosition::UpperRight)?;
        root.present().map_err(e)?;
    }
    publish(path)
}

/// The estimate drawn red inside each GNSS outage.
fn draw_outages(
    chart: &mut ChartContext<
        '_,
        SVGBackend,
        Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
    >,
    estimate: &[(f64, f64, f64)],
    outages: &[(f64, f64)],
) -> Result<(), String> {
    let e = |x: DrawingAreaErrorKind<std::io::Error>| x.to_string();
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
    Ok(())
}
