//! Simulated RTK drives shared by `tests/rtk.rs` and `examples/rtk_corpus.rs`: a rover on
//! the 630 s drive of `ins_gnss_sim::scenarios::drive_600s` (1 Hz, the shipped navigation
//! file's GPS satellites on 2005-04-02 03:00), a base station 3.5 km north and 3.5 km east
//! of its start (the baseline 1.6–4.9 km over the drive), both receivers under one sky
//! (`ins_gnss_sim::raw::simulate_rtk`: the single point's error budget, its orbit, clock
//! and atmosphere errors shared, a 1 ppm ionospheric gradient; each receiver its own
//! clock, code biases, noise and ambiguities), and each run's figures against the truth.

use std::path::{Path, PathBuf};

use estimator_core::{FixedNoise, NoObserver};
use gnss::atmosphere::Klobuchar;
use gnss::rtk::{information_beyond, Rtk, RtkEpoch, RtkOptions};
use gnss::spp::single_point;
use gnss::{read_nav, GpsTime, NavData, ObsEpoch};
use ins_gnss_core::earth::{ecef_to_geodetic, ecef_to_ned_rotation, geodetic_to_ecef};
use ins_gnss_core::{GeoPos, GnssConfig, GnssEpoch, InitialState, InitialStd, InsModel, Navigator};
use ins_gnss_sim::raw::{simulate_rtk, write_rinex_obs, RawSim, RawTruth, RtkSim, SkyMask};
use ins_gnss_sim::{scenarios, Trajectory};
use nalgebra::{Matrix3, Vector3};

/// A fixed epoch further than this from the truth (3D, m) is a wrong fix: an L1 cycle is
/// 19 cm, a wrong integer moves the position by decimetres.
pub const WRONG_FIX: f64 = 0.10;

/// The tunnel of the tunnel cells: no satellite from 300 to 330 s.
pub const TUNNEL: (f64, f64) = (300.0, 330.0);

/// The canyon of the canyon cells: the 3 highest satellites from 300 to 360 s.
pub const CANYON: (f64, f64) = (300.0, 360.0);

/// The probability per satellite, frequency and epoch of a cycle slip the receiver does
/// not flag, in the slip cells (about 20 in a run).
pub const SLIPS: f64 = 0.002;

/// What the rover's sky and receiver do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sky {
    /// Open sky.
    Open,
    /// No satellite over [`TUNNEL`].
    Tunnel,
    /// Open, with cycle slips the receiver does not flag ([`SLIPS`]).
    Slips,
    /// The 3 highest satellites over [`CANYON`].
    Canyon,
}

impl Sky {
    /// The cell's name in a table.
    pub fn label(self) -> &'static str {
        match self {
            Sky::Open => "",
            Sky::Tunnel => ", 30 s tunnel",
            Sky::Slips => ", unflagged slips",
            Sky::Canyon => ", 60 s canyon of 3",
        }
    }

    /// The end of the outage (tunnel or canyon), trajectory time (s).
    pub fn outage_end(self) -> Option<f64> {
        match self {
            Sky::Tunnel => Some(TUNNEL.1),
            Sky::Canyon => Some(CANYON.1),
            _ => None,
        }
    }
}

/// The drive, its base station and its sky.
pub struct Drive {
    /// The shipped navigation file (zstd).
    pub nav_path: PathBuf,
    /// Its contents.
    pub nav: NavData,
    klobuchar: Klobuchar,
    traj: Trajectory,
    /// The base station's antenna (ECEF), m.
    pub base: Vector3<f64>,
    /// GPS time of the trajectory's start.
    pub start: GpsTime,
}

