//! IMU noise as datasheets state it: a bias random walk given directly (deg/h/√h or
//! rad/s/√s) is the same filter as the instability and correlation time it corresponds
//! to (`q = σ √(2/τ)`); ambiguous or contradictory settings are refused with their keys;
//! the run summary echoes the SI densities used.

use std::path::{Path, PathBuf};

use ins_gnss::config::Config;

fn example() -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("config.example.toml"))
        .unwrap()
}

fn load(text: &str, name: &str) -> Result<Config, String> {
    let dir = std::env::temp_dir().join(format!("estimator-noise-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p: PathBuf = dir.join(format!("{name}.toml"));
    std::fs::write(&p, text).unwrap();
    Config::load(&p).map_err(|e| e.to_string())
}

/// The example's `[imu_noise]` bias lines replaced by `lines`.
fn with_bias(lines: &str) -> String {
    let text = example();
    let keep: Vec<&str> = text
        .lines()
        .filter(|l| {
            !(l.starts_with("gyro_bias_std = [10")
                || l.starts_with("accel_bias_std = [100")
                || l.starts_with("corr_time"))
        })
        .collect();
    keep.join("\n").replace("[imu_noise]\n", &format!("[imu_noise]\n{lines}\n"))
}

#[test]
fn a_random_walk_given_directly_equals_the_instability_it_corresponds_to() {
    let base = load(&example(), "base").unwrap();
    let n = base.imu_noise();
    // the example: 10 deg/h and 100 mGal with τ = 1 h; its random walk q = σ √(2/τ)
    let tau_h: f64 = 1.0;
    let q_deg_h_sqrt_h = 10.0 * (2.0 / tau_h).sqrt();
    let q_mgal_sqrt_h = 100.0 * (2.0 / tau_h).sqrt();
    let rw = load(
        &with_bias(&format!(
            "gyro_bias_rw = [{q_deg_h_sqrt_h}, {q_deg_h_sqrt_h}, {q_deg_h_sqrt_h}]\n\
             accel_bias_rw = [{q_mgal_sqrt_h}, {q_mgal_sqrt_h}, {q_mgal_sqrt_h}]"
        )),
        "rw",
    )
    .unwrap()
    .imu_noise();
    let g_si = n.gyro_bias.x;
    let a_si = n.accel_bias.x;
    let si = load(
        &with_bias(&format!(
            "gyro_bias_rw_si = [{g_si:e}, {g_si:e}, {g_si:e}]\n\
             accel_bias_rw_si = [{a_si:e}, {a_si:e}, {a_si:e}]"
        )),
        "si",
    )
    .unwrap()
    .imu_noise();
    for other in [&rw, &si] {
        assert_eq!(other.bias_model, n.bias_model);
        assert!((other.gyro_bias - n.gyro_bias).norm() <= 1e-12 * n.gyro_bias.norm());
        assert!((other.accel_bias - n.accel_bias).norm() <= 1e-12 * n.accel_bias.norm());
        assert_eq!(other.arw, n.arw);
    }
    // the echo shows the densities in SI
    let echo = ins_gnss::config::noise_echo(&base.imu_noise());
    assert!(echo.contains("rad/s/√s") && echo.contains(&format!("{g_si:.3e}")), "{echo}");
}

#[test]
fn ambiguous_or_contradictory_bias_noise_is_refused_with_its_keys() {
    let both = with_bias(
        "gyro_bias_std = [10.0, 10.0, 10.0]\ncorr_time = 1.0\ngyro_bias_rw = [1.0, 1.0, 1.0]\n\
         accel_bias_std = [100.0, 100.0, 100.0]",
    );
    let e = load(&both, "both").unwrap_err();
    assert!(e.contains("imu_noise.gyro_bias_std") && e.contains("imu_noise.gyro_bias_rw"), "{e}");
    let gm = with_bias(
        "gyro_bias_rw = [1.0, 1.0, 1.0]\naccel_bias_rw = [1.0, 1.0, 1.0]\nbias_model = \"gauss-markov\"",
    );
    let e = load(&gm, "gm").unwrap_err();
    assert!(e.contains("random walk") && e.contains("random-walk"), "{e}");
    let no_tau = with_bias("gyro_bias_std = [10.0, 10.0, 10.0]\naccel_bias_rw = [1.0, 1.0, 1.0]");
    let e = load(&no_tau, "notau").unwrap_err();
    assert!(e.contains("imu_noise.corr_time"), "{e}");
    let none = with_bias("accel_bias_rw = [1.0, 1.0, 1.0]");
    let e = load(&none, "none").unwrap_err();
    assert!(e.contains("missing `imu_noise.gyro_bias_std`"), "{e}");
    // mixed: gyro as a random walk, accelerometer as instability + τ, is fine
    let mixed = with_bias(
        "gyro_bias_rw = [1.0, 1.0, 1.0]\naccel_bias_std = [100.0, 100.0, 100.0]\ncorr_time = 1.0",
    );
    assert!(load(&mixed, "mixed").is_ok());
}
