//! The raw-observation simulator against the single point that inverts its model: a RINEX
//! round trip, the single point's error against the truth and its covariance (NEES) over
//! seeds, the receiver clock recovered, RAIM against simulated multipath, sky masks.

use gnss::spp::{single_point, SppOptions};
use gnss::{read_nav, GpsTime, NavData, ObsReader};
use ins_gnss_sim::raw::{simulate_raw, write_rinex_obs, RawSim, SkyMask};
use ins_gnss_sim::scenarios::drive_600s;
use ins_gnss_sim::Trajectory;
use std::path::Path;

fn nav() -> NavData {
    read_nav(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/rinex-rtklib/07590920.05n.zst"))
        .unwrap()
}

fn drive() -> Trajectory {
    let (start, segs) = drive_600s();
    Trajectory::new(start, &segs).unwrap()
}

/// 2005-04-02 03:00 GPST: inside the shipped navigation file's day.
fn start() -> GpsTime {
    GpsTime::from_calendar(2005, 4, 2, 3, 0, 0.0)
}

#[test]
fn rinex_round_trip_keeps_every_observation() {
    let nav = nav();
    let traj = drive();
    let sim = RawSim { slip_probability: 0.01, ..RawSim::spp_budget(start()) };
    let (epochs, _) = simulate_raw(&traj, &nav.ephemerides, &nav.klobuchar.unwrap(), &sim, 1);
    let dir = std::env::temp_dir().join(format!("raw-sim-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("sim.obs");
    let mut f = std::io::BufWriter::new(std::fs::File::create(&p).unwrap());
    write_rinex_obs(&mut f, &epochs, None).unwrap();
    drop(f);
    let back: Vec<_> = ObsReader::open(&p).unwrap().map(Result::unwrap).collect();
    assert_eq!(back.len(), epochs.len());
    let mut slips = 0;
    for (a, b) in epochs.iter().zip(&back) {
        assert!((a.time.diff(&b.time)).abs() < 1e-7);
        assert_eq!(a.sats.len(), b.sats.len());
        for (x, y) in a.sats.iter().zip(&b.sats) {
            assert_eq!(x.sat, y.sat);
            for (s, r) in x.signals.iter().zip(&y.signals) {
                for (u, v) in
                    [(s.code, r.code), (s.phase, r.phase), (s.doppler, r.doppler), (s.cn0, r.cn0)]
                {
                    assert!((u.unwrap() - v.unwrap()).abs() <= 5e-4, "{} {u:?} {v:?}", x.sat);
                }
                assert_eq!(s.lli, r.lli);
                slips += s.lli as usize;
            }
        }
    }
    assert!(slips > 0);
    let _ = std::fs::remove_dir_all(&dir);
}

/// 20 seeds of the 600 s drive at 1 Hz, errors drawn from the single point's own budget:
/// the position error's NEES averages to its 3 degrees of freedom, and the clock is found.
#[test]
fn single_point_on_simulated_observations_is_consistent_over_seeds() {
    let nav = nav();
    let kb = nav.klobuchar.unwrap();
    let traj = drive();
    let opt = SppOptions::default();
    let (mut nees_sum, mut n, mut worst_clock, mut solved, mut epochs_all) =
        (0.0, 0usize, 0.0f64, 0, 0);
    let mut per_seed = Vec::new();
    for seed in 0..20u64 {
        let sim = RawSim::spp_budget(start());
        let (epochs, truth) = simulate_raw(&traj, &nav.ephemerides, &kb, &sim, 100 + seed);
        let (mut s_sum, mut s_n) = (0.0, 0usize);
        for e in &epochs {
            epochs_all += 1;
            let tr = truth[e.line];
            let Ok(s) = single_point(e, &nav.ephemerides, Some(&kb), &opt, None) else { continue };
            solved += 1;
            let d = s.pos - tr.antenna;
            let nees = d.dot(&(s.cov.try_inverse().unwrap() * d));
            s_sum += nees;
            s_n += 1;
            worst_clock = worst_clock.max((s.clocks[0].1 - tr.clock.0).abs());
        }
        per_seed.push(s_sum / s_n as f64);
        nees_sum += s_sum;
        n += s_n;
    }
    let mean = nees_sum / n as f64;
    eprintln!(
        "{solved}/{epochs_all} solved; NEES mean {mean:.2} (3 expected); per seed {per_seed:.2?}; worst clock error {worst_clock:.1} m"
    );
    assert!(solved as f64 > 0.95 * epochs_all as f64);
    // the errors are constant per satellite and run, so epochs of a run are not
    // independent: the band is that of 20 runs' means (3 dof each), widened for the rest
    assert!((2.0..4.0).contains(&mean), "{mean}");
    assert!(worst_clock < 50.0, "{worst_clock}");
}

/// Errors (m) of the single points of a simulated run, and the RAIM exclusions.
fn spp_errors(
    sim: &RawSim,
    seed: u64,
) -> (Vec<f64>, usize, Vec<gnss::ObsEpoch>, Vec<ins_gnss_sim::raw::RawTruth>) {
    let nav = nav();
    let kb = nav.klobuchar.unwrap();
    let (epochs, truth) = simulate_raw(&drive(), &nav.ephemerides, &kb, sim, seed);
    let opt = SppOptions::default();
    let mut excluded = 0;
    let mut errors = Vec::new();
    for e in &epochs {
        let Ok(s) = single_point(e, &nav.ephemerides, Some(&kb), &opt, None) else { continue };
        excluded += s.excluded.len();
        errors.push((s.pos - truth[e.line].antenna).norm());
    }
    (errors, excluded, epochs, truth)
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// A canyon leaves 3 satellites (no single point: 4 unknowns), a tunnel none; multipath
/// outliers of 30–100 m on 5 % of the codes are excluded by RAIM or refused, and the
/// fixes that remain keep the clean run's accuracy.
#[test]
fn masks_and_multipath() {
    let masks = vec![
        SkyMask { start: 100.0, end: 160.0, keep: 3 },
        SkyMask { start: 300.0, end: 320.0, keep: 0 },
    ];
    let clean = RawSim { masks: masks.clone(), ..RawSim::spp_budget(start()) };
    let dirty = RawSim { outliers: (0.05, (30.0, 100.0)), ..clean.clone() };
    // seeds 7–11: the decisions (RAIM's exclusions and refusals) as rates over them
    for seed in 7..12u64 {
        let (mut ok, _, epochs, truth) = spp_errors(&clean, seed);
        let in_canyon: Vec<_> =
            epochs.iter().filter(|e| (100.0..160.0).contains(&truth[e.line].t)).collect();
        assert_eq!(in_canyon.len(), 60);
        assert!(in_canyon.iter().all(|e| e.sats.len() == 3));
        assert!(
            !epochs.iter().any(|e| (300.0..320.0).contains(&truth[e.line].t)),
            "a tunnel has no epochs"
        );
        let (mut bad, excluded, _, _) = spp_errors(&dirty, seed);
        let big = bad.iter().filter(|e| **e > 30.0).count();
        let (m_ok, m_bad) = (median(&mut ok), median(&mut bad));
        eprintln!(
            "seed {seed}: clean: {} fixes, median {m_ok:.2} m; 5 % outliers: {} fixes, {excluded} exclusions, {big} beyond 30 m, median {m_bad:.2} m",
            ok.len(),
            bad.len()
        );
        assert!(excluded > 20, "seed {seed}: {excluded}");
        assert!(big as f64 <= 0.02 * bad.len() as f64, "seed {seed}: {big}");
        assert!(m_bad <= 1.15 * m_ok, "seed {seed}: {m_bad} against {m_ok}");
    }
}
