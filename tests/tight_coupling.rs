//! Tight coupling on simulated raw observations (satellites of the shipped navigation
//! file, a 600 s car drive, a consumer MEMS IMU): Jacobians of the satellite models, tight
//! against loose coupling (the single point's fixes), an urban canyon, multipath outliers
//! and the filter's consistency over seeds.

use adaptive::GrossErrorGate;
use estimator_core::{
    FixedNoise, Manifold, NoObserver, NoiseStrategy, SegmentSmoother, StepRecorder,
};
use gnss::spp::{prepare, single_point, Ionosphere, SppOptions};
use gnss::{read_nav, GpsTime, NavData, ObsEpoch};
use ins_gnss_core::navigator::{ClockInit, RawEpoch, TightConfig};
use ins_gnss_core::tight::{ClockNoise, InsModelTc, InsStateTc, Pseudorange, RangeRate};
use ins_gnss_core::{
    GeoPos, GnssConfig, GnssEpoch, ImuInput, InitialState, InitialStd, InsModel, Navigator,
};
use ins_gnss_sim::raw::{simulate_raw, RawSim, SkyMask};
use ins_gnss_sim::{scenarios, simulate, GnssSim, SimDataset, Trajectory};
use nalgebra::{Matrix3, Vector3};
use std::path::Path;

fn nav() -> NavData {
    read_nav(&Path::new(env!("CARGO_MANIFEST_DIR")).join("data/rinex-rtklib/07590920.05n.zst"))
        .unwrap()
}

fn start() -> GpsTime {
    GpsTime::from_calendar(2005, 4, 2, 3, 0, 0.0)
}

const LEVER: Vector3<f64> = Vector3::new(0.4, 0.1, -1.2);

struct Case {
    data: SimDataset,
    epochs: Vec<ObsEpoch>,
}

/// The built-in 600 s drive, one for the file's cases: its exact IMU is integrated once
/// ([`Trajectory::exact_imu`]) and each seed draws only its errors.
static DRIVE: std::sync::LazyLock<Trajectory> = std::sync::LazyLock::new(|| {
    let (s, segs) = scenarios::drive_600s();
    Trajectory::new(s, &segs).unwrap()
});

fn case(sim: &RawSim, seed: u64) -> Case {
    let traj = &*DRIVE;
    let none = GnssSim::none();
    let data = simulate(traj, 100.0, &scenarios::mems_imu(), &none, seed);
    let nav = nav();
    let sim = RawSim { lever_arm: LEVER, ..sim.clone() };
    let (epochs, _) = simulate_raw(traj, &nav.ephemerides, &nav.klobuchar.unwrap(), &sim, seed);
    Case { data, epochs }
}

fn init(data: &SimDataset) -> InitialState {
    let deg = core::f64::consts::PI / 180.0;
    let t0 = &data.truth[0];
    InitialState {
        time: t0.t,
        state: t0.state.clone(),
        std: InitialStd {
            att: Vector3::new(0.5 * deg, 0.5 * deg, 2.0 * deg),
            vel: Vector3::repeat(0.1),
            pos: Vector3::repeat(3.0),
            bg: Vector3::repeat(50.0 / 3600.0 * deg),
            ba: Vector3::repeat(5e-3),
        },
    }
}

/// Horizontal errors (m) at each raw epoch with its time, and the position NEES.
struct Track {
    t: Vec<f64>,
    horizontal: Vec<f64>,
    nees: Vec<f64>,
}

impl Track {
    fn rms_after(&self, t0: f64) -> f64 {
        let v: Vec<f64> = self
            .t
            .iter()
            .zip(&self.horizontal)
            .filter(|(t, _)| **t >= t0)
            .map(|(_, h)| h * h)
            .collect();
        (v.iter().sum::<f64>() / v.len() as f64).sqrt()
    }
    fn max_in(&self, a: f64, b: f64) -> f64 {
        self.t
            .iter()
            .zip(&self.horizontal)
            .filter(|(t, _)| (a..b).contains(*t))
            .map(|(_, h)| *h)
            .fold(0.0, f64::max)
    }
    fn nees_after(&self, t0: f64) -> (f64, usize) {
        let v: Vec<f64> =
            self.t.iter().zip(&self.nees).filter(|(t, _)| **t >= t0).map(|(_, n)| *n).collect();
        (v.iter().sum::<f64>(), v.len())
    }
}

