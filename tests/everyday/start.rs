//! The start campaign (the decisions issue's first "done when"): simulated cars that stand
//! still for a while and then drive, headed anywhere, with IMUs of four grades and RTK or
//! single-point fixes, run as a user runs them — no `[init]`, the datasheet's noise, the
//! default gate — and judged on what the start must never do: refuse, or report a heading
//! (or a start velocity) its own σ does not cover.

use super::*;
use ins_gnss_core::imu::{BiasModel, ImuNoise, DEG_PER_H, DEG_PER_SQRT_H, MGAL, M_S_PER_SQRT_H};
use ins_gnss_sim::{ImuErrors, Segment, Start};

/// An IMU grade: its datasheet (the configuration's units: deg/√h, m/s/√h, deg/h, mGal)
/// and its turn-on biases (deg/h, mGal), which no datasheet gives.
#[derive(Clone, Copy, Debug)]
pub struct Grade {
    pub name: &'static str,
    pub arw: f64,
    pub vrw: f64,
    pub gyro_bias: f64,
    pub accel_bias: f64,
    pub gyro_turn_on: [f64; 3],
    pub accel_turn_on: [f64; 3],
    /// White vibration while moving: rate (rad/s) and specific force (m/s²) per sample.
    pub vibration: (f64, f64),
}

/// navego's two IMUs (ADIS16488-like and ADIS16405-like, `data/README.md`), drive-0708's
/// datasheet figures (KF-GINS's YAML), and a noisy consumer MEMS (white rate noise
/// 1e-3 rad/s per 100 Hz sample, 0.34°/√h, shaken while it moves).
pub const GRADES: [Grade; 4] = [
    Grade {
        name: "ADIS16488",
        arw: 0.3,
        vrw: 0.03,
        gyro_bias: 6.5,
        accel_bias: 50.0,
        gyro_turn_on: [20.0, -15.0, 10.0],
        accel_turn_on: [100.0, -80.0, 60.0],
        vibration: (0.0, 0.0),
    },
    Grade {
        name: "ADIS16405",
        arw: 2.0,
        vrw: 0.2,
        gyro_bias: 25.0,
        accel_bias: 200.0,
        gyro_turn_on: [60.0, -50.0, 40.0],
        accel_turn_on: [400.0, -300.0, 200.0],
        vibration: (0.0, 0.0),
    },
    Grade {
        name: "drive-0708",
        arw: 0.3,
        vrw: 0.1,
        gyro_bias: 50.0,
        accel_bias: 1000.0,
        gyro_turn_on: [80.0, -60.0, 50.0],
        accel_turn_on: [1500.0, -1000.0, 800.0],
        vibration: (0.0, 0.0),
    },
    Grade {
        name: "noisy MEMS",
        arw: 0.344,
        vrw: 0.3,
        gyro_bias: 100.0,
        accel_bias: 2000.0,
        gyro_turn_on: [150.0, -100.0, 120.0],
        accel_turn_on: [3000.0, -2000.0, 1500.0],
        vibration: (0.0, 0.0),
    },
];

impl Grade {
    fn errors(&self) -> ImuErrors {
        let v = |a: [f64; 3], u: f64| Vector3::from(a) * u;
        ImuErrors {
            noise: ImuNoise {
                arw: Vector3::repeat(self.arw * DEG_PER_SQRT_H),
                vrw: Vector3::repeat(self.vrw * M_S_PER_SQRT_H),
                gyro_bias: Vector3::repeat(self.gyro_bias * DEG_PER_H),
                accel_bias: Vector3::repeat(self.accel_bias * MGAL),
                bias_model: BiasModel::GaussMarkov { tau: 3600.0 },
            },
            gyro_turn_on: v(self.gyro_turn_on, DEG_PER_H),
            accel_turn_on: v(self.accel_turn_on, MGAL),
            vibration: self.vibration,
            ..ImuErrors::none()
        }
    }

