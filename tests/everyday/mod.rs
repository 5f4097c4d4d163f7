//! The everyday-GNSS corpus's machinery (the everyday-GNSS issue, item 4), shared by
//! `examples/everyday_corpus.rs` (the full table) and the CI subset
//! (`tests/everyday_gnss.rs`): data sets, error models, runs through the program's
//! `run_in_memory` as a user makes them, and their scores.
#![allow(dead_code)]

pub mod start;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use ins_gnss::config::Config;
use ins_gnss::run::{run_in_memory, Inputs, Results, RunSummary};
use ins_gnss_io::formats::open;
use ins_gnss_io::lines::NumericLines;
use ins_gnss_sim::{scenarios, simulate, GnssSim, Trajectory};
use nalgebra::Vector3;
use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

pub const EARTH: f64 = 6_378_137.0;

/// How the fixes' errors are drawn.
#[derive(Clone, Copy, Debug)]
pub enum Errors {
    /// White, σ per axis.
    White([f64; 3]),
    /// Gauss–Markov σ per axis, τ (s), over white noise σ (all axes).
    Wander([f64; 3], f64, f64),
}

impl Errors {
    pub fn name(&self) -> String {
        match *self {
            Errors::White(s) => format!("white {}/{}/{} m", s[0], s[1], s[2]),
            Errors::Wander(s, tau, w) => {
                format!("wander {}/{}/{} m τ {tau} s +{w}", s[0], s[1], s[2])
            }
        }
    }

    /// The total σ per axis (what a receiver declaring the truth states).
    pub fn total(&self) -> [f64; 3] {
        match *self {
            Errors::White(s) => s,
            Errors::Wander(s, _, w) => s.map(|x| (x * x + w * w).sqrt()),
        }
    }

    /// The errors of fixes at times `t` (NED, m).
    pub fn draw(&self, t: &[f64], seed: u64) -> Vec<Vector3<f64>> {
        let mut rng = StdRng::seed_from_u64(seed ^ 0x5eed_f1c5);
        let mut g = || Distribution::<f64>::sample(&StandardNormal, &mut rng);
        let (gm, tau, white) = match *self {
            Errors::White(s) => ([0.0; 3], 1.0, s),
            Errors::Wander(s, tau, w) => (s, tau, [w; 3]),
        };
        let mut e = Vector3::from_fn(|i, _| gm[i] * g());
        let mut last = t.first().copied().unwrap_or(0.0);
        t.iter()
            .map(|&ti| {
                let phi = (-(ti - last).max(0.0) / tau).exp();
                last = ti;
                e = Vector3::from_fn(|i, _| phi * e[i] + (1.0 - phi * phi).sqrt() * gm[i] * g());
                e + Vector3::from_fn(|i, _| white[i] * g())
            })
            .collect()
    }

    /// The configuration's lines that give a run the true noise model.
    pub fn oracle(&self) -> String {
        match *self {
            Errors::White(s) => format!(
                "[gnss]\nposition_std = [{}, {}, {}]\n[gnss.errors]\nmodel = \"white\"\n\
                 [filter.gate]\nlearn = false\n",
                s[0], s[1], s[2]
            ),
            Errors::Wander(s, tau, w) => format!(
                "[gnss]\nposition_std = [{w}, {w}, {w}]\n[gnss.errors]\nmodel = \"persisting\"\n\
                 sigma = [{}, {}, {}]\ntau = {tau}\nlearn = false\n[filter.gate]\nlearn = false\n",
                s[0], s[1], s[2]
            ),
        }
    }
}

/// A data set: IMU rows, the fixes' true antenna positions, the truth, the configuration.
#[derive(Clone)]
pub struct Data {
    pub name: &'static str,
    pub imu: Arc<[f64]>,
    /// `t`, latitude, longitude (rad), height of the antenna.
    pub fixes: Vec<[f64; 4]>,
    /// `t`, latitude, longitude (rad), height of the truth the result is scored against.
    pub truth: Vec<[f64; 4]>,
    /// The configuration's text (TOML) or path (a shipped one).
    pub config: Source,
    /// Score the outages' largest horizontal errors (drive-0708) instead of the RMS.
    pub outages: Option<Vec<(f64, f64)>>,
    /// Seconds skipped before scoring.
    pub skip: f64,
}