fn record(track: &mut Track, t: f64, est: &GeoPos, p_pos: &Matrix3<f64>, truth: &GeoPos) {
    let e = truth.ominus(est);
    track.t.push(t);
    track.horizontal.push((e.x * e.x + e.y * e.y).sqrt());
    track.nees.push(e.dot(&(p_pos.try_inverse().unwrap() * e)));
}

/// The navigator time of an epoch: its receiver stamp on the IMU's clock.
fn epoch_time(e: &ObsEpoch, data: &SimDataset) -> f64 {
    data.truth[0].t + e.time.diff(&start())
}

fn truth_at(data: &SimDataset, t: f64) -> GeoPos {
    // IMU at 100 Hz: the truth record at or just before t
    let i = data.truth.partition_point(|r| r.t <= t + 1e-9).saturating_sub(1);
    data.truth[i].state.pos
}

fn run_tight<A: NoiseStrategy>(c: &Case, strategy: A, doppler: bool) -> Track {
    run_tight_opt(c, strategy, doppler, &SppOptions::default(), ClockNoise::default().drift)
}

fn run_tight_opt<A: NoiseStrategy>(
    c: &Case,
    strategy: A,
    doppler: bool,
    opt: &SppOptions,
    drift: f64,
) -> Track {
    run_tight_recorded(c, strategy, doppler, opt, drift, &mut ()).0
}

/// The tight run with `recorder` told of every step and update, and the navigator at the end.
fn run_tight_recorded<A: NoiseStrategy, R: StepRecorder<InsStateTc, ImuInput>>(
    c: &Case,
    strategy: A,
    doppler: bool,
    opt: &SppOptions,
    drift: f64,
    recorder: &mut R,
) -> (Track, Navigator<A, InsStateTc>) {
    let nav = nav();
    let opt = opt.clone();
    let kb = nav.klobuchar.unwrap();
    // the clock from the first epoch's single point
    let first = single_point(&c.epochs[0], &nav.ephemerides, Some(&kb), &opt, None).unwrap();
    let clock = ClockInit { clock: (first.clocks[0].1, 0.0), std: (10.0, 2.0), isb_std: 10.0 };
    let model = InsModelTc {
        base: InsModel::wgs84(scenarios::mems_imu().noise),
        clock: ClockNoise { drift, ..ClockNoise::default() },
    };
    let cfg = GnssConfig { lever_arm: LEVER, ..GnssConfig::default() };
    let mut n = Navigator::new((&init(&c.data), &clock), model, strategy, cfg).unwrap();
    let tight = TightConfig {
        models: opt.clone(),
        klobuchar: kb,
        use_doppler: doppler,
        error_floor: false,
        carrier: false,
        phase_std: 0.003,
    };
    let raw: Vec<RawEpoch> = c
        .epochs
        .iter()
        .map(|e| RawEpoch {
            t: epoch_time(e, &c.data),
            time: e.time,
            sats: prepare(e, &nav.ephemerides, &opt).0,
            heading: None,
        })
        .collect();
    let mut track = Track { t: vec![], horizontal: vec![], nees: vec![] };
    let (mut k, mut out) = (0, Vec::new());
    for s in &c.data.imu {
        let first = k;
        while k < raw.len() && raw[k].t <= s.t + 1e-9 {
            k += 1;
        }
        out.clear();
        n.process_raw_recorded(s, &raw[first..k], &tight, &mut NoObserver, &mut out, recorder)
            .unwrap();
        if k > first {
            let x: &InsStateTc = n.state();
            let p = n.covariance().fixed_view::<3, 3>(6, 6).into_owned();
            record(&mut track, s.t, &x.nav.pos, &p, &truth_at(&c.data, s.t));
        }
    }
    (track, n)
}

fn run_loose(c: &Case) -> Track {
    run_loose_opt(c, &SppOptions::default())
}

