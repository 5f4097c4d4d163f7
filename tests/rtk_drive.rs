//! Simulated RTK drives shared by `tests/rtk.rs` and `examples/rtk_corpus.rs`: a rover on
//! the 630 s drive of `ins_gnss_sim::scenarios::drive_600s` (1 Hz, the shipped navigation
//! file's GPS satellites on 2005-04-02 03:00), a base station 3.5 km north and 3.5 km east
//! of its start (the baseline 1.6–4.9 km over the drive), both receivers under one sky
//! (`ins_gnss_sim::raw::simulate_rtk`: the single point's error budget, its orbit, clock
//! and atmosphere errors shared, a 1 ppm ionospheric gradient; each receiver its own
//! clock, code biases, noise and ambiguities), and each run's figures against the truth.

use std::path::{Path, PathBuf};

use ins_gnss_core::earth::{ecef_to_geodetic, ecef_to_ned_rotation, geodetic_to_ecef};
use ins_gnss_core::raw::atmosphere::Klobuchar;
use ins_gnss_core::raw::{read_nav, GpsTime, NavData};
use ins_gnss_sim::raw::{simulate_rtk, write_rinex_obs, RawSim, RawTruth, RtkSim, SkyMask};
use ins_gnss_sim::{scenarios, Trajectory};
use nalgebra::Vector3;

/// A fixed epoch further than this from the truth (3D, m) is a wrong fix: an L1 cycle is
/// 19 cm, a wrong integer moves the position by decimetres.
pub const WRONG_FIX: f64 = 0.10;

/// The tunnel of the tunnel cells: no satellite from 300 to 330 s.
pub const TUNNEL: (f64, f64) = (300.0, 330.0);

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
        let mut sim = RawSim::spp_budget(self.start);
        match sky {
            Sky::Open => {}
            Sky::Tunnel => sim.masks = vec![SkyMask { start: TUNNEL.0, end: TUNNEL.1, keep: 0 }],
            Sky::Slips => (sim.slip_probability, sim.flag_slips) = (SLIPS, false),
        }
        let (rover, base, truth) = simulate_rtk(
            &self.traj,
            &self.nav.ephemerides,
            &self.klobuchar,
            &sim,
            &RtkSim::new(self.base),
            1000 + seed,
        );
        for (name, epochs, approx) in
            [("rover.obs", &rover, None), ("base.obs", &base, Some(&self.base))]
        {
            let mut w = std::io::BufWriter::new(std::fs::File::create(dir.join(name))?);
            write_rinex_obs(&mut w, epochs, approx)?;
        }
        Ok(truth)
    }
}

/// A solution as (GPS time of week, ECEF, fixed).
pub type Solution = (f64, Vector3<f64>, bool);

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
}

/// The figures of solutions `sol` against the truth (one per second from `start`); the
/// time to the fix again after the tunnel under [`Sky::Tunnel`].
pub fn figures(sol: &[Solution], truth: &[RawTruth], start: GpsTime, sky: Sky) -> Figures {
    let tunnel = sky == Sky::Tunnel;
    let mut f = Figures::default();
    let first = sol.first().map(|s| s.0);
    for &(tow, pos, fixed) in sol {
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