    /// The datasheet as the configuration gives it.
    fn config(&self) -> String {
        let r = |x: f64| format!("[{x}, {x}, {x}]");
        format!(
            "[data]\nimu = \"imu\"\ngnss = \"gnss\"\nimu_rate = 100.0\n[imu_noise]\narw = {}\n\
             vrw = {}\ngyro_bias_std = {}\naccel_bias_std = {}\ncorr_time = 1.0\n",
            r(self.arw),
            r(self.vrw),
            r(self.gyro_bias),
            r(self.accel_bias)
        )
    }
}

/// The fixes: RTK (white 2 cm; 1 cm for the walk), a single point (the everyday wander,
/// 1.5/1.5/3 m over τ 100 s plus 0.3 m white), or the slow rover's white 5/5/8 m,
/// declared with their true σ.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fixes {
    Rtk,
    Rtk1cm,
    SinglePoint,
    White5m,
}

impl Fixes {
    pub fn errors(self) -> Errors {
        match self {
            Fixes::Rtk => Errors::White([0.02, 0.02, 0.04]),
            Fixes::Rtk1cm => Errors::White([0.01, 0.01, 0.02]),
            Fixes::SinglePoint => Errors::Wander([1.5, 1.5, 3.0], 100.0, 0.3),
            Fixes::White5m => Errors::White([5.0, 5.0, 8.0]),
        }
    }
}

/// The truth's `t`, NED velocity, yaw (rad), gyro bias (deg/h) and roll, pitch (rad) at
/// every IMU epoch.
pub type Motion = Vec<(f64, [f64; 3], f64, [f64; 3], [f64; 2])>;

/// A car headed anywhere (the seed draws the yaw) that stands `standing` s and then drives
/// 240 s (accelerating, straight, a right and a left turn, a stop), the IMU of `grade`,
/// error-free fixes at 1 Hz from an antenna 0.3 m ahead and 1 m above the IMU.
pub fn standing_car(seed: u64, standing: f64, grade: &Grade) -> (Data, Motion) {
    let deg = core::f64::consts::PI / 180.0;
    let mut segs = Vec::new();
    if standing > 0.0 {
        segs.push(Segment::stop(standing));
    }
    segs.extend([
        Segment::accelerate(10.0, 1.5),
        Segment::straight(40.0),
        Segment::turn(15.0, 6.0 * deg),
        Segment::straight(30.0),
        Segment::accelerate(5.0, 1.0),
        Segment::straight(40.0),
        Segment::turn(30.0, -3.0 * deg),
        Segment::straight(50.0),
        Segment::decelerate(10.0, 2.0),
        Segment::stop(10.0),
    ]);
    let lever = [0.3, 0.0, -1.0];
    simulated_start(seed, 0.0, &segs, grade, lever, Vector3::zeros())
}

/// The same car driving backwards: its IMU mounted facing the rear (yaw 180°), so that
/// to the IMU the car reverses for its whole drive, after standing `standing` s.
pub fn reversing_car(seed: u64, standing: f64, grade: &Grade) -> (Data, Motion) {
    let deg = core::f64::consts::PI / 180.0;
    let segs = [
        Segment::stop(standing),
        Segment::accelerate(4.0, 0.5),
        Segment::turn(10.0, 4.5 * deg),
        Segment::straight(20.0),
        Segment::accelerate(6.0, 1.0),
        Segment::straight(30.0),
        Segment::turn(20.0, -4.0 * deg),
        Segment::straight(30.0),
        Segment::decelerate(4.0, 2.0),
        Segment::stop(10.0),
    ];
    simulated_start(seed, 0.0, &segs, grade, [0.3, 0.0, -1.0], Vector3::new(0.0, 0.0, 180.0 * deg))
}

/// A person who stands `standing` s (0: walking from the first sample) and then walks at
/// 1.2 m/s around a 17 m square yard with tight turns (90° in 2 s), twice one way, a
/// short stop, and once the other way; a consumer MEMS IMU (`scenarios/walk.toml`'s), the
/// antenna 0.2 m above it.
pub fn yard_walk(seed: u64, standing: f64) -> (Data, Motion) {
    let deg = core::f64::consts::PI / 180.0;
    let (speed, mut segs) = if standing > 0.0 {
        (0.0, vec![Segment::stop(standing), Segment::accelerate(1.0, 1.2)])
    } else {
        (1.2, vec![])
    };
    for _ in 0..8 {
        segs.extend([Segment::straight(14.0), Segment::turn(2.0, 45.0 * deg)]);
    }
    segs.extend([Segment::decelerate(1.0, 1.2), Segment::stop(3.0), Segment::accelerate(1.0, 1.2)]);
    for _ in 0..4 {
        segs.extend([Segment::straight(14.0), Segment::turn(2.0, -45.0 * deg)]);
    }
    segs.extend([Segment::decelerate(1.0, 1.2), Segment::stop(5.0)]);
    simulated_start(seed, speed, &segs, &WALKER, [0.0, 0.0, -0.2], Vector3::zeros())
}