fn run_loose_opt(c: &Case, opt: &SppOptions) -> Track {
    let nav = nav();
    let opt = opt.clone();
    let kb = nav.klobuchar.unwrap();
    let fixes: Vec<GnssEpoch> = c
        .epochs
        .iter()
        .filter_map(|e| {
            // the Dopplers' velocity too, as a receiver's fix carries it
            let s = single_point(e, &nav.ephemerides, Some(&kb), &opt, None).ok()?;
            Some(GnssEpoch::from_single_point(&s, epoch_time(e, &c.data)))
        })
        .collect();
    let cfg = GnssConfig { lever_arm: LEVER, ..GnssConfig::default() };
    let mut n = Navigator::new(
        &init(&c.data),
        InsModel::wgs84(scenarios::mems_imu().noise),
        FixedNoise,
        cfg,
    )
    .unwrap();
    let mut track = Track { t: vec![], horizontal: vec![], nees: vec![] };
    let (mut k, mut out) = (0, Vec::new());
    // the track is sampled at every raw epoch (as the tight one), fix or not
    let times: Vec<f64> = c.epochs.iter().map(|e| epoch_time(e, &c.data)).collect();
    let mut j = 0;
    for s in &c.data.imu {
        let first = k;
        while k < fixes.len() && fixes[k].t <= s.t + 1e-9 {
            k += 1;
        }
        out.clear();
        n.process_into(s, &fixes[first..k], &mut NoObserver, &mut out).unwrap();
        let mut sampled = false;
        while j < times.len() && times[j] <= s.t + 1e-9 {
            j += 1;
            sampled = true;
        }
        if sampled {
            let p = n.covariance().fixed_view::<3, 3>(6, 6).into_owned();
            record(&mut track, s.t, &n.nav_state().pos, &p, &truth_at(&c.data, s.t));
        }
    }
    track
}

fn gate() -> GrossErrorGate<FixedNoise> {
    GrossErrorGate::new(FixedNoise, 1e-6, 20)
}

#[test]
fn satellite_jacobians_match_differences_through_oplus() {
    let nav = nav();
    let c = case(&RawSim::spp_budget(start()), 3);
    let e = &c.epochs[150];
    let (sats, _) = prepare(e, &nav.ephemerides, &SppOptions::default());
    let t = &c.data.truth[c.data.truth.partition_point(|r| r.t <= epoch_time(e, &c.data))];
    let mut x = InsStateTc {
        nav: t.state.clone(),
        clock: nalgebra::Vector2::new(1234.0, 0.3),
        isb: Vector3::new(1.0, 2.0, 3.0),
    };
    x.nav.bg = Vector3::new(1e-4, -2e-4, 3e-4);
    use estimator_core::MeasurementModel;
    for s in &sats {
        let pr = Pseudorange { sat: s, corrections: 3.0, lever_arm: LEVER };
        let rr = RangeRate { sat: s, lever_arm: LEVER, gyro_rate: Vector3::new(0.1, -0.05, 0.2) };
        let (hp, hr) = (pr.jacobian(&x).H, rr.jacobian(&x).H);
        for k in 0..20 {
            // (steps large enough that 2e7 m ranges keep the difference's digits)
            let h = match k {
                9..=11 => 1e-5,
                _ => 1e-3,
            };
            let mut d = ins_gnss_core::tight::V20::zeros();
            d[k] = h;
            let (xp, xm) = (x.oplus(&d), x.oplus(&(-d)));
            let np = (pr.predict(&xp)[0] - pr.predict(&xm)[0]) / (2.0 * h);
            let nr = (rr.predict(&xp)[0] - rr.predict(&xm)[0]) / (2.0 * h);
            // the Sagnac term's and the Earth rate's state dependence are left out of H
            assert!(
                (np - hp[(0, k)]).abs() < 2e-4 * (1.0 + hp[(0, k)].abs()),
                "{} pr d{k}: {np} vs {}",
                s.sat,
                hp[(0, k)]
            );
            assert!(
                (nr - hr[(0, k)]).abs() < 2e-4 * (1.0 + hr[(0, k)].abs()),
                "{} rr d{k}: {nr} vs {}",
                s.sat,
                hr[(0, k)]
            );
        }
    }
}