#[derive(Clone)]
pub enum Source {
    Toml(String),
    File(PathBuf),
}

pub fn rows(path: &Path) -> (Vec<f64>, usize) {
    let mut lines = NumericLines::new(open(path).unwrap(), path);
    let (mut all, mut width) = (Vec::new(), 0);
    while let Some(r) = lines.next_record().unwrap() {
        width = r.len();
        all.extend_from_slice(r);
    }
    (all, width)
}

pub fn data_dir(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(name)
}

/// The simulator's drive: truth at every IMU epoch, fixes at 1 Hz.
pub fn sim_drive(seed: u64) -> Data {
    let lever = Vector3::new(0.3, 0.0, -1.0);
    let mut d = simulated("sim drive", seed, lever, 0.0, Vector3::zeros());
    if let Source::Toml(c) = &mut d.config {
        c.push_str("[gnss]\nlever_arm = [0.3, 0.0, -1.0]\n");
    }
    d
}

/// The antenna's true lever arm in [`calibration_drive`] (body FRD), m: 1.0 m from the
/// IMU.
pub const LEVER: [f64; 3] = [0.6, -0.5, -0.62];

/// The simulator's drive with the antenna at [`LEVER`] and the IMU's stamps late by
/// `late` s (the calibration campaign and its CI subset); the configuration gives the
/// IMU's noise and no lever arm.
pub fn calibration_drive(seed: u64, late: f64) -> Data {
    mounted_drive(seed, late, Vector3::zeros())
}

/// [`calibration_drive`] with the IMU mounted at `mounting` (roll, pitch, yaw of its axes
/// in the vehicle's, rad) and the car moving without sideslip (what the non-holonomic
/// constraint assumes).
pub fn mounted_drive(seed: u64, late: f64, mounting: Vector3<f64>) -> Data {
    simulated("calibration drive", seed, Vector3::from(LEVER), late, mounting)
}

/// The built-in 600 s drive, one for the corpus's simulated cells: its exact IMU is
/// integrated once ([`Trajectory::exact_imu`]) and each seed draws only its errors.
static DRIVE: std::sync::LazyLock<Trajectory> = std::sync::LazyLock::new(|| {
    let (start, segs) = scenarios::drive_600s();
    Trajectory::new(start, &segs).unwrap()
});

/// The simulator's 600 s drive with the simulator's MEMS mounted at `mounting`, error-free
/// fixes at 1 Hz from an antenna at `lever`, the IMU's stamps late by `late` s; the
/// configuration gives the IMU's noise in its units and nothing else.
fn simulated(
    name: &'static str,
    seed: u64,
    lever: Vector3<f64>,
    late: f64,
    mounting: Vector3<f64>,
) -> Data {
    let traj = &*DRIVE;
    let gnss = GnssSim {
        rate_hz: 1.0,
        pos_sigma: Vector3::zeros(),
        vel_sigma: None,
        lever_arm: lever,
        windows: vec![],
    };
    let imu = ins_gnss_sim::ImuErrors { mounting, ..scenarios::mems_imu() };
    let d = simulate(traj, 100.0, &imu, &gnss, seed);
    sim_data(name, &d, late, MEMS_CONFIG.to_string(), None, 60.0)
}

/// The simulator's MEMS (`scenarios::mems_imu`) in the configuration's units, with the
/// files' names.
pub const MEMS_CONFIG: &str = "[data]\nimu = \"imu\"\ngnss = \"gnss\"\nimu_rate = 100.0\n\
     [imu_noise]\narw = [0.3, 0.3, 0.3]\nvrw = [0.1, 0.1, 0.1]\n\
     gyro_bias_std = [10.0, 10.0, 10.0]\naccel_bias_std = [100.0, 100.0, 100.0]\n\
     corr_time = 1.0\n";