impl Drive {
    /// The drive; `root` the workspace root.
    pub fn new(root: &Path) -> Result<Self, Box<dyn std::error::Error>> {
        let nav_path = root.join("data/rinex-rtklib/07590920.05n.zst");
        let nav = read_nav(&nav_path)?;
        let klobuchar = nav.klobuchar.ok_or("no ionosphere in the navigation file")?;
        let (start, segs) = scenarios::drive_600s();
        let traj = Trajectory::new(start, &segs)?;
        let p0 = traj.position(traj.start_time());
        let c = ecef_to_ned_rotation(p0.lat, p0.lon).transpose();
        let base = geodetic_to_ecef(p0.lat, p0.lon, p0.h) + c * Vector3::new(3500.0, 3500.0, 0.0);
        let start = GpsTime::from_calendar(2005, 4, 2, 3, 0, 0.0);
        Ok(Self { nav_path, nav, klobuchar, traj, base, start })
    }

    /// Seed `seed`'s rover and base observations written as `rover.obs` and `base.obs`
    /// (RINEX 3.04, the base's position in its header) in `dir`, under `sky`; the rover's
    /// truth, one per second.
    pub fn write(&self, dir: &Path, seed: u64, sky: Sky) -> std::io::Result<Vec<RawTruth>> {
        let (rover, base, truth) = self.simulate(seed, sky);
        for (name, epochs, approx) in
            [("rover.obs", &rover, None), ("base.obs", &base, Some(&self.base))]
        {
            let mut w = std::io::BufWriter::new(std::fs::File::create(dir.join(name))?);
            write_rinex_obs(&mut w, epochs, approx)?;
        }
        Ok(truth)
    }
}

impl Drive {
    /// The trajectory.
    pub fn trajectory(&self) -> &Trajectory {
        &self.traj
    }

    /// Seed `seed`'s IMU samples of the drive with `errors`, from `exact` (the drive's
    /// [`ins_gnss_sim::ExactImu`] at 200 Hz), no GNSS.
    pub fn imu(
        &self,
        exact: &ins_gnss_sim::ExactImu,
        errors: &ins_gnss_sim::ImuErrors,
        seed: u64,
    ) -> ins_gnss_sim::SimDataset {
        let none = ins_gnss_sim::GnssSim::none();
        ins_gnss_sim::simulate_from(exact, &self.traj, errors, &none, 500 + seed)
    }

    /// Seed `seed`'s rover and base epochs under `sky`, and the rover's truth.
    pub fn simulate(&self, seed: u64, sky: Sky) -> (Vec<ObsEpoch>, Vec<ObsEpoch>, Vec<RawTruth>) {
        let mut sim = RawSim::spp_budget(self.start);
        match sky {
            Sky::Open => {}
            Sky::Tunnel => sim.masks = vec![SkyMask { start: TUNNEL.0, end: TUNNEL.1, keep: 0 }],
            Sky::Canyon => sim.masks = vec![SkyMask { start: CANYON.0, end: CANYON.1, keep: 3 }],
            Sky::Slips => (sim.slip_probability, sim.flag_slips) = (SLIPS, false),
        }
        simulate_rtk(
            &self.traj,
            &self.nav.ephemerides,
            &self.klobuchar,
            &sim,
            &RtkSim::new(self.base),
            1000 + seed,
        )
    }

    /// RTK alone (each epoch's single point the rover's start) over the epochs, against
    /// the truth.
    pub fn alone(
        &self,
        rover: &[ObsEpoch],
        base_obs: &[ObsEpoch],
        truth: &[RawTruth],
        opt: &RtkOptions,
        sky: Sky,
    ) -> Run {
        let (eph, kb, base) = (&self.nav.ephemerides, self.klobuchar, self.base);
        let base_at = |e: &ObsEpoch| base_obs.iter().find(|b| b.line == e.line);
        let outage_end = sky.outage_end();
        // RTK alone
        let mut alone = Run::default();
        let mut rtk = Rtk::new(base, opt.clone());
        let mut prior = None;
        for e in rover {
            let Some(b) = base_at(e) else { continue };
            let spp = single_point(e, eph, Some(&kb), &opt.spp, prior.as_ref()).ok();
            prior = spp.as_ref().map(|s| s.pos).or(prior);
            let t = e.line as f64;
            alone.epochs += 1;
            if let Ok(s) = rtk.step(e, b, eph, spp.map(|s| s.pos)) {
                let tr = &truth[e.line].antenna;
                alone.position(t, &ned_error(&s.pos, tr), outage_end);
                alone.solution(t, &s, tr, outage_end);
            }
        }
        alone
    }

