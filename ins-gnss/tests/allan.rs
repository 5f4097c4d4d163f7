//! `ins-gnss allan` on the shipped drive-0708: its 12 s static start analysed (white noise
//! per axis, the bias instability declared unobservable in 12 s, the `[imu_noise]` block,
//! an SVG), and the whole drive refused as a moving record.

use std::path::PathBuf;

fn config() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/drive-0708/aided.toml")
}

#[test]
fn the_static_start_gives_white_noise_and_says_what_it_cannot_resolve() {
    let dir = tempfile_dir();
    let svg = dir.join("allan.svg");
    let text = ins_gnss::allan::run(&config(), None, false, Some(12.0), Some(&svg)).unwrap();
    assert!(text.contains("[imu_noise]\narw = ["), "{text}");
    assert!(text.contains("vrw = ["), "{text}");
    assert!(text.contains("# gyro_bias_std: bias instability not observable"), "{text}");
    assert_eq!(text.matches("instability not observable in 0 min").count(), 6, "{text}");
    let plot = std::fs::read_to_string(&svg).unwrap();
    assert!(plot.starts_with("<svg") && plot.contains("gyro Allan deviation"));
    // the white noise of each gyro axis lies below σ·√dt of the samples (vibration at rest
    // adds to the samples' scatter at 100 Hz and averages out over longer clusters), and
    // within a factor of three of it
    let record = ins_gnss::allan::read(&config(), None, false, Some(12.0)).unwrap();
    let fits = ins_gnss::allan::analyse_record(&record).unwrap();
    for (axis, f) in record.axes.iter().zip(&fits) {
        let mean = axis.iter().sum::<f64>() / axis.len() as f64;
        let sd = (axis.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / axis.len() as f64).sqrt();
        let scatter = sd / record.dt.sqrt();
        let white = f.white.expect("white noise resolved in 12 s").value;
        assert!(white <= scatter * 1.05 && white >= scatter / 5.0, "{white} against {scatter}");
    }
}

#[test]
fn a_moving_record_is_refused_with_what_moved() {
    let e = ins_gnss::allan::run(&config(), None, false, Some(120.0), None).unwrap_err();
    assert!(e.contains("the record moves") && e.contains("give a static record"), "{e}");
}

#[test]
fn a_bare_imu_file_needs_its_rate() {
    let imu = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/drive-0708/IMU.txt.zst");
    let e = ins_gnss::allan::run(&imu, None, false, Some(5.0), None).unwrap_err();
    assert!(e.contains("--rate"), "{e}");
    let text = ins_gnss::allan::run(&imu, Some(100.0), false, Some(12.0), None).unwrap();
    assert!(text.contains("arw = ["), "{text}");
}

fn tempfile_dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("ins-gnss-allan-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}