/// A slow rover (`scenarios/rover.toml`'s): 0.42 m/s from the first sample (no static
/// start), gentle turns of 6–9°/s, its IMU, the antenna 0.2 m ahead and 0.8 m above it.
pub fn slow_rover(seed: u64) -> (Data, Motion) {
    let deg = core::f64::consts::PI / 180.0;
    let segs = [
        Segment::straight(110.0),
        Segment::turn(10.0, 9.0 * deg),
        Segment::straight(90.0),
        Segment::turn(15.0, -6.0 * deg),
        Segment::straight(80.0),
        Segment::turn(10.0, 9.0 * deg),
        Segment::straight(60.0),
    ];
    simulated_start(seed, 0.42, &segs, &ROVER, [0.2, 0.0, -0.8], Vector3::zeros())
}

/// The walk's IMU (`scenarios/walk.toml`).
pub const WALKER: Grade = Grade {
    name: "walker",
    arw: 0.3,
    vrw: 0.1,
    gyro_bias: 10.0,
    accel_bias: 100.0,
    gyro_turn_on: [30.0, -20.0, 40.0],
    accel_turn_on: [300.0, -200.0, 100.0],
    vibration: (0.0, 0.0),
};

/// The slow rover's IMU (`scenarios/rover.toml`).
pub const ROVER: Grade = Grade {
    name: "rover",
    arw: 0.5,
    vrw: 0.5,
    gyro_bias: 20.0,
    accel_bias: 300.0,
    gyro_turn_on: [50.0, -30.0, 60.0],
    accel_turn_on: [500.0, -400.0, 300.0],
    vibration: (0.0, 0.0),
};

/// A trajectory headed anywhere (the seed draws the yaw) from `speed` along `segs`, the
/// IMU of `grade` mounted at `mounting` (roll, pitch, yaw, rad), error-free fixes at 1 Hz
/// from the antenna at `lever` (body frame, m; also the configuration's).
fn simulated_start(
    seed: u64,
    speed: f64,
    segs: &[Segment],
    grade: &Grade,
    lever: [f64; 3],
    mounting: Vector3<f64>,
) -> (Data, Motion) {
    let deg = core::f64::consts::PI / 180.0;
    let mut rng = StdRng::seed_from_u64(seed.wrapping_mul(7919).wrapping_add(3));
    let yaw = (rand::Rng::random::<f64>(&mut rng) * 360.0 - 180.0) * deg;
    let start = Start {
        t: 0.0,
        pos: ins_gnss_core::GeoPos::from_degrees(30.5, 114.3, 25.0),
        speed,
        yaw,
        pitch: 0.0,
    };
    let traj = Trajectory::new(start, segs).unwrap();
    let gnss = GnssSim {
        rate_hz: 1.0,
        pos_sigma: Vector3::zeros(),
        vel_sigma: None,
        lever_arm: Vector3::from(lever),
        windows: vec![],
    };
    let imu = ImuErrors { mounting, ..grade.errors() };
    let d = simulate(&traj, 100.0, &imu, &gnss, seed);
    let motion = d
        .truth
        .iter()
        .map(|r| {
            let b = r.state.bg / DEG_PER_H;
            let (roll, pitch, yaw) = r.state.att.euler();
            let v = r.state.vel;
            (r.t, [v.x, v.y, v.z], yaw, [b.x, b.y, b.z], [roll, pitch])
        })
        .collect();
    let config = format!(
        "{}[gnss]\nlever_arm = [{}, {}, {}]\n",
        grade.config(),
        lever[0],
        lever[1],
        lever[2]
    );
    (sim_data("start campaign", &d, 0.0, config, None, 0.0), motion)
}