    /// RTK with the INS: the IMU samples of `imu` (from the truth's start, with `noise`
    /// the filter's model), the filter started from the truth with σ 1°, 0.1 m/s, 3 m;
    /// each epoch the INS prediction is the RTK filter's prior, a fix what it adds beyond
    /// that prior (gated by the prediction, χ²₃ 99.9 %), a float epoch the single point
    /// when the INS knows less than it.
    #[allow(clippy::too_many_arguments)]
    pub fn with_ins(
        &self,
        data: &ins_gnss_sim::SimDataset,
        noise: ins_gnss_core::imu::ImuNoise,
        rover: &[ObsEpoch],
        base_obs: &[ObsEpoch],
        truth: &[RawTruth],
        opt: &RtkOptions,
        sky: Sky,
    ) -> Result<Run, Box<dyn std::error::Error>> {
        let (eph, kb, base) = (&self.nav.ephemerides, self.klobuchar, self.base);
        let base_at = |e: &ObsEpoch| base_obs.iter().find(|b| b.line == e.line);
        let outage_end = sky.outage_end();
        // RTK with the INS
        let mut with = Run::default();
        let init = InitialState {
            time: data.truth[0].t,
            state: data.truth[0].state.clone(),
            std: InitialStd {
                att: Vector3::repeat(1f64.to_radians()),
                vel: Vector3::repeat(0.1),
                pos: Vector3::repeat(3.0),
                bg: Vector3::repeat(1e-4),
                ba: Vector3::repeat(5e-3),
            },
        };
        let mut n =
            Navigator::new(&init, InsModel::wgs84(noise), FixedNoise, GnssConfig::default())?;
        let mut rtk = Rtk::new(base, opt.clone());
        let mut next = 0usize;
        let mut pending: Vec<GnssEpoch> = Vec::new();
        let mut out = Vec::new();
        let t0 = data.truth[0].t;
        for s in &data.imu {
            out.clear();
            n.process_into(s, &pending, &mut NoObserver, &mut out)?;
            pending.clear();
            while next < rover.len() && t0 + rover[next].line as f64 <= s.t + 1e-6 {
                let e = &rover[next];
                next += 1;
                let t = t0 + e.line as f64;
                if (t - s.t).abs() > 1e-6 {
                    continue;
                }
                let Some(b) = base_at(e) else { continue };
                let st = n.nav_state();
                let x = geodetic_to_ecef(st.pos.lat, st.pos.lon, st.pos.h);
                let c = ecef_to_ned_rotation(st.pos.lat, st.pos.lon);
                let p_ned: Matrix3<f64> = n.covariance().fixed_view::<3, 3>(6, 6).into_owned();
                let p = c.transpose() * p_ned * c;
                let tr = &truth[e.line].antenna;
                let ins_err = ned_error(&x, tr);
                with.epochs += 1;
                let rel = e.line as f64;
                with.position(rel, &ins_err, outage_end);
                if let Some(ch) = p_ned.cholesky() {
                    with.nees += ins_err.dot(&ch.solve(&ins_err));
                }
                let spp = single_point(e, eph, Some(&kb), &opt.spp, Some(&x)).ok();
                let Ok(sol) =
                    rtk.step_with_prior(e, b, eph, spp.as_ref().map(|s| s.pos), Some((x, p)))
                else {
                    continue;
                };
                with.solution(rel, &sol, tr, outage_end);
                // not fixed: the single point, whose errors the RTK filter's float
                // ambiguities do not share, as a leash only — when the INS knows its
                // position less well than one single point does (its errors persist
                // for minutes: their information does not add up over epochs)
                if !sol.fixed {
                    if let Some(f) = spp.map(|s| GnssEpoch::from_single_point(&s, t + 1e-6))
                        && p_ned.trace() > f.position_covariance().trace()
                    {
                        pending.push(f);
                    }
                    continue;
                }
                let Some((z, r)) = information_beyond((&x, &p), (&sol.pos, &sol.cov)) else {
                    continue;
                };
                // a fix the INS prediction contradicts (χ²₃ 99.9 %) is not used
                let d = z - x;
                let nis = (p + r).cholesky().map_or(f64::INFINITY, |c| d.dot(&c.solve(&d)));
                if nis > 16.27 {
                    with.gated += 1;
                    continue;
                }
                let (lat, lon, h) = ecef_to_geodetic(&z);
                let cz = ecef_to_ned_rotation(lat, lon);
                let r_ned = cz * r * cz.transpose();
                let mut g = GnssEpoch::new(
                    t + 1e-6,
                    GeoPos { lat, lon, h },
                    r_ned.diagonal().map(f64::sqrt),
                    None,
                );
                g.pos_cov = Some(r_ned);
                pending.push(g);
            }
        }
        Ok(with)
    }
}