/// A simulated data set as the corpus runs it: the IMU rows (stamps late by `late` s; the
/// odometer's speed as an 8th column when the IMU has one), the fixes' true antenna
/// positions, the truth.
fn sim_data(
    name: &'static str,
    d: &ins_gnss_sim::SimDataset,
    late: f64,
    config: String,
    outages: Option<Vec<(f64, f64)>>,
    skip: f64,
) -> Data {
    let imu: Vec<f64> = d
        .imu
        .iter()
        .flat_map(|s| {
            let row = [s.t + late, s.dtheta[0], s.dtheta[1], s.dtheta[2], s.dvel[0], s.dvel[1]];
            row.into_iter().chain([s.dvel[2]]).chain(s.odometer)
        })
        .collect();
    let fixes = d.gnss.iter().map(|g| [g.t, g.pos.lat, g.pos.lon, g.pos.h]).collect();
    let truth =
        d.truth.iter().map(|r| [r.t, r.state.pos.lat, r.state.pos.lon, r.state.pos.h]).collect();
    Data { name, imu: imu.into(), fixes, truth, config: Source::Toml(config), outages, skip }
}

/// The simulator's 600 s drive with `imu`, error-free fixes at 1 Hz from the antenna at
/// [`LEVER`] lost in [`ANTENNA_OUTAGES`].
fn outage_drive(
    imu: &ins_gnss_sim::ImuErrors,
    seed: u64,
) -> (Trajectory, ins_gnss_sim::SimDataset) {
    use ins_gnss_sim::{GnssWindow, GnssWindowKind};
    let traj = DRIVE.clone();
    let windows = ANTENNA_OUTAGES
        .iter()
        .map(|&(start, end)| GnssWindow { start, end, kind: GnssWindowKind::Outage })
        .collect();
    let gnss = GnssSim {
        rate_hz: 1.0,
        pos_sigma: Vector3::zeros(),
        vel_sigma: None,
        lever_arm: Vector3::from(LEVER),
        windows,
    };
    let d = simulate(&traj, 100.0, imu, &gnss, seed);
    (traj, d)
}

/// drive-0708's IMU and RTK fixes (the outage file's epochs), scored in its outages
/// against the RTK-fixed reference; `config` one of its shipped configurations.
pub fn drive_0708(config: &str) -> Data {
    let dir = data_dir("drive-0708");
    let (imu, _) = rows(&dir.join("IMU.txt.zst"));
    let (g, w) = rows(&dir.join("GNSS-RTK-outage10x15.txt.zst"));
    let fixes = g.chunks(w).map(|r| [r[0], r[1].to_radians(), r[2].to_radians(), r[3]]).collect();
    let (r, w) = rows(&dir.join("ref_rtkfix.txt.zst"));
    let truth = r.chunks(w).map(|r| [r[0], r[1].to_radians(), r[2].to_radians(), r[3]]).collect();
    let windows: Vec<[f64; 2]> = serde_json::from_str(
        &std::fs::read_to_string(dir.join("outage_windows_15s.json")).unwrap(),
    )
    .unwrap();
    Data {
        name: if config.ends_with("yaml") { "drive-0708 yaml" } else { "drive-0708 noinit" },
        imu: imu.into(),
        fixes,
        truth,
        config: Source::File(dir.join(config)),
        outages: Some(windows.iter().map(|w| (w[0], w[1])).collect()),
        skip: 0.0,
    }
}

/// navego's IMU and truth, its fixes the truth's positions at 5 Hz (the shipped GNSS
/// file's epochs); the configuration `noinit.toml`.
pub fn navego() -> Data {
    let dir = data_dir("navego");
    let (imu, _) = rows(&dir.join("IMU-ADIS16488.txt.zst"));
    let (t, w) = rows(&dir.join("truth.nav.zst"));
    let truth: Vec<[f64; 4]> =
        t.chunks(w).map(|r| [r[1], r[2].to_radians(), r[3].to_radians(), r[4]]).collect();
    let (g, w) = rows(&dir.join("GNSS-POS.txt.zst"));
    let fixes = g
        .chunks(w)
        .map(|r| {
            let k = truth.partition_point(|x| x[0] < r[0] - 1e-6).min(truth.len() - 1);
            let mut p = truth[k];
            p[0] = r[0];
            p
        })
        .collect();
    Data {
        name: "navego noinit",
        imu: imu.into(),
        fixes,
        truth,
        config: Source::File(dir.join("noinit.toml")),
        outages: None,
        skip: 60.0,
    }
}

