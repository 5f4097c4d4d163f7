//! `report.html`: one run in one self-contained file — the summary and consistency
//! verdict, the error tables against the truth, the plots inline (SVG), and the
//! configuration used (TOML). No script, no external file: it opens offline in any
//! browser and can be mailed as it is.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use crate::config::Config;
use crate::eval::{Evaluation, Stats};
use crate::run::RunSummary;

/// Text made safe for HTML.
pub(crate) fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            _ => out.push(c),
        }
    }
    out
}

/// One table row of statistics.
fn row(out: &mut String, label: &str, s: &Stats) {
    let _ = write!(out, "<tr><td>{}</td><td>{}</td>", escape(label), s.epochs);
    for v in s.table_row() {
        let _ = write!(out, "<td>{v:.3}</td>");
    }
    out.push_str("</tr>\n");
}

const HEADER: &str = "<tr><th>result</th><th>epochs</th><th>N RMS m</th><th>E RMS m</th>\
<th>D RMS m</th><th>horizontal RMS m</th><th>horizontal max m</th><th>3D RMS m</th>\
<th>velocity 3D RMS m/s</th><th>roll RMS °</th><th>pitch RMS °</th><th>yaw RMS °</th>\
<th>yaw max °</th></tr>\n";

/// An SVG file's markup, for inlining (its XML declaration dropped).
pub(crate) fn inline_svg(path: &Path) -> Result<String, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let start = text.find("<svg").ok_or_else(|| format!("{}: not an SVG", path.display()))?;
    Ok(text[start..].to_string())
}

/// The tables of the errors against the truth and, where the results carry σ, their
/// consistency (NEES) per block.
fn truth_tables(h: &mut String, tables: &[(String, Evaluation)]) {
    h.push_str("<h2>Errors against the truth</h2>\n<table>\n");
    h.push_str(HEADER);
    for (label, ev) in tables {
        row(h, &format!("{label} ({})", ev.overall.label), &ev.overall);
        for w in &ev.windows {
            row(h, &format!("{label} ({})", w.label), w);
        }
    }
    h.push_str("</table>\n");
    let nees: Vec<_> =
        tables.iter().filter_map(|(l, ev)| ev.nees.as_ref().map(|n| (l, n))).collect();
    if !nees.is_empty() {
        h.push_str("<h2>Consistency against the truth (NEES)</h2>\n<table>\n");
        h.push_str(
            "<tr><th>result</th><th>block</th><th>epochs</th><th>NEES/dof (1)</th>\
             <th>beyond χ²<sub>0.99</sub> (1 %, at most 5 %)</th><th>verdict</th></tr>\n",
        );
        for (label, n) in nees {
            for (block, b) in n.blocks() {
                let ok = b.consistent() == Some(true);
                let _ = writeln!(
                    h,
                    "<tr><td>{}</td><td>{block}</td><td>{}</td><td>{:.2}</td><td>{:.1} %</td><td>{}</td></tr>",
                    escape(label),
                    b.epochs,
                    b.mean_per_dof,
                    100.0 * b.beyond_99,
                    if ok { "consistent" } else { "<b>NOT consistent</b>" }
                );
            }
        }
        h.push_str("</table>\n");
    }
}

/// A report's beginning: the document's head with its style, the body and the title.
pub(crate) fn head(title: &str) -> String {
    let mut h = String::new();
    h.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n");
    let _ = writeln!(h, "<title>{}</title>", escape(title));
    h.push_str(
        "<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;padding:0 1em}\
         table{border-collapse:collapse;font-size:90%}td,th{border:1px solid #bbb;\
         padding:3px 6px;text-align:right}td:first-child{text-align:left}\
         pre{background:#f4f4f4;padding:1em;overflow-x:auto}.bad{color:#b00}\
         svg{max-width:100%;height:auto}</style>\n</head>\n<body>\n",
    );
    let _ = writeln!(h, "<h1>{}</h1>", escape(title));
    h
}