/// One run of RTK alone or with the INS, against the truth.
#[derive(Clone, Debug, Default)]
pub struct Run {
    /// Rover epochs.
    pub epochs: usize,
    /// Fixed epochs.
    pub fixed: usize,
    /// Fixed epochs more than [`WRONG_FIX`] from the truth and outside their own
    /// covariance's χ²₃ 99.9 % ellipsoid (a canyon's fix knows some directions only).
    pub wrong: usize,
    /// The position's horizontal error², summed over the epochs (alone: the solution's;
    /// with the INS: its prediction at the epoch), and their count.
    pub h2: f64,
    /// (count)
    pub n: usize,
    /// The INS prediction's NEES, summed.
    pub nees: f64,
    /// The horizontal error at the first epoch after the outage (with the INS: its
    /// prediction there, what the outage left).
    pub end: Option<f64>,
    /// Seconds from the outage's end to the first fix.
    pub refix: Option<f64>,
    /// Fixes the INS prediction contradicted (not used).
    pub gated: usize,
}

impl Run {
    /// The position's error (NED) at trajectory time `t`: its horizontal part summed,
    /// and kept when it is the first after the outage ending at `outage_end`.
    fn position(&mut self, t: f64, err: &Vector3<f64>, outage_end: Option<f64>) {
        self.h2 += err.x * err.x + err.y * err.y;
        self.n += 1;
        if outage_end.is_some_and(|end| t >= end) && self.end.is_none() {
            self.end = Some(err.xy().norm());
        }
    }

    /// An RTK solution at trajectory time `t` against the true antenna `truth` (ECEF): a
    /// fixed one counted, wrong or not, and the first after the outage timed.
    fn solution(&mut self, t: f64, s: &RtkEpoch, truth: &Vector3<f64>, outage_end: Option<f64>) {
        if !s.fixed {
            return;
        }
        self.fixed += 1;
        let err = s.pos - truth;
        let outside = s.cov.cholesky().is_none_or(|c| err.dot(&c.solve(&err)) > 16.27);
        if err.norm() > WRONG_FIX && outside {
            self.wrong += 1;
        }
        if let Some(end) = outage_end.filter(|&end| t >= end) {
            self.refix.get_or_insert(t - end);
        }
    }

    /// Fixed over all epochs.
    pub fn fix_rate(&self) -> f64 {
        self.fixed as f64 / self.epochs.max(1) as f64
    }
}

fn ned_error(pos: &Vector3<f64>, truth: &Vector3<f64>) -> Vector3<f64> {
    let (lat, lon, _) = ecef_to_geodetic(truth);
    ecef_to_ned_rotation(lat, lon) * (pos - truth)
}