/// The fixes' rows: the true positions moved by `errors`, declaring `declared` × their
/// total σ.
pub fn gnss_rows(d: &Data, errors: Errors, declared: f64, seed: u64) -> Arc<[f64]> {
    let t: Vec<f64> = d.fixes.iter().map(|f| f[0]).collect();
    let e = errors.draw(&t, seed);
    let s = errors.total().map(|x| x * declared);
    d.fixes
        .iter()
        .zip(e)
        .flat_map(|(f, e)| {
            let lat = f[1] + e[0] / EARTH;
            let lon = f[2] + e[1] / (EARTH * f[1].cos());
            [f[0], lat.to_degrees(), lon.to_degrees(), f[3] - e[2], s[0], s[1], s[2]]
        })
        .collect()
}

/// One run's outcome.
#[derive(Clone, Debug, Default)]
pub struct Outcome {
    /// Refused before it started (the error).
    pub refused: Option<String>,
    /// Flagged untrustworthy: the causes named.
    pub flagged: Option<Vec<String>>,
    /// Restarted with the fixes' persisting error as states.
    pub persisting: bool,
    /// The score (horizontal RMS, or the outages' score), m.
    pub score: f64,
    /// Share of epochs beyond the run's own 99 % ellipse.
    pub beyond: f64,
    /// The fix stream's lag-one autocorrelation at the end (the gate's learner).
    pub lag: f64,
}

pub fn config_of(d: &Data, extra: &str) -> Config {
    let base = Path::new(".");
    match &d.config {
        Source::Toml(t) => {
            let text = merge(t, extra);
            Config::parse(&text, ins_gnss::config::ConfigKind::Toml, base).unwrap()
        }
        Source::File(p) => {
            let c = Config::load(p).unwrap();
            if extra.is_empty() {
                return c;
            }
            // (the loaded configuration, paths resolved, with `extra`'s keys merged in)
            let text = merge(&toml::to_string(&c).unwrap(), extra);
            Config::parse(&text, ins_gnss::config::ConfigKind::Toml, base).unwrap()
        }
    }
}

/// `extra`'s sections merged into `text` (a section present in both gets the extra keys).
pub fn merge(text: &str, extra: &str) -> String {
    let mut v: toml::Table = toml::from_str(text).unwrap();
    let e: toml::Table = toml::from_str(extra).unwrap();
    for (k, x) in e {
        match (v.get_mut(&k), x) {
            (Some(toml::Value::Table(a)), toml::Value::Table(b)) => {
                for (kk, xx) in b {
                    a.insert(kk, xx);
                }
            }
            (_, x) => {
                v.insert(k, x);
            }
        }
    }
    toml::to_string(&v).unwrap()
}

/// The horizontal error (N, E; m) of `nav` (latitude and longitude in degrees) against the
/// truth interpolated at `t` (`None` outside it).
pub fn horizontal_error(truth: &[[f64; 4]], t: f64, lat: f64, lon: f64) -> Option<(f64, f64)> {
    let k = truth.partition_point(|x| x[0] < t);
    if k == 0 || k >= truth.len() {
        return None;
    }
    let (a, b) = (&truth[k - 1], &truth[k]);
    if b[0] - a[0] > 1.0 {
        return None;
    }
    let f = (t - a[0]) / (b[0] - a[0]);
    let (tl, tn) = (a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2]));
    Some(((lat.to_radians() - tl) * EARTH, (lon.to_radians() - tn) * EARTH * tl.cos()))
}

