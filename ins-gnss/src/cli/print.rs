//! The tables and summaries the subcommands print.

use super::*;

/// Print a run summary.
pub fn print_summary(s: &RunSummary) {
    for line in s.lines() {
        out!("{line}");
    }
}

/// The NEES line of an evaluation against the truth, if its σ file was there.
pub(super) fn print_nees(label: &str, ev: &Evaluation) {
    if let Some(n) = &ev.nees {
        out!("consistency against the truth ({label}): {}", n.line());
    }
}

/// Print a table of statistics, one row per labelled result.
pub fn print_table(rows: &[(&str, &Stats)]) {
    let w = rows.iter().map(|r| r.0.chars().count()).max().unwrap_or(0).max(12);
    out!(
        "| {:w$} | {:>7} | {:>7} | {:>7} | {:>7} | {:>8} | {:>8} | {:>8} | {:>8} | {:>8} |",
        "strategy",
        "N RMS",
        "E RMS",
        "D RMS",
        "horiz",
        "horiz max",
        "3D RMS",
        "vel RMS",
        "roll °",
        "pitch °"
    );
    for (name, s) in rows {
        let [n, e, d, h, hmax, p3, v, roll, pitch, yaw, ymax] = s.table_row();
        out!(
            "| {name:w$} | {n:7.3} | {e:7.3} | {d:7.3} | {h:7.3} | {hmax:8.3} | {p3:8.3} | {v:8.4} | {roll:8.4} | {pitch:8.4} | yaw RMS {yaw:.4}° max {ymax:.3}°"
        );
    }
}

pub(super) fn print_eval(ev: &Evaluation) {
    out!("epochs compared: {} (unmatched {})", ev.overall.epochs, ev.unmatched);
    if let Some(n) = &ev.nees {
        out!("consistency against the truth: {}", n.line());
    }
    if !ev.windows.is_empty() {
        out!(
            "windows: RMS over windows of the maximum horizontal error {:.3} m, vertical {:.3} m",
            ev.windows_rms_of_max_horizontal,
            ev.windows_rms_of_max_vertical
        );
    }
    let mut rows: Vec<(&str, &Stats)> = vec![(ev.overall.label.as_str(), &ev.overall)];
    for w in &ev.windows {
        rows.push((w.label.as_str(), w));
    }
    out!(
        "| {:16} | {:>6} | {:>21} | {:>21} | {:>21} | {:>21} |",
        "span",
        "epochs",
        "N rms/max/mean m",
        "E rms/max/mean m",
        "D rms/max/mean m",
        "horiz rms/max m"
    );
    for (label, s) in &rows {
        let f = |x: &crate::eval::Stat| format!("{:.3}/{:.3}/{:+.3}", x.rms, x.max, x.mean);
        out!(
            "| {:16} | {:6} | {:>21} | {:>21} | {:>21} | {:>21} |",
            label,
            s.epochs,
            f(&s.north),
            f(&s.east),
            f(&s.down),
            format!("{:.3}/{:.3}", s.horizontal.rms, s.horizontal.max)
        );
    }
    out!(
        "| {:16} | {:>21} | {:>21} | {:>21} | {:>21} |",
        "span",
        "3D rms/max m",
        "vel 3D rms/max m/s",
        "roll rms/max °",
        "pitch rms/max °"
    );
    for (label, s) in &rows {
        let f = |x: &crate::eval::Stat| format!("{:.4}/{:.4}", x.rms, x.max);
        out!(
            "| {:16} | {:>21} | {:>21} | {:>21} | {:>21} | yaw rms/max {}",
            label,
            f(&s.position_3d),
            f(&s.velocity_3d),
            f(&s.roll),
            f(&s.pitch),
            f(&s.yaw)
        );
    }
}
