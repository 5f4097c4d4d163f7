//! The plots and the report as a reader gets them: every SVG renders (resvg) to a PNG of
//! its stated size with something drawn on it, the legends carry their entries, and
//! `report.html` is well-formed, holds every plot inline and the configuration used.

use std::path::{Path, PathBuf};
use std::process::Command;

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("estimator-plots-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_ins-gnss"))
}

/// Render `svg` to pixels: (width, height, fraction of pixels that are not white).
fn render(svg: &Path) -> (u32, u32, f64) {
    let options = resvg::usvg::Options::default();
    let tree = resvg::usvg::Tree::from_data(&std::fs::read(svg).unwrap(), &options)
        .unwrap_or_else(|e| panic!("{}: {e}", svg.display()));
    let size = tree.size().to_int_size();
    let mut pixmap = resvg::tiny_skia::Pixmap::new(size.width(), size.height()).unwrap();
    resvg::render(&tree, resvg::tiny_skia::Transform::default(), &mut pixmap.as_mut());
    let png = pixmap.encode_png().unwrap();
    assert!(png.len() > 1000, "{}: PNG of {} bytes", svg.display(), png.len());
    let drawn = pixmap.pixels().iter().filter(|p| p.red() < 250 || p.green() < 250).count();
    (size.width(), size.height(), drawn as f64 / pixmap.pixels().len() as f64)
}

/// Elements opened and closed in order (void elements and the doctype aside), text and
/// attributes of a well-formed page: the first mismatch, if any.
fn unbalanced(html: &str) -> Option<String> {
    const VOID: [&str; 6] = ["meta", "br", "hr", "img", "link", "input"];
    let mut stack: Vec<String> = Vec::new();
    let mut rest = html;
    while let Some(i) = rest.find('<') {
        rest = &rest[i + 1..];
        let end = rest.find('>')?;
        let tag = &rest[..end];
        rest = &rest[end + 1..];
        if tag.starts_with('!') || tag.starts_with('?') || tag.ends_with('/') {
            continue;
        }
        let name: String = tag
            .trim_start_matches('/')
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '-' || *c == ':')
            .collect();
        if VOID.contains(&name.as_str()) {
            continue;
        }
        if tag.starts_with('/') {
            match stack.pop() {
                Some(open) if open == name => {}
                other => return Some(format!("</{name}> closes {other:?}")),
            }
        } else {
            stack.push(name);
        }
    }
    (!stack.is_empty()).then(|| format!("left open: {stack:?}"))
}

#[test]
fn plots_render_and_the_report_holds_them() {
    let dir = temp("run");
    let scenario = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/drive.toml");
    let out = bin().args(["simulate"]).arg(&scenario).arg("--out").arg(&dir).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let out = bin()
        .arg("run")
        .arg(dir.join("config.toml"))
        .args(["--quiet", "--smooth", "--report", "--zupt"])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let out_dir = dir.join("out");
    let sizes = [
        ("errors_position.svg", (1000, 900)),
        ("errors_attitude.svg", (1000, 900)),
        ("adaptation.svg", (1000, 600)),
        ("trajectory.svg", (900, 900)),
    ];
    for (name, size) in sizes {
        assert!(stdout.contains(name), "{name} not reported: {stdout}");
        let (w, h, drawn) = render(&out_dir.join(name));
        assert_eq!((w, h), size, "{name}");
        assert!(drawn > 0.02, "{name}: {:.1} % drawn", drawn * 100.0);
    }
    // legends name every line (each entry drawn with its swatch: see the PNGs in docs/img)
    let svg = std::fs::read_to_string(out_dir.join("errors_position.svg")).unwrap();
    for entry in ["error", "±3σ", "smoothed error", "smoothed ±3σ"] {
        assert!(svg.lines().any(|l| l.trim() == entry), "no legend entry {entry}");
    }
    // ... in the margin right of the plotting area, off the data (they sat on it at
    // t ≈ 510–590 s): every legend label starts right of the x axis's end
    let axis_end = svg
        .split("points=\"")
        .skip(1)
        .filter_map(|p| {
            let pts: Vec<(i64, i64)> = p[..p.find('"').unwrap()]
                .split_whitespace()
                .filter_map(|xy| xy.split_once(','))
                .map(|(x, y)| (x.parse().unwrap(), y.parse().unwrap()))
                .collect();
            // the x axis: one horizontal segment
            (pts.len() == 2 && pts[0].1 == pts[1].1 && pts[1].0 - pts[0].0 > 500)
                .then_some(pts[1].0)
        })
        .max()
        .expect("an x axis");
    let label_x = |label: &str| -> Vec<i64> {
        let lines: Vec<&str> = svg.lines().collect();
        (1..lines.len())
            .filter(|&i| lines[i].trim() == label)
            .map(|i| {
                let tag = lines[i - 1];
                let x = &tag[tag.find("x=\"").unwrap() + 3..];
                x[..x.find('"').unwrap()].parse().unwrap()
            })
            .collect()
    };
    for entry in ["error", "±3σ", "smoothed error", "smoothed ±3σ"] {
        for x in label_x(entry) {
            assert!(x > axis_end, "legend `{entry}` at x = {x}, the data end at {axis_end}");
        }
    }
    // the y range from the errors after the skip, not from the initial σ: with --skip 20
    // the north panel's top tick is within 2× the largest north error after 20 s
    let skipped = dir.join("skipped");
    let out = bin()
        .arg("run")
        .arg(dir.join("config.toml"))
        .args(["--quiet", "--plots", "--skip", "20", "--out"])
        .arg(&skipped)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let row = stdout.lines().find(|l| l.starts_with("| fixed")).unwrap();
    let north_rms: f64 = row.split('|').nth(2).unwrap().trim().parse().unwrap();
    let svg = std::fs::read_to_string(skipped.join("errors_position.svg")).unwrap();
    let first_panel = &svg[..svg.find("position error, east").unwrap()];
    let lines: Vec<&str> = first_panel.lines().collect();
    let top_tick = (1..lines.len())
        .filter(|&i| lines[i - 1].contains("text-anchor=\"end\""))
        .filter_map(|i| lines[i].trim().parse::<f64>().ok())
        .fold(f64::NEG_INFINITY, f64::max);
    // (the initial σ is 2 m × 3; the largest error after 20 s a few times the RMS)
    assert!(
        top_tick < 6.0 && top_tick > north_rms,
        "top tick {top_tick} m, north RMS {north_rms} m"
    );
    let plan = std::fs::read_to_string(out_dir.join("trajectory.svg")).unwrap();
    for entry in ["truth", "estimate", "smoothed", "GNSS fixes", "estimate in a GNSS outage"] {
        assert!(plan.lines().any(|l| l.trim() == entry), "no legend entry {entry}");
    }
    // the report: one well-formed page with every plot inline and the configuration
    let html = std::fs::read_to_string(out_dir.join("report.html")).unwrap();
    assert!(html.starts_with("<!DOCTYPE html>"));
    assert_eq!(unbalanced(&html), None);
    assert_eq!(html.matches("<svg").count(), sizes.len());
    for (name, _) in sizes {
        assert!(html.contains(&format!("<figure id=\"{name}\">")), "{name} not in the report");
    }
    for part in ["Consistency", "Errors against the truth", "smoothed", "[data]", "[imu_noise]"] {
        assert!(html.contains(part), "no {part} in the report");
    }
    assert!(!html.contains("src=\"") && !html.contains("href=\"http"), "not self-contained");
    std::fs::remove_dir_all(&dir).unwrap();
}