/// Write `out_dir/report.html` (through a `.partial` file, renamed when complete).
pub fn write(
    out_dir: &Path,
    summary: &RunSummary,
    config: &Config,
    tables: &[(String, Evaluation)],
    plots: &[PathBuf],
) -> Result<PathBuf, String> {
    let mut h = head(&format!("ins-gnss run: {}", summary.strategy));
    h.push_str("<h2>Summary</h2>\n<ul>\n");
    for line in summary.lines() {
        let _ = writeln!(h, "<li>{}</li>", escape(&line));
    }
    h.push_str("</ul>\n<h2>Consistency</h2>\n");
    match summary.consistency() {
        Some(c) => {
            let class = if c.consistent() { "" } else { " class=\"bad\"" };
            let _ = writeln!(h, "<p{class}>{}</p>", escape(&c.verdict()));
        }
        None => h.push_str("<p>No accepted update to judge by.</p>\n"),
    }
    // every innovation of each stream, before adaptation
    for st in &summary.streams {
        let follows = summary.follows(st);
        let (mean, (_, hi)) = st.mean_nis();
        let fine = st.consistent() || (follows && mean <= hi);
        let class = if fine { "" } else { " class=\"bad\"" };
        let _ = writeln!(h, "<p{class}>{}</p>", escape(&st.verdict_of(follows)));
        if let Some(a) = st.adaptation() {
            let _ = writeln!(h, "<p>{}</p>", escape(&a));
        }
    }
    if let Some(rtk) = &summary.rtk {
        fix_table(&mut h, &rtk.metrics);
    }
    if !tables.is_empty() {
        truth_tables(&mut h, tables);
    }
    if !plots.is_empty() {
        h.push_str("<h2>Plots</h2>\n");
        for p in plots {
            let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("plot");
            let _ = writeln!(h, "<figure id=\"{}\">", escape(name));
            h.push_str(&inline_svg(p)?);
            let _ = writeln!(h, "\n<figcaption>{}</figcaption>\n</figure>", escape(name));
        }
    }
    h.push_str("<h2>Configuration</h2>\n<pre>");
    let toml = toml::to_string_pretty(config).map_err(|e| format!("configuration: {e}"))?;
    h.push_str(&escape(&toml));
    h.push_str("</pre>\n</body>\n</html>\n");
    let path = out_dir.join("report.html");
    ins_gnss_io::formats::write_published(&path, h)?;
    Ok(path)
}

/// An RTK run's fix metrics as a table (`ins-gnss rtk --report`, and a run's report with
/// `gnss.coupling = "rtk"`): fix rate, time to first fix, the outages of the fix and the
/// longest time to fix again, the ratio's statistics, the epochs unsolved and why.
pub fn fix_table(h: &mut String, m: &gnss::rtk::RtkMetrics) {
    h.push_str("<h2>The fix (RTK)</h2>\n<table>\n");
    let none = |v: Option<f64>| v.map_or("—".to_string(), |t| format!("{t:.1}"));
    let longest = m.refix_times.iter().copied().reduce(f64::max);
    let rows: [(&str, String); 10] = [
        ("rover epochs", m.epochs.to_string()),
        ("solved", m.solved.to_string()),
        ("fixed", m.fixed.to_string()),
        ("fix rate", format!("{:.1} %", 100.0 * m.fix_rate)),
        ("time to first fix, s", none(m.time_to_first_fix)),
        ("outages of the fix", m.refix_times.len().to_string()),
        ("longest time to fix again, s", none(longest)),
        ("ratio of the fixed epochs: min, median", ratio_pair(m.ratio_fixed)),
        ("ratio of the others: min, median", ratio_pair(m.ratio_other)),
        ("epochs unsolved", gnss::rtk::reasons_text(&m.failures)),
    ];
    for (label, value) in rows {
        let _ = writeln!(h, "<tr><td>{label}</td><td>{}</td></tr>", escape(&value));
    }
    h.push_str("</table>\n");
}

/// (minimum, median) of the ratio as text ("—": none).
fn ratio_pair((min, median): (f64, f64)) -> String {
    if min.is_nan() {
        "—".into()
    } else {
        format!("{min:.1}, {median:.1}")
    }
}