/// A solution as (GPS time of week, ECEF, fixed, its covariance in NED, m²).
pub type Solution = (f64, Vector3<f64>, bool, Matrix3<f64>);

/// An RTK run's solutions as [`Solution`]s.
pub fn solutions(run: &ins_gnss::rtk::RtkRun) -> Vec<Solution> {
    run.solutions
        .iter()
        .map(|s| {
            let (lat, lon, _) = ecef_to_geodetic(&s.pos);
            let c = ecef_to_ned_rotation(lat, lon);
            (s.time.tow, s.pos, s.fixed, c * s.cov * c.transpose())
        })
        .collect()
}

/// One run's figures against the truth.
#[derive(Clone, Debug, Default)]
pub struct Figures {
    /// Epochs solved.
    pub solved: usize,
    /// Epochs fixed.
    pub fixed: usize,
    /// Fixed epochs further than [`WRONG_FIX`] from the truth.
    pub wrong: usize,
    /// Sums of squares of the fixed epochs' horizontal and vertical errors, m².
    pub h2: f64,
    /// (vertical)
    pub v2: f64,
    /// Seconds from the first solution to the first fixed one.
    pub ttff: Option<f64>,
    /// Seconds from the tunnel's end to the first fix after it.
    pub refix: Option<f64>,
    /// The largest error of a fixed epoch (3D), m.
    pub worst: f64,
    /// The sum of the fixed epochs' errors (NED), m.
    pub sum: Vector3<f64>,
    /// The fixed epochs' NEES, summed, and how many lie beyond χ²₃'s 99 % (11.34).
    pub nees: f64,
    /// (beyond)
    pub beyond: usize,
}

/// The figures of solutions `sol` against the truth (one per second from `start`); the
/// time to the fix again after the tunnel under [`Sky::Tunnel`].
pub fn figures(sol: &[Solution], truth: &[RawTruth], start: GpsTime, sky: Sky) -> Figures {
    let tunnel = sky == Sky::Tunnel;
    let mut f = Figures::default();
    let first = sol.first().map(|s| s.0);
    for &(tow, pos, fixed, cov) in sol {
        let j = (tow - start.tow).round();
        let Some(tr) = (j >= 0.0).then(|| truth.get(j as usize)).flatten() else { continue };
        f.solved += 1;
        if !fixed {
            continue;
        }
        let (lat, lon, _) = ecef_to_geodetic(&tr.antenna);
        let d = ecef_to_ned_rotation(lat, lon) * (pos - tr.antenna);
        f.fixed += 1;
        f.sum += d;
        let nees = cov.cholesky().map_or(f64::INFINITY, |c| d.dot(&c.solve(&d)));
        f.nees += nees;
        f.beyond += usize::from(nees > 11.34);
        f.h2 += d.x * d.x + d.y * d.y;
        f.v2 += d.z * d.z;
        f.worst = f.worst.max(d.norm());
        if d.norm() > WRONG_FIX {
            f.wrong += 1;
        }
        if f.ttff.is_none() {
            f.ttff = first.map(|t0| tow - t0);
        }
        let t = tow - start.tow;
        if tunnel && t >= TUNNEL.1 && f.refix.is_none() {
            f.refix = Some(t - TUNNEL.1);
        }
    }
    f
}

/// The examples' switch `RTK_CODE_BIAS=σ[,τ]` (m, s; τ infinite when not given, σ 0: the
/// code white): the code biases as states set on `opt`, to compare (the tests do not use
/// it).
#[allow(dead_code)]
pub fn code_biases_from_env(opt: &mut RtkOptions) {
    if let Ok(v) = std::env::var("RTK_CODE_BIAS") {
        let mut it = v.split(',').map(|x| x.parse::<f64>().unwrap_or(0.0));
        opt.code_bias_sigma = it.next().unwrap_or(0.0);
        opt.code_bias_tau = it.next().unwrap_or(f64::INFINITY);
    }
}
