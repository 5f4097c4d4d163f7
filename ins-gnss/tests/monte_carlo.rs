//! Two independent paths through a simulated scenario agree: the in-memory Monte Carlo
//! run (`MonteCarlo::run`, simulation → filter → evaluation without files) and the
//! program's path (`Scenario::write_dataset` → `run::run` over the files → `evaluate` of
//! `nav.txt` against `truth.nav`). They differ only by the files' printed precision.

use ins_gnss::config::Config;
use ins_gnss::eval::evaluate;
use ins_gnss::scenario::{MonteCarlo, Scenario};

#[test]
fn monte_carlo_run_matches_simulate_then_run() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/iakf-chi-square.toml");
    let mut sc = Scenario::load(&path).unwrap();
    sc.seed = 5;
    let dir = std::env::temp_dir().join(format!("mc-vs-files-{}", std::process::id()));
    sc.write_dataset(&dir).unwrap();
    let mut cfg = Config::load(&dir.join("config.toml")).unwrap();
    // `MonteCarlo::run` reproduces the papers' filters, without the gross-error gate
    cfg.filter.gate.enabled = false;
    let windows = [(400.0, 450.0)];
    for name in ["fixed", "iakf"] {
        let out = dir.join(name);
        let files = ins_gnss::run::run(&cfg, name.parse().unwrap(), &out, None).unwrap();
        let ev_files =
            evaluate(&out.join("nav.txt"), &dir.join("truth.nav"), 30.0, &windows).unwrap();
        let mem = MonteCarlo::new(sc.clone())
            .unwrap()
            .run(5, name.parse().unwrap(), 30.0, &windows, |_, _, _| {})
            .unwrap();
        let (a, b) = (&ev_files.overall, &mem.eval.overall);
        eprintln!(
            "{name}: horizontal RMS files {:.6} memory {:.6}; yaw RMS {:.6} / {:.6}; window max {:.6} / {:.6}",
            a.horizontal.rms,
            b.horizontal.rms,
            a.yaw.rms,
            b.yaw.rms,
            ev_files.windows[0].horizontal.max,
            mem.eval.windows[0].horizontal.max
        );
        assert_eq!(a.epochs, b.epochs);
        assert_eq!(files.accepted, mem.summary.accepted);
        assert_eq!(files.inflated, mem.summary.inflated);
        assert_eq!(files.rejected, mem.summary.rejected);
        for (x, y) in [
            (a.horizontal.rms, b.horizontal.rms),
            (a.down.rms, b.down.rms),
            (a.velocity_3d.rms, b.velocity_3d.rms),
            (a.yaw.rms, b.yaw.rms),
            (a.roll.max, b.roll.max),
            (ev_files.windows[0].horizontal.max, mem.eval.windows[0].horizontal.max),
        ] {
            assert!((x - y).abs() <= 1e-4 * x.abs().max(1e-3), "{name}: {x} vs {y}");
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}
