//! `ins-gnss rtk --report`: an RTK run in one HTML file — the summary, the fix's metrics,
//! the settings and three plots inline.

use super::*;

/// Writes `path`: an RTK run in one self-contained HTML file (no script, no external
/// file) — the summary's `lines`, the fix's metrics as a table, the settings, and three
/// plots inline: the ratio test on the fixed and the float epochs beside its threshold,
/// the solutions' σ north, east and down, and their offset from the mean fixed position
/// (from the last solution when nothing fixed). Written through a `.partial` file.
pub fn write_report(
    path: &Path,
    title: &str,
    lines: &[String],
    run: &RtkRun,
    opt: &RtkOptions,
) -> Result<(), CliError> {
    use crate::report::{escape, inline_svg};
    use std::fmt::Write as _;
    let m = run.metrics();
    let mut h = crate::report::head(title);
    h.push_str("<h2>Summary</h2>\n<ul>\n");
    for line in lines {
        let _ = writeln!(h, "<li>{}</li>", escape(line));
    }
    h.push_str("</ul>\n");
    crate::report::fix_table(&mut h, &m);
    h.push_str("<h2>Plots</h2>\n");
    let dir = tempdir(path)?;
    let drawn = plots(&dir, run, opt).and_then(|files| {
        files.iter().map(|f| inline_svg(f)).collect::<Result<Vec<String>, String>>()
    });
    let _ = std::fs::remove_dir_all(&dir);
    for svg in drawn? {
        let _ = writeln!(h, "<figure>{svg}</figure>");
    }
    let _ = writeln!(h, "<h2>Settings</h2>\n<pre>{}</pre>", escape(&describe(run, opt)));
    h.push_str("</body>\n</html>\n");
    ins_gnss_io::formats::write_published(path, h)?;
    Ok(())
}

/// A scratch folder beside `path` for the report's plots.
fn tempdir(path: &Path) -> Result<PathBuf, String> {
    let parent = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let dir = parent.join(format!(".rtk-report-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    Ok(dir)
}

/// The report's three plots as SVG files in `dir`.
fn plots(dir: &Path, run: &RtkRun, opt: &RtkOptions) -> Result<Vec<PathBuf>, String> {
    let Some(first) = run.solutions.first() else { return Ok(Vec::new()) };
    let t = |s: &RtkEpoch| s.time.diff(&first.time);
    let (fixed, float): (Vec<&RtkEpoch>, Vec<&RtkEpoch>) =
        run.solutions.iter().partition(|s| s.fixed);
    let ratio = |set: &[&RtkEpoch]| -> Vec<(f64, f64)> {
        set.iter().filter(|s| s.ratio.is_finite()).map(|s| (t(s), s.ratio)).collect()
    };
    let span = (0.0, t(run.solutions.last().unwrap_or(first)));
    let threshold = vec![(span.0, opt.ratio), (span.1, opt.ratio)];
    let centre = fixed_scatter(run).map_or(run.solutions.last().unwrap_or(first).pos, |f| f.0);
    let (lat, lon, _) = ecef_to_geodetic(&centre);
    let c = ecef_to_ned_rotation(lat, lon);
    let axis = |f: &dyn Fn(&RtkEpoch) -> f64| -> Vec<(f64, f64)> {
        run.solutions.iter().map(|s| (t(s), f(s))).collect()
    };
    let sigma = |k: usize| axis(&|s| (c * s.cov * c.transpose())[(k, k)].sqrt());
    let offset = |k: usize| axis(&|s| (c * (s.pos - centre))[k]);
    let files = [
        (
            "rtk_ratio.svg",
            false,
            ("the ratio test, and its threshold", "ratio"),
            vec!["fixed epochs", "float epochs", "threshold"],
            vec![ratio(&fixed), ratio(&float), threshold],
        ),
        (
            "rtk_sigma.svg",
            false,
            ("the solutions' σ", "m"),
            vec!["north", "east", "down"],
            vec![sigma(0), sigma(1), sigma(2)],
        ),
        (
            "rtk_offset.svg",
            true,
            ("offset from the mean fixed position", "m"),
            vec!["north", "east", "down"],
            vec![offset(0), offset(1), offset(2)],
        ),
    ];
    let mut out = Vec::new();
    for (name, symmetric, panel, labels, series) in files {
        let path = dir.join(name);
        crate::plot::comparison_about(&path, &[panel], &labels, &[series], symmetric)?;
        out.push(path);
    }
    Ok(out)
}