/// The 21-state tight state (scale factors): the satellite models through `OnTc` match
/// differences through ⊕ in all 26 directions (zero in the scale factors'), and the
/// process model's `Φ` and its block-wise covariance product match differences and the
/// dense product.
#[test]
fn tight21_jacobians_match_differences_through_oplus() {
    use estimator_core::MeasurementModel;
    use ins_gnss_core::scale::{InsModel21, InsState21, ScaleFactorNoise};
    use ins_gnss_core::tight::{InsModelTc21, InsStateTc21, OnTc};
    let nav = nav();
    let c = case(&RawSim::spp_budget(start()), 3);
    let e = &c.epochs[150];
    let (sats, _) = prepare(e, &nav.ephemerides, &SppOptions::default());
    let k = c.data.truth.partition_point(|r| r.t <= epoch_time(e, &c.data));
    let t = &c.data.truth[k];
    let mut nav21 = InsState21 {
        nav: t.state.clone(),
        sg: Vector3::new(1e-3, -2e-3, 5e-4),
        sa: Vector3::new(-1e-3, 3e-4, 2e-3),
    };
    nav21.nav.bg = Vector3::new(1e-4, -2e-4, 3e-4);
    let x = InsStateTc21 {
        nav: nav21,
        clock: nalgebra::Vector2::new(1234.0, 0.3),
        isb: Vector3::new(1.0, 2.0, 3.0),
    };
    for s in &sats {
        let pr = Pseudorange { sat: s, corrections: 3.0, lever_arm: LEVER };
        let rr = RangeRate { sat: s, lever_arm: LEVER, gyro_rate: Vector3::new(0.1, -0.05, 0.2) };
        let (pr, rr) = (OnTc(&pr), OnTc(&rr));
        let (hp, hr) = (pr.jacobian(&x).H, rr.jacobian(&x).H);
        for k in 0..26 {
            let h = match k {
                9..=11 => 1e-5,
                _ => 1e-3,
            };
            let mut d = nalgebra::SVector::<f64, 26>::zeros();
            d[k] = h;
            let (xp, xm) = (x.oplus(&d), x.oplus(&(-d)));
            let np = (pr.predict(&xp)[0] - pr.predict(&xm)[0]) / (2.0 * h);
            let nr = (rr.predict(&xp)[0] - rr.predict(&xm)[0]) / (2.0 * h);
            assert!((np - hp[(0, k)]).abs() < 2e-4 * (1.0 + hp[(0, k)].abs()), "pr d{k}");
            assert!((nr - hr[(0, k)]).abs() < 2e-4 * (1.0 + hr[(0, k)].abs()), "rr d{k}");
            if (15..21).contains(&k) {
                assert_eq!((hp[(0, k)], hr[(0, k)]), (0.0, 0.0));
            }
        }
    }
    let base = InsModel::wgs84(scenarios::mems_imu().noise);
    let scale = ScaleFactorNoise { gyro: Vector3::repeat(1e-4), accel: Vector3::repeat(1e-4) };
    let model = InsModelTc21 { base: InsModel21 { base, scale }, clock: ClockNoise::default() };
    let u = ImuInput { prev: Some(c.data.imu[k - 1]), cur: c.data.imu[k] };
    let dt = u.cur.dt;
    // Φ: the 21-state model's (checked against one step in ins-gnss/tests/jacobians.rs)
    // and the clock's shear, nothing across
    use estimator_core::ProcessModel;
    let phi = model.jacobians(&x, &u, dt).Phi;
    let phi21 = model.base.jacobians(&x.nav, &u, dt).Phi;
    let mut expected = nalgebra::SMatrix::<f64, 26, 26>::identity();
    expected.fixed_view_mut::<21, 21>(0, 0).copy_from(&phi21);
    expected[(21, 22)] = dt;
    assert_eq!(phi, expected);
    // the block-wise covariance product against the dense one, the combined calls
    estimator_core::harness::check_combined_calls(&model, &x, &u, dt).unwrap();
}

/// A dual-frequency receiver (iono-free codes, broadcast orbits good to 0.5 m) on the
/// drive, seeds 11–14: tight coupling against loose coupling of the same observations
/// (the single point's positions and Doppler velocities), a 60 s canyon that leaves the 3
/// highest satellites (no single point there), and 10 % of the codes with 20–100 m of
/// multipath (the default gate).
#[test]
fn tight_against_loose_canyon_and_multipath() {
    let base = RawSim { ephemeris_std: 0.5, ..RawSim::spp_budget(start()) };
    let canyon =
        RawSim { masks: vec![SkyMask { start: 200.0, end: 260.0, keep: 3 }], ..base.clone() };
    let dirty = RawSim { outliers: (0.10, (20.0, 100.0)), ..base.clone() };
    let opt = SppOptions { ionosphere: Ionosphere::IonoFree, ..SppOptions::default() };
    let drift = ClockNoise::default().drift;
    for seed in [11u64, 12, 13, 14] {
        let c = case(&base, seed);
        let rt = run_tight_opt(&c, gate(), true, &opt, drift).rms_after(30.0);
        let rl = run_loose_opt(&c, &opt).rms_after(30.0);
        let cc = case(&canyon, seed);
        let mt = run_tight_opt(&cc, gate(), true, &opt, drift).max_in(200.0, 260.0);
        let ml = run_loose_opt(&cc, &opt).max_in(200.0, 260.0);
        let td = run_tight_opt(&case(&dirty, seed), gate(), true, &opt, drift).rms_after(30.0);
        let line = format!(
            "seed {seed}: horizontal RMS tight {rt:.2} loose {rl:.2}; canyon max tight {mt:.2} loose {ml:.2}; 10 % outliers tight {td:.2} m"
        );
        eprintln!("{line}");
        assert!(rt <= 1.1 * rl, "{line}");
        assert!(mt <= ml / 5.0, "{line}");
        assert!(td <= 1.2 * rt, "{line}");
    }
}