pub fn score(d: &Data, r: &Results, t0: f64) -> (f64, f64) {
    let w = r.std_width;
    // coverage at the rows of std.txt (after every update, at least once a second)
    let (mut n, mut beyond) = (0usize, 0usize);
    for s in r.std.chunks(w) {
        if s[0] < t0 + d.skip {
            continue;
        }
        let k = r.nav.partition_point(|x| x[0] < s[0] - 1e-9);
        let Some(row) = r.nav.get(k).filter(|x| (x[0] - s[0]).abs() < 1e-6) else { continue };
        if let Some((en, ee)) = horizontal_error(&d.truth, row[0], row[1], row[2]) {
            n += 1;
            if (en / s[1]).powi(2) + (ee / s[2]).powi(2) > 9.21 {
                beyond += 1;
            }
        }
    }
    let cover = beyond as f64 / n.max(1) as f64;
    let score = match &d.outages {
        Some(windows) => {
            let worst: Vec<f64> = windows
                .iter()
                .map(|&(a, b)| {
                    r.nav
                        .iter()
                        .filter(|x| x[0] >= a && x[0] <= b)
                        .filter_map(|x| horizontal_error(&d.truth, x[0], x[1], x[2]))
                        .map(|(n, e)| n.hypot(e))
                        .fold(0.0, f64::max)
                })
                .collect();
            (worst.iter().map(|v| v * v).sum::<f64>() / worst.len() as f64).sqrt()
        }
        None => {
            let e: Vec<f64> = r
                .nav
                .iter()
                .filter(|x| x[0] >= t0 + d.skip)
                .filter_map(|x| horizontal_error(&d.truth, x[0], x[1], x[2]))
                .map(|(n, e)| n * n + e * e)
                .collect();
            (e.iter().sum::<f64>() / e.len().max(1) as f64).sqrt()
        }
    };
    (score, cover)
}

pub fn run(d: &Data, gnss: Arc<[f64]>, extra: &str) -> Outcome {
    let cfg = config_of(d, extra);
    let inputs = Inputs::Arrays { imu: d.imu.clone(), imu_width: 7, gnss, gnss_width: 7 };
    let (summary, results): (RunSummary, Results) =
        match run_in_memory(&cfg, "fixed".parse().unwrap(), &inputs) {
            Ok(r) => r,
            Err(e) => return Outcome { refused: Some(e.to_string()), ..Default::default() },
        };
    // (VERBOSE=2: the run's summary on stderr)
    if std::env::var("VERBOSE").is_ok_and(|v| v == "2") {
        eprintln!("{}", summary.lines().join("\n"));
    }
    let flagged = ins_gnss::health::assess(&summary, &cfg).err().map(|u| u.diagnosis);
    let t0 = results.nav.first().map_or(0.0, |x| x[0]);
    let (score, beyond) = score(d, &results, t0);
    let persisting = summary.fix_errors.is_some_and(|f| f.probe.is_some());
    let lag = summary
        .fix_errors
        .and_then(|f| f.probe.map(|p| p.lag_one))
        .or_else(|| {
            summary.learned.iter().find(|l| l.stream.starts_with("gnss")).map(|l| l.lag_one)
        })
        .unwrap_or(f64::NAN);
    Outcome { refused: None, flagged, persisting, score, beyond, lag }
}

/// Means over runs and their true-model twins: the share beyond the 99 % ellipse, the
/// score, and the true model's score (0 over no runs).
pub fn pooled<'a>(outs: impl IntoIterator<Item = &'a (Outcome, Outcome)>) -> (f64, f64, f64) {
    let (mut n, mut beyond, mut score, mut truth) = (0usize, 0.0, 0.0, 0.0);
    for (o, t) in outs {
        n += 1;
        beyond += o.beyond;
        score += o.score;
        truth += t.score;
    }
    let n = n.max(1) as f64;
    (beyond / n, score / n, truth / n)
}

