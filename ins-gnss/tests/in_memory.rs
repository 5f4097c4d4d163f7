//! `run_in_memory` on arrays against `run` on the files (drive-0708 as shipped, smoothed):
//! the navigation rows written by the files' writer are the files' bytes, the smoothed
//! ones too, and every update's NIS and verdict is the same — the arrays path, the rows
//! reader and the in-memory sink change nothing. Row errors name the array and row.

use std::path::Path;
use std::sync::Arc;

use ins_gnss::config::Config;
use ins_gnss::run::{run, run_in_memory, Inputs, Results};
use ins_gnss_io::fixed::push_row;
use ins_gnss_io::formats::open;
use ins_gnss_io::lines::NumericLines;

use crate::sample_data;

/// A numeric text file's rows and their width.
fn rows(path: &Path) -> (Arc<[f64]>, usize) {
    let mut lines = NumericLines::new(open(path).unwrap(), path);
    let (mut all, mut width) = (Vec::new(), 0);
    while let Some(r) = lines.next_record().unwrap() {
        width = r.len();
        all.extend_from_slice(r);
    }
    (all.into(), width)
}

/// Navigation rows (`t`, lat, lon in degrees, …) in the text of `nav.txt` (the week 0,
/// then the decimals of `write_nav`).
fn nav_text(rows: &[[f64; 10]]) -> Vec<u8> {
    const DECIMALS: [usize; 10] = [6, 10, 10, 4, 5, 5, 5, 8, 8, 8];
    let mut out = Vec::new();
    for r in rows {
        let mut row = vec![(0.0, 0)];
        row.extend(r.iter().zip(DECIMALS).map(|(v, d)| (*v, d)));
        push_row(&mut out, &row);
    }
    out
}

#[test]
fn arrays_in_memory_give_the_files_results() {
    let dir = sample_data::dir(env!("CARGO_MANIFEST_DIR"), "drive-0708");
    let mut cfg = Config::load(&dir.join("kf-gins-outage15.yaml")).unwrap();
    cfg.filter.smooth = true;
    let out = std::env::temp_dir().join(format!("estimator-in-memory-{}", std::process::id()));
    let files = run(&cfg, "fixed".parse().unwrap(), &out, None).unwrap();
    let ((imu, imu_width), (gnss, gnss_width)) = (rows(&cfg.data.imu), rows(&cfg.data.gnss));
    let inputs = Inputs::Arrays { imu, imu_width, gnss, gnss_width };
    let (summary, results): (_, Results) =
        run_in_memory(&cfg, "fixed".parse().unwrap(), &inputs).unwrap();
    assert_eq!(summary.imu_epochs, files.imu_epochs);
    assert_eq!((summary.accepted, summary.rejected), (files.accepted, files.rejected));
    assert_eq!(summary.nis_sum.to_bits(), files.nis_sum.to_bits());
    // (the week column is 0 in both)
    let text = std::fs::read(out.join("nav.txt")).unwrap();
    assert!(nav_text(&results.nav) == text, "nav.txt differs");
    let smoothed = std::fs::read(out.join("nav_smoothed.txt")).unwrap();
    assert!(nav_text(&results.smoothed_nav) == smoothed, "nav_smoothed.txt differs");
    let csv = std::fs::read_to_string(out.join("updates.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(lines.len(), results.updates.len());
    for (line, u) in lines.iter().zip(&results.updates) {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(
            (f[1], f[3], f[5]),
            (u.stream.name(), &*format!("{:.6}", u.nis), u.verdict.as_str())
        );
    }
    let widths = (results.std_width, results.imu_errors_width);
    assert_eq!(widths, (16, 7));
    let std_rows = std::fs::read_to_string(out.join("std.txt")).unwrap().lines().count();
    assert_eq!(std_rows * results.std_width, results.std.len());
    let _ = std::fs::remove_dir_all(&out);
    eprintln!(
        "drive-0708 smoothed: {} rows, {} updates: arrays in memory = files, byte for byte",
        results.nav.len(),
        results.updates.len()
    );
}

#[test]
fn a_bad_row_is_named_by_array_and_row() {
    let dir = sample_data::dir(env!("CARGO_MANIFEST_DIR"), "drive-0708");
    let cfg = Config::load(&dir.join("kf-gins-outage15.yaml")).unwrap();
    let ((imu, imu_width), (gnss, gnss_width)) = (rows(&cfg.data.imu), rows(&cfg.data.gnss));
    let mut bad: Vec<f64> = imu[..imu_width * 3000].to_vec();
    bad[imu_width * 41 + 2] = f64::NAN; // row 42, column 3
    let inputs = Inputs::Arrays { imu: bad.into(), imu_width, gnss, gnss_width };
    let e = run_in_memory(&cfg, "fixed".parse().unwrap(), &inputs).unwrap_err().to_string();
    assert!(e.contains("imu array row:42: column 3 is NaN or infinite"), "{e}");
}