/// The smoother on the tight run through the canyon (dual-frequency receiver as above):
/// the largest horizontal error in the canyon, forward against smoothed.
#[test]
fn tight_smoothing_cuts_the_canyon_error() {
    let canyon = RawSim {
        ephemeris_std: 0.5,
        masks: vec![SkyMask { start: 200.0, end: 260.0, keep: 3 }],
        ..RawSim::spp_budget(start())
    };
    let opt = SppOptions { ionosphere: Ionosphere::IonoFree, ..SppOptions::default() };
    for seed in [11u64, 12, 13, 14] {
        let c = case(&canyon, seed);
        let mut rec =
            SegmentSmoother::<InsStateTc, ImuInput, _>::new(std::io::Cursor::new(Vec::new()), 64);
        let (fwd, nav) =
            run_tight_recorded(&c, gate(), true, &opt, ClockNoise::default().drift, &mut rec);
        let mut rows = Vec::new();
        rec.smooth(nav.filter(), nav.model(), |r| {
            rows.push(r.to_vec());
            Ok(())
        })
        .unwrap();
        let rows: Vec<_> = rows.into_iter().rev().flatten().collect();
        assert_eq!(rows.len(), c.data.imu.len());
        let mut worst: f64 = 0.0;
        for (k, r) in rows.iter().enumerate() {
            let t = &c.data.truth[k + 1];
            assert!((r.time - t.t).abs() < 1e-9);
            if (200.0..260.0).contains(&r.time) {
                let e = t.state.pos.ominus(&r.x.nav.pos);
                worst = worst.max(e.x.hypot(e.y));
            }
        }
        let f = fwd.max_in(200.0, 260.0);
        eprintln!("seed {seed}: canyon max forward {f:.2} m, smoothed {worst:.2} m");
        assert!(worst < f, "seed {seed}: smoothed {worst} against forward {f}");
    }
}

/// A single-frequency receiver (Klobuchar with half its delay left as error, URA 2.4 m):
/// the canyon's advantage shrinks, since the per-satellite biases of the 3 satellites left
/// carry into the position.
#[test]
fn tight_single_frequency_canyon() {
    let canyon = RawSim {
        masks: vec![SkyMask { start: 200.0, end: 260.0, keep: 3 }],
        ..RawSim::spp_budget(start())
    };
    for seed in [11u64, 12, 13, 14] {
        let cc = case(&canyon, seed);
        let (t, l) = (run_tight(&cc, gate(), true), run_loose(&cc));
        let (mt, ml) = (t.max_in(200.0, 260.0), l.max_in(200.0, 260.0));
        let (rt, rl) = (t.rms_after(30.0), l.rms_after(30.0));
        eprintln!(
            "seed {seed}: canyon max tight {mt:.2} loose {ml:.2}; RMS tight {rt:.2} loose {rl:.2}"
        );
        assert!(mt <= ml / 2.5, "seed {seed}: {mt} against {ml}");
        assert!(rt <= 1.1 * rl, "seed {seed}: {rt} against {rl}");
    }
}

/// With the errors drawn afresh at every epoch from the budget the filter assumes, the
/// position NEES averages to 3 over 20 seeds (after 30 s).
#[test]
fn tight_filter_is_consistent_over_seeds() {
    let sim = RawSim { white_errors: true, ..RawSim::spp_budget(start()) };
    let (mut sum, mut n) = (0.0, 0);
    let mut per = Vec::new();
    for seed in 0..20u64 {
        let c = case(&sim, 40 + seed);
        let (s, k) = run_tight(&c, FixedNoise, true).nees_after(30.0);
        per.push(s / k as f64);
        sum += s;
        n += k;
    }
    let mean = sum / n as f64;
    eprintln!("tight NEES mean {mean:.2}; per seed {per:.2?}");
    let (lo, hi) = estimator_core::consistency::averaged_chi2_band(3, 20, 0.99);
    assert!(mean > lo * 0.8 && mean < hi * 1.25, "{mean} outside ~[{lo}, {hi}]");
}