pub fn report(name: &str, outs: &[(Outcome, Outcome)]) {
    let k = outs.len() as f64;
    let ok: Vec<&(Outcome, Outcome)> =
        outs.iter().filter(|(o, t)| o.refused.is_none() && t.refused.is_none()).collect();
    let (beyond, score, truth) = pooled(ok.iter().copied());
    let truth_beyond = ok.iter().map(|(_, t)| t.beyond).sum::<f64>() / ok.len().max(1) as f64;
    let mut lags: Vec<f64> = ok.iter().map(|(o, _)| o.lag).collect();
    lags.sort_by(f64::total_cmp);
    let lag = lags.get(lags.len() / 2).copied().unwrap_or(f64::NAN);
    let refused = outs.iter().filter(|(o, _)| o.refused.is_some()).count();
    let flagged = outs.iter().filter(|(o, _)| o.flagged.is_some()).count();
    let restarted = outs.iter().filter(|(o, _)| o.persisting).count();
    let mut causes: Vec<String> = outs
        .iter()
        .filter_map(|(o, _)| o.flagged.as_ref())
        .flat_map(|c| c.iter().map(|s| s.chars().take(60).collect::<String>()))
        .collect();
    causes.sort();
    causes.dedup();
    println!(
        "| {name} | {score:.3} | {truth:.3} | {:.2} | {:.1} % | {:.1} % | {refused} | {flagged} | {restarted} of {} ({lag:.2}) | {} |",
        score / truth,
        beyond * 100.0,
        truth_beyond * 100.0,
        k,
        causes.join("; ")
    );
    if let Some((o, _)) = outs.iter().find(|(o, _)| o.refused.is_some()) {
        println!(
            "|   refused: {} |",
            o.refused.as_deref().unwrap_or("").lines().next().unwrap_or("")
        );
    }
}

/// The fixes' rows of one run as a 7-column file `DIR/gnss-SEED.txt` (the `DUMP`
/// environment variable), to run the program on by hand.
pub fn dump(dir: &str, d: &Data, g: &[f64], seed: u64) {
    let _ = std::fs::create_dir_all(dir);
    let text: String = g
        .chunks(7)
        .map(|r| {
            format!(
                "{:.3} {:.10} {:.10} {:.4} {:.4} {:.4} {:.4}\n",
                r[0], r[1], r[2], r[3], r[4], r[5], r[6]
            )
        })
        .collect();
    let name = d.name.replace(' ', "-");
    let _ = std::fs::write(Path::new(dir).join(format!("gnss-{name}-{seed}.txt")), text);
    if let Source::Toml(t) = &d.config {
        let imu: String = d
            .imu
            .chunks(7)
            .map(|r| {
                let v: Vec<String> = r.iter().map(|x| format!("{x:.12e}")).collect();
                v.join(" ") + "\n"
            })
            .collect();
        let _ = std::fs::write(Path::new(dir).join(format!("imu-{name}-{seed}.txt")), imu);
        let cfg = t
            .replace("imu = \"imu\"", &format!("imu = \"imu-{name}-{seed}.txt\""))
            .replace("gnss = \"gnss\"", &format!("gnss = \"gnss-{name}-{seed}.txt\""));
        let _ = std::fs::write(Path::new(dir).join(format!("config-{name}-{seed}.toml")), cfg);
    }
}

/// The outages of [`antenna_drive`]: 60 s each, on straights, turns and a stop.
pub const ANTENNA_OUTAGES: [(f64, f64); 4] =
    [(100.0, 160.0), (230.0, 290.0), (360.0, 420.0), (480.0, 540.0)];

/// The simulator's 600 s drive (standing 20 s first) with a moving-base receiver: the
/// fixes at 1 Hz from the antenna at [`LEVER`] (white errors drawn by [`gnss_rows`]), the
/// baseline `baseline` (body FRD, m) measured at every fix with white noise σ `sigma` deg
/// on the heading and `2 sigma` on the elevation, both lost in [`ANTENNA_OUTAGES`]; a share
/// `wrong` of the headings moved by 5–30° either way (a moving-base receiver's wrong
/// integer fix), their stated σ unchanged. The
/// headings' file is written under the system's temporary directory; the configuration
/// names it, the lever arm and the baseline.
pub struct AntennaDrive {
    pub data: Data,
    /// `t`, yaw (rad) of the truth at every IMU epoch.
    pub yaw: Vec<(f64, f64)>,
    /// The headings' file.
    pub headings: PathBuf,
}