/// `[init]` with the truth's state at the first IMU epoch (σ 0.1°, 0.01 m/s, 0.01 m):
/// the run the start is compared with.
pub fn true_init(d: &Data, motion: &Motion) -> String {
    let t = d.imu[0];
    let k = motion.partition_point(|m| m.0 < t - 1e-6);
    let m = &motion[k.min(motion.len() - 1)];
    let p = d.truth[d.truth.partition_point(|x| x[0] < t - 1e-6).min(d.truth.len() - 1)];
    format!(
        "[init]\nattitude = [{}, {}, {}]\nvelocity = [{}, {}, {}]\nposition = [{}, {}, {}]\n\
         attitude_std = [0.1, 0.1, 0.1]\nvelocity_std = [0.01, 0.01, 0.01]\n\
         position_std = [0.01, 0.01, 0.01]\n",
        m.4[0].to_degrees(),
        m.4[1].to_degrees(),
        m.2.to_degrees(),
        m.1[0],
        m.1[1],
        m.1[2],
        p[1].to_degrees(),
        p[2].to_degrees(),
        p[3]
    )
}

/// What the start campaign judges in one run.
#[derive(Clone, Debug, Default)]
pub struct StartOutcome {
    /// Refused before it started (the error).
    pub refused: Option<String>,
    /// Flagged untrustworthy (exit 3).
    pub flagged: bool,
    /// Every `std.txt` epoch's heading error within 3 of its σ.
    pub heading_covered: bool,
    /// The same from 30 s after the start.
    pub heading_covered_after: bool,
    /// The largest heading error over its σ, and the largest heading error (deg).
    pub worst_ratio: f64,
    pub worst_error: f64,
    /// When the ratio was largest, s.
    pub worst_t: f64,
    /// The first epoch's velocity within 3 of its σ on every axis.
    pub velocity_covered: bool,
    /// The first epoch's velocity error (m/s, largest axis).
    pub velocity_error: f64,
    /// Horizontal RMS against the truth, m.
    pub rms: f64,
}

/// Run `d` with `fixes` as a user does and judge its start against `motion`.
pub fn judge_start(
    d: &Data,
    motion: &Motion,
    fixes: Fixes,
    seed: u64,
    extra: &str,
) -> StartOutcome {
    let cfg = config_of(d, extra);
    let gnss = gnss_rows(d, fixes.errors(), 1.0, seed);
    let inputs = Inputs::Arrays { imu: d.imu.clone(), imu_width: 7, gnss, gnss_width: 7 };
    let (summary, r) = match run_in_memory(&cfg, "fixed".parse().unwrap(), &inputs) {
        Ok(x) => x,
        Err(e) => return StartOutcome { refused: Some(e.to_string()), ..Default::default() },
    };
    if std::env::var("VERBOSE").is_ok_and(|v| v == "2") {
        eprintln!("{}", summary.lines().join("\n"));
    }
    let flagged = ins_gnss::health::assess(&summary, &cfg).is_err();
    let truth_at = |t: f64| {
        let k = motion.partition_point(|m| m.0 < t - 1e-6);
        motion.get(k).filter(|m| (m.0 - t).abs() < 1e-6)
    };
    let (mut covered, mut worst_ratio, mut worst_error, mut worst_t) = (true, 0.0f64, 0.0f64, 0.0);
    let mut covered_after = true;
    let first = r.nav.first().map_or(0.0, |x| x[0]);
    for s in r.std.chunks(r.std_width) {
        let k = r.nav.partition_point(|x| x[0] < s[0] - 1e-9);
        let Some(row) = r.nav.get(k).filter(|x| (x[0] - s[0]).abs() < 1e-6) else { continue };
        let Some(m) = truth_at(row[0]) else { continue };
        let e = ins_gnss_core::heading::wrap(row[9].to_radians() - m.2).to_degrees().abs();
        let ratio = e / s[9].max(1e-9);
        if std::env::var("TRACE").is_ok() && (row[0] % 50.0 < 1e-6 || ratio > 3.0) {
            let b = r.imu_errors.chunks(r.imu_errors_width).find(|b| b[0] >= row[0] - 1e-6);
            eprintln!(
                "t {:.1} heading error {:.2}° σ {:.2}° gyro bias {:?} σ {:.1} {:.1} {:.1} true {:?}",
                row[0],
                e,
                s[9],
                b.map(|b| [b[1].round(), b[2].round(), b[3].round()]),
                s[10],
                s[11],
                s[12],
                m.3.map(f64::round)
            );
        }
        covered &= ratio <= 3.0;
        covered_after &= ratio <= 3.0 || row[0] < first + 30.0;
        if ratio > worst_ratio {
            (worst_ratio, worst_t) = (ratio, row[0]);
        }
        worst_error = worst_error.max(e);
    }
    let (mut velocity_covered, mut velocity_error) = (false, f64::NAN);
    if let (Some(row), Some(s)) = (r.nav.first(), r.std.get(..r.std_width))
        && let Some(m) = truth_at(row[0])
    {
        let e = [row[4] - m.1[0], row[5] - m.1[1], row[6] - m.1[2]];
        velocity_covered = (0..3).all(|i| e[i].abs() <= 3.0 * s[4 + i]);
        velocity_error = e.iter().fold(0.0f64, |a, x| a.max(x.abs()));
    }
    let e: Vec<f64> = r
        .nav
        .iter()
        .filter_map(|x| horizontal_error(&d.truth, x[0], x[1], x[2]))
        .map(|(n, e)| n * n + e * e)
        .collect();
    let rms = (e.iter().sum::<f64>() / e.len().max(1) as f64).sqrt();
    StartOutcome {
        refused: None,
        flagged,
        heading_covered: covered,
        heading_covered_after: covered_after,
        worst_ratio,
        worst_error,
        worst_t,
        velocity_covered,
        velocity_error,
        rms,
    }
}