pub fn antenna_drive(seed: u64, baseline: Vector3<f64>, sigma: f64, wrong: f64) -> AntennaDrive {
    let (traj, d) = outage_drive(&scenarios::mems_imu(), seed);
    let times: Vec<f64> = d.gnss.iter().map(|g| g.t).collect();
    let s = sigma.to_radians();
    let headings = ins_gnss_sim::antenna_headings(
        &traj,
        &times,
        &baseline,
        &Vector3::zeros(),
        s,
        2.0 * s,
        seed,
    );
    let mut rng = StdRng::seed_from_u64(seed.wrapping_add(17));
    let mut headings = headings;
    for h in headings.iter_mut() {
        let u: f64 = rand::Rng::random(&mut rng);
        if u < wrong {
            let size: f64 = 5.0 + 25.0 * rand::Rng::random::<f64>(&mut rng);
            let sign = if rand::Rng::random::<bool>(&mut rng) { 1.0 } else { -1.0 };
            h.heading = ins_gnss_core::heading::wrap(h.heading + sign * size.to_radians());
        }
    }
    let path = std::env::temp_dir().join(format!(
        "antenna-drive-{}-{seed}-{:.0}-{:.0}-{:.0}.txt",
        std::process::id(),
        baseline.y.atan2(baseline.x).to_degrees(),
        sigma * 1000.0,
        wrong * 1000.0
    ));
    let mut f = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
    ins_gnss_io::write_headings(&mut f, &headings).unwrap();
    drop(f);
    let yaw = d.truth.iter().map(|r| (r.t, r.state.att.euler().2)).collect();
    let config = format!(
        "{}[gnss]\nlever_arm = [{}, {}, {}]\n[gnss.heading]\nbaseline = [{}, {}, {}]\n",
        MEMS_CONFIG.replacen(
            "imu_rate = 100.0\n",
            &format!("imu_rate = 100.0\nheading = {:?}\n", path.to_string_lossy()),
            1
        ),
        LEVER[0],
        LEVER[1],
        LEVER[2],
        baseline.x,
        baseline.y,
        baseline.z
    );
    let data = sim_data("two antennas", &d, 0.0, config, None, 0.0);
    AntennaDrive { data, yaw, headings: path }
}

/// The heading errors of a run's rows against the truth's yaw (deg): RMS over the rows
/// from `t0`, RMS inside [`ANTENNA_OUTAGES`], and the largest.
pub fn heading_errors(yaw: &[(f64, f64)], nav: &[[f64; 10]], t0: f64) -> (f64, f64, f64) {
    let (mut all, mut out, mut worst) = ((0.0, 0usize), (0.0, 0usize), 0.0f64);
    for row in nav.iter().filter(|r| r[0] >= t0) {
        let k = yaw.partition_point(|y| y.0 < row[0] - 1e-6);
        let Some(&(t, truth)) = yaw.get(k) else { continue };
        if (t - row[0]).abs() > 1e-6 {
            continue;
        }
        let e = ins_gnss_core::heading::wrap(row[9].to_radians() - truth).to_degrees();
        all = (all.0 + e * e, all.1 + 1);
        if ANTENNA_OUTAGES.iter().any(|&(a, b)| row[0] >= a && row[0] < b) {
            out = (out.0 + e * e, out.1 + 1);
        }
        worst = worst.max(e.abs());
    }
    let rms = |(s, n): (f64, usize)| (s / n.max(1) as f64).sqrt();
    (rms(all), rms(out), worst)
}

/// The simulator's 600 s drive with a wheel odometer at the IMU reading `scale` (fraction)
/// fast with 0.05 m/s of noise (the IMU rows' 8th column), fixes at 1 Hz from the antenna
/// at [`LEVER`] lost in [`ANTENNA_OUTAGES`]; the configuration gives the IMU's noise, the
/// lever arm, the NHC and the odometer (its wheel point `[0, 0, 0]` unless `extra` says
/// otherwise).
pub fn odometer_drive(seed: u64, scale: f64) -> Data {
    let imu = ins_gnss_sim::ImuErrors { odometer: Some((scale, 0.05)), ..scenarios::mems_imu() };
    let (_, d) = outage_drive(&imu, seed);
    let config = format!(
        "{MEMS_CONFIG}[gnss]\nlever_arm = [{}, {}, {}]\n[vehicle.nhc]\n[vehicle.odometer]\n",
        LEVER[0], LEVER[1], LEVER[2]
    );
    sim_data("odometer drive", &d, 0.0, config, Some(ANTENNA_OUTAGES.to_vec()), 0.0)
}