/// One Markdown row of a cell: runs, refused, flagged, heading covered at every epoch and
/// from 30 s on, start velocity covered, the median and largest of each run's worst heading
/// error over its σ, the median worst heading error, the median RMS, and (with the runs
/// given the true initial state) the median and largest RMS ratio and the runs within
/// 1.2× of theirs; the first refusal's message.
pub fn start_row(name: &str, outs: &[(StartOutcome, Option<StartOutcome>)]) -> String {
    let n = outs.len();
    let ran: Vec<&(StartOutcome, Option<StartOutcome>)> =
        outs.iter().filter(|o| o.0.refused.is_none()).collect();
    let count = |f: &dyn Fn(&StartOutcome) -> bool| ran.iter().filter(|o| f(&o.0)).count();
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
    };
    let ratios: Vec<f64> = ran.iter().map(|o| o.0.worst_ratio).collect();
    let largest = ratios.iter().copied().fold(f64::NAN, f64::max);
    let errors: Vec<f64> = ran.iter().map(|o| o.0.worst_error).collect();
    let vs: Vec<f64> = ran
        .iter()
        .filter_map(|o| o.1.as_ref().filter(|t| t.refused.is_none()).map(|t| o.0.rms / t.rms))
        .collect();
    let oracle = if vs.is_empty() {
        "—".to_string()
    } else {
        format!(
            "{:.2} / {:.2} ({} of {})",
            median(vs.clone()),
            vs.iter().copied().fold(f64::NAN, f64::max),
            vs.iter().filter(|&&v| v <= 1.2).count(),
            vs.len()
        )
    };
    let first_refusal = outs
        .iter()
        .find_map(|o| o.0.refused.as_deref())
        .map(|e| e.chars().take(90).collect::<String>())
        .unwrap_or_default();
    format!(
        "| {name} | {n} | {} | {} | {} | {} | {} | {:.2} / {:.1} | {:.1}° | {:.2} | {oracle} | {first_refusal} |",
        n - ran.len(),
        count(&|o| o.flagged),
        count(&|o| o.heading_covered),
        count(&|o| o.heading_covered_after),
        count(&|o| o.velocity_covered),
        median(ratios),
        largest,
        median(errors),
        median(ran.iter().map(|o| o.0.rms).collect()),
    )
}
