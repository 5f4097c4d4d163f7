//! Raw GNSS observations of a simulated trajectory: pseudorange, carrier phase, Doppler
//! and C/N0 per satellite on two frequencies, from the satellites of a real navigation
//! file, with a receiver clock, the atmosphere, noise, multipath outliers, cycle slips and
//! sky masks (an urban canyon that leaves the highest few satellites, a tunnel that leaves
//! none).
//!
//! The observation model is the one [`gnss::spp`] inverts:
//! `P = ρ + c·dt_r − c·dt_s + I + T + e_eph + e_code + ε` with `ρ` the geometric range from
//! the satellite at its transmission time to the antenna at the true reception time, with
//! the Sagnac term; the phase has `−I`, an integer ambiguity per arc and its own noise.
//! The errors are drawn from the single-point solution's error budget by default
//! ([`RawSim::spp_budget`]), so that its covariance can be checked (NEES) on this data.

use crate::trajectory::Trajectory;
use gnss::atmosphere::Klobuchar;
use gnss::ephemeris::{Ephemerides, C};
use gnss::obs::frequency;
use gnss::spp::Troposphere;
use gnss::spp::{azel, geometry, range_rate};
use gnss::{GpsTime, ObsEpoch, Sat, SatObs, Signal};
use ins_gnss_core::earth::{ecef_to_geodetic, geodetic_to_ecef};
use nalgebra::Vector3;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::{Distribution, Normal};
use std::collections::BTreeMap;

/// A sky mask over a time window (trajectory time, s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkyMask {
    /// Start, s.
    pub start: f64,
    /// End, s.
    pub end: f64,
    /// Satellites left: the `keep` highest (an urban canyon); 0 is a tunnel.
    pub keep: usize,
}

/// Settings of the raw-observation simulator.
#[derive(Clone, Debug, PartialEq)]
pub struct RawSim {
    /// GPS time of the trajectory's start.
    pub start: GpsTime,
    /// Observation rate, Hz.
    pub rate_hz: f64,
    /// Satellites below this elevation are not tracked, rad.
    pub elevation_mask: f64,
    /// Antenna lever arm (FRD), m.
    pub lever_arm: Vector3<f64>,
    /// Code noise `σ² = a² + b²/sin²(el)`: `(a, b)`, m.
    pub code_noise: (f64, f64),
    /// Carrier-phase noise, m.
    pub phase_std: f64,
    /// Doppler noise, m/s.
    pub doppler_std: f64,
    /// Receiver clock at the start: bias (m) and drift (m/s).
    pub clock: (f64, f64),
    /// Random-walk density of the clock drift, m/s/√s.
    pub clock_drift_noise: f64,
    /// σ of a constant range error per satellite and run (orbit and clock), m.
    pub ephemeris_std: f64,
    /// σ of a constant code bias per satellite and run, m.
    pub code_bias_std: f64,
    /// The true ionosphere is the broadcast model times `1 + δ`, `δ ~ N(0, σ²)` per
    /// satellite and run.
    pub iono_error: f64,
    /// The true troposphere is Saastamoinen's (mapped as this says: `Saastamoinen` by
    /// 1/sin(el), `Niell` by Niell's functions, `Off` none) plus `tropo_error`'s term.
    pub troposphere: Troposphere,
    /// The true troposphere is the mapped Saastamoinen delay plus `N(0, (k/(sin el +
    /// 0.1))²)` with this `k`, per satellite and run, m.
    pub tropo_error: f64,
    /// Probability per satellite and epoch of a multipath outlier on the code, and its
    /// size range (m, either sign).
    pub outliers: (f64, (f64, f64)),
    /// Probability per satellite and epoch of a cycle slip (loss-of-lock flag set).
    pub slip_probability: f64,
    /// Whether the receiver flags its slips (LLI); `false` leaves them for the data to
    /// reveal.
    pub flag_slips: bool,
    /// Sky masks.
    pub masks: Vec<SkyMask>,
    /// Draw the per-satellite errors (orbit, code bias, ionosphere, troposphere) afresh at
    /// every epoch instead of once per satellite and run: white errors, the model a filter
    /// that treats each epoch's code as independent assumes (for consistency checks).
    pub white_errors: bool,
}

impl RawSim {
    /// A receiver whose errors are drawn from the budget [`gnss::spp`]
    /// assumes with its default options: URA 2.4 m, 0.3 m code bias, half the Klobuchar
    /// delay, 0.3/(sin el + 0.1) m of troposphere, code noise 0.3 m ⊕ 0.3 m/sin el,
    /// Doppler 0.1 m/s; 1 Hz, 10° mask, no outliers, slips or masks.
    pub fn spp_budget(start: GpsTime) -> Self {
        Self {
            start,
            rate_hz: 1.0,
            elevation_mask: 10f64.to_radians(),
            lever_arm: Vector3::zeros(),
            code_noise: (0.3, 0.3),
            phase_std: 0.003,
            doppler_std: 0.1,
            clock: (3.0e4, 0.5),
            clock_drift_noise: 0.01,
            ephemeris_std: 2.4,
            code_bias_std: 0.3,
            iono_error: 0.5,
            troposphere: Troposphere::Saastamoinen,
            tropo_error: 0.3,
            outliers: (0.0, (20.0, 100.0)),
            slip_probability: 0.0,
            flag_slips: true,
            masks: Vec::new(),
            white_errors: false,
        }
    }
}

/// What the simulator knows that a receiver does not, per epoch.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawTruth {
    /// Trajectory time of the epoch, s.
    pub t: f64,
    /// True antenna position (ECEF), m.
    pub antenna: Vector3<f64>,
    /// True antenna velocity (ECEF), m/s.
    pub antenna_vel: Vector3<f64>,
    /// Receiver clock bias (m) and drift (m/s).
    pub clock: (f64, f64),
}

/// Per satellite and run: the constant errors and the phase arc.
struct Track {
    errors: SatErrors,
    /// The ionosphere's gradient under a shared sky (zero alone), m per m.
    gradient: Vector3<f64>,
    ambiguity: [f64; 2],
}

/// A satellite's range errors: orbit and clock (m), code bias (m), the ionosphere's factor
/// and the troposphere's error in units of its σ.
struct SatErrors {
    eph_bias: f64,
    code_bias: f64,
    iono_factor: f64,
    tropo_bias: f64,
}

impl SatErrors {
    fn draw(sim: &RawSim, n01: &Normal<f64>, rng: &mut StdRng) -> Self {
        Self {
            eph_bias: sim.ephemeris_std * n01.sample(rng),
            code_bias: sim.code_bias_std * n01.sample(rng),
            iono_factor: 1.0 + sim.iono_error * n01.sample(rng),
            tropo_bias: n01.sample(rng),
        }
    }
}

/// Simulates observations at `sim.rate_hz` over the trajectory: the epochs (receiver time
/// stamps = true time + clock bias / c, exactly as a receiver's) and the truth of each.
/// Deterministic for a seed.
pub fn simulate_raw(
    traj: &Trajectory,
    eph: &Ephemerides,
    klobuchar: &Klobuchar,
    sim: &RawSim,
    seed: u64,
) -> (Vec<ObsEpoch>, Vec<RawTruth>) {
    let antenna = |t: f64| antenna_of(traj, &sim.lever_arm, t);
    let span = (traj.start_time(), traj.end_time());
    observe(&antenna, span, eph, klobuchar, sim, seed, None)
}

/// The antenna's ECEF position and velocity at trajectory time `t` (the lever arm turned
/// by the attitude, its velocity by the body's and the frame's rotation).
fn antenna_of(traj: &Trajectory, lever_arm: &Vector3<f64>, t: f64) -> (Vector3<f64>, Vector3<f64>) {
    let k = traj.at(t);
    let lever_n = k.att.rotate(lever_arm);
    let ant = manifolds::Manifold::oplus(&k.pos, &lever_n);
    let rr = geodetic_to_ecef(ant.lat, ant.lon, ant.h);
    let c_en = ins_gnss_core::earth::ecef_to_ned_rotation(ant.lat, ant.lon).transpose();
    let w_in = ins_gnss_core::earth::earth_rate_ned(k.pos.lat)
        + ins_gnss_core::earth::transport_rate(k.pos.lat, k.pos.h, &k.vel);
    let v_ant_n = k.vel + k.att.rotate(&k.w_ib_b.cross(lever_arm)) - w_in.cross(&lever_n);
    (rr, c_en * v_ant_n)
}

/// A rover and a base station under one sky, for RTK: the satellites' orbit and clock
/// errors, the ionosphere's and troposphere's errors are the same at both receivers
/// (drawn once per satellite from the seed), except for a spatial gradient of the
/// ionosphere of `iono_gradient_ppm` (per satellite a random direction: the slant delay
/// on the first frequency differs by about that many millimetres per kilometre of
/// baseline); each receiver has its own clock, code biases (multipath), noise, ambiguities
/// and, for the rover, `sim`'s outliers, slips and sky masks.
#[derive(Clone, Debug, PartialEq)]
pub struct RtkSim {
    /// The base station's antenna (ECEF), m.
    pub base: Vector3<f64>,
    /// The base receiver's clock at the start: bias (m) and drift (m/s).
    pub base_clock: (f64, f64),
    /// The ionosphere's spatial gradient, mm per km of baseline (ppm) on the first
    /// frequency's slant delay, per satellite.
    pub iono_gradient_ppm: f64,
}

impl RtkSim {
    /// A base at `base` (ECEF, m), its clock −12 km and −0.3 m/s, a quiet mid-latitude
    /// ionosphere's gradient of 1 ppm.
    pub fn new(base: Vector3<f64>) -> Self {
        Self { base, base_clock: (-1.2e4, -0.3), iono_gradient_ppm: 1.0 }
    }
}

/// The observations of a rover on `traj` and of a base station as `rtk` says, over the
/// trajectory's span at `sim.rate_hz`: (rover epochs, base epochs, the rover's truth). The
/// base has no lever arm, outliers, slips or masks. Deterministic for a seed.
pub fn simulate_rtk(
    traj: &Trajectory,
    eph: &Ephemerides,
    klobuchar: &Klobuchar,
    sim: &RawSim,
    rtk: &RtkSim,
    seed: u64,
) -> (Vec<ObsEpoch>, Vec<ObsEpoch>, Vec<RawTruth>) {
    let sky = SharedSky { seed, base: rtk.base, iono_gradient_ppm: rtk.iono_gradient_ppm };
    let span = (traj.start_time(), traj.end_time());
    let antenna = |t: f64| antenna_of(traj, &sim.lever_arm, t);
    let (rover, truth) = observe(&antenna, span, eph, klobuchar, sim, seed, Some(&sky));
    let base_sim = RawSim {
        lever_arm: Vector3::zeros(),
        clock: rtk.base_clock,
        outliers: (0.0, sim.outliers.1),
        slip_probability: 0.0,
        masks: Vec::new(),
        ..sim.clone()
    };
    let fixed = |_: f64| (rtk.base, Vector3::zeros());
    let base_seed = seed ^ 0x0062_6173_655f_7278;
    let (base, _) = observe(&fixed, span, eph, klobuchar, &base_sim, base_seed, Some(&sky));
    (rover, base, truth)
}

/// What both receivers of an RTK pair share: per satellite, the orbit and clock error, the
/// ionosphere's factor and gradient and the troposphere's error, drawn from the seed and
/// the satellite alone (the same whichever receiver asks first).
struct SharedSky {
    seed: u64,
    base: Vector3<f64>,
    iono_gradient_ppm: f64,
}

impl SharedSky {
    /// `sat`'s errors at a receiver: the shared ones, its own code bias from `rng`; and
    /// the ionosphere's gradient (m of L1 slant delay per m of baseline).
    fn errors(
        &self,
        sat: Sat,
        sim: &RawSim,
        n01: &Normal<f64>,
        rng: &mut StdRng,
    ) -> (SatErrors, Vector3<f64>) {
        let key = ((sat.sys as u64) << 8) | u64::from(sat.prn);
        let mut own = StdRng::seed_from_u64(self.seed ^ 0x0073_6b79_0000_0000 ^ key);
        let errors = SatErrors {
            eph_bias: sim.ephemeris_std * n01.sample(&mut own),
            code_bias: sim.code_bias_std * n01.sample(rng),
            iono_factor: 1.0 + sim.iono_error * n01.sample(&mut own),
            tropo_bias: n01.sample(&mut own),
        };
        let g = Vector3::from_fn(|_, _| n01.sample(&mut own)) / 3f64.sqrt();
        (errors, g * self.iono_gradient_ppm * 1e-6)
    }
}

/// One receiver's observations over `span` (trajectory time, s) with its antenna's ECEF
/// position and velocity from `antenna`; the per-satellite errors its own, or shared with
/// another receiver under `sky`.
#[allow(clippy::too_many_arguments)]
fn observe(
    antenna: &dyn Fn(f64) -> (Vector3<f64>, Vector3<f64>),
    span: (f64, f64),
    eph: &Ephemerides,
    klobuchar: &Klobuchar,
    sim: &RawSim,
    seed: u64,
    sky: Option<&SharedSky>,
) -> (Vec<ObsEpoch>, Vec<RawTruth>) {
    let mut rng = StdRng::seed_from_u64(seed ^ 0x0072_6177_5f6f_6273);
    // outliers and slips on streams of their own: a run with them differs from the clean
    // run of the same seed by them alone
    let mut rng_faults = StdRng::seed_from_u64(seed ^ 0x0066_6175_6c74_7321);
    let n01 = Normal::new(0.0, 1.0).expect("unit normal");
    let mut tracks: BTreeMap<Sat, Track> = BTreeMap::new();
    let sats: Vec<Sat> = {
        let mut s: Vec<Sat> = eph.records().iter().map(|e| e.sat).collect();
        s.dedup();
        s
    };
    let (t0, t_end) = span;
    let step = 1.0 / sim.rate_hz;
    let n = ((t_end - t0) / step + 1e-9).floor() as usize;
    let (mut bias, mut drift) = sim.clock;
    let mut epochs = Vec::with_capacity(n + 1);
    let mut truth = Vec::with_capacity(n + 1);
    for j in 0..=n {
        let t = t0 + j as f64 * step;
        if j > 0 {
            drift += sim.clock_drift_noise * step.sqrt() * n01.sample(&mut rng);
            bias += drift * step;
        }
        let gps = sim.start.add(t - t0);
        let (rr, vr) = antenna(t);
        let (lat, lon, h) = ecef_to_geodetic(&rr);
        let mut visible: Vec<(f64, SatObs)> = Vec::new();
        for &sat in &sats {
            let Some(e) = eph.select(sat, &gps) else { continue };
            // transmission time: iterate on the geometric range
            let mut tau = 0.075;
            let mut st = e.state(&gps.add(-tau));
            for _ in 0..4 {
                tau = geometry(&st.pos, &rr).0 / C;
                st = e.state(&gps.add(-tau));
            }
            let (_, u) = geometry(&st.pos, &rr);
            let (az, el) = azel(lat, lon, &u);
            if el < sim.elevation_mask {
                tracks.remove(&sat);
                continue;
            }
            let range = tau * C;
            let draw = |rng: &mut StdRng| match sky {
                None => (SatErrors::draw(sim, &n01, rng), Vector3::zeros()),
                Some(sky) => sky.errors(sat, sim, &n01, rng),
            };
            if sim.white_errors
                && let Some(old) = tracks.get_mut(&sat)
            {
                (old.errors, old.gradient) = draw(&mut rng);
            }
            let tr = tracks.entry(sat).or_insert_with(|| {
                let (errors, gradient) = draw(&mut rng);
                Track {
                    errors,
                    gradient,
                    ambiguity: [
                        rng.random_range(-1e6..1e6f64).round(),
                        rng.random_range(-1e6..1e6f64).round(),
                    ],
                }
            });
            let gradient = sky.map_or(0.0, |s| tr.gradient.dot(&(rr - s.base)));
            let iono_l1 =
                klobuchar.delay(lat, lon, az, el, gps.tow) * tr.errors.iono_factor + gradient;
            let tropo = sim.troposphere.delay(lat, h, el, gps)
                + sim.tropo_error / (el.sin() + 0.1) * tr.errors.tropo_bias;
            // range rate with the Sagnac term's rate
            let rate = range_rate(&st.pos, &st.vel, &rr, &vr, &u);
            let (a, b) = sim.code_noise;
            let sin_el = el.sin().max(0.05);
            let code_sigma = (a * a + (b / sin_el).powi(2)).sqrt();
            let outlier = if sim.outliers.0 > 0.0 && rng_faults.random::<f64>() < sim.outliers.0 {
                let (lo, hi) = sim.outliers.1;
                rng_faults.random_range(lo..hi)
                    * if rng_faults.random::<bool>() { 1.0 } else { -1.0 }
            } else {
                0.0
            };
            let mut signals = [Signal::default(); 2];
            for (slot, s) in signals.iter_mut().enumerate() {
                let f = frequency(sat.sys, slot);
                let lambda = C / f;
                let iono = iono_l1 * (frequency(sat.sys, 0) / f).powi(2);
                // the broadcast clock's group delay belongs to the first frequency's code
                let tgd = if slot == 0 {
                    0.0
                } else {
                    e.group_delay() * C * ((frequency(sat.sys, 0) / f).powi(2) - 1.0)
                };
                let geometric = range + bias - C * st.clock + tropo + tr.errors.eph_bias;
                s.code = Some(
                    geometric
                        + iono
                        + tgd
                        + tr.errors.code_bias
                        + outlier
                        + code_sigma * n01.sample(&mut rng),
                );
                let mut lli = 0;
                if sim.slip_probability > 0.0 && rng.random::<f64>() < sim.slip_probability {
                    tr.ambiguity[slot] += rng.random_range(1..50) as f64
                        * if rng.random::<bool>() { 1.0 } else { -1.0 };
                    lli = u8::from(sim.flag_slips);
                }
                s.phase = Some(
                    (geometric - iono + sim.phase_std * n01.sample(&mut rng)) / lambda
                        + tr.ambiguity[slot],
                );
                s.lli = lli;
                s.doppler = Some(
                    -(rate + drift - C * st.drift + sim.doppler_std * n01.sample(&mut rng))
                        / lambda,
                );
                s.cn0 = Some(30.0 + 20.0 * sin_el - 3.0 * slot as f64);
            }
            visible.push((el, SatObs { sat, signals }));
        }
        // sky masks: the highest `keep` satellites
        let t_rel = t;
        if let Some(m) =
            sim.masks.iter().filter(|m| t_rel >= m.start && t_rel < m.end).map(|m| m.keep).min()
        {
            visible.sort_by(|a, b| b.0.total_cmp(&a.0));
            for (_, o) in visible.iter().skip(m) {
                tracks.remove(&o.sat);
            }
            visible.truncate(m);
            visible.sort_by_key(|v| v.1.sat);
        }
        truth.push(RawTruth { t, antenna: rr, antenna_vel: vr, clock: (bias, drift) });
        if visible.is_empty() {
            continue;
        }
        epochs.push(ObsEpoch {
            // the receiver stamps its own time: true time + clock bias
            time: gps.add(bias / C),
            flag: 0,
            sats: visible.into_iter().map(|v| v.1).collect(),
            line: j,
        });
    }
    (epochs, truth)
}

/// Writes epochs as a RINEX 3.04 observation file (GPS, Galileo, BeiDou, QZSS; two
/// frequencies: code, phase, Doppler, C/N0 each).
pub fn write_rinex_obs<W: std::io::Write>(
    w: &mut W,
    epochs: &[ObsEpoch],
    approx: Option<&Vector3<f64>>,
) -> std::io::Result<()> {
    let line = |w: &mut W, body: String, label: &str| writeln!(w, "{body:<60}{label}");
    line(
        w,
        format!("{:>9.2}{:11}{:<20}{:<20}", 3.04, "", "OBSERVATION DATA", "M: Mixed"),
        "RINEX VERSION / TYPE",
    )?;
    line(w, format!("{:<20}{:<20}{:<20}", "ins-gnss-sim", "", ""), "PGM / RUN BY / DATE")?;
    line(w, "SIM".into(), "MARKER NAME")?;
    let p = approx.copied().unwrap_or_else(Vector3::zeros);
    line(w, format!("{:14.4}{:14.4}{:14.4}", p.x, p.y, p.z), "APPROX POSITION XYZ")?;
    let types = |sys: char, b1: &str, b2: &str| {
        let t: Vec<String> = ["C", "L", "D", "S"]
            .iter()
            .flat_map(|k| [format!("{k}{b1}"), format!("{k}{b2}")])
            .collect();
        format!("{sys}  {:>3} {}", t.len(), t.join(" "))
    };
    for (sys, b1, b2) in
        [('G', "1C", "2W"), ('E', "1C", "5Q"), ('C', "2I", "6I"), ('J', "1C", "2L")]
    {
        line(w, types(sys, b1, b2), "SYS / # / OBS TYPES")?;
    }
    if let Some(first) = epochs.first() {
        let (y, m, d, h, mi, s) = first.time.calendar();
        line(w, format!("{y:>6}{m:>6}{d:>6}{h:>6}{mi:>6}{s:>13.7}     GPS"), "TIME OF FIRST OBS")?;
    }
    line(w, String::new(), "END OF HEADER")?;
    for e in epochs {
        let (y, m, d, h, mi, s) = e.time.calendar();
        writeln!(w, "> {y:04} {m:02} {d:02} {h:02} {mi:02}{s:11.7}  {}{:3}", e.flag, e.sats.len())?;
        for o in &e.sats {
            write!(w, "{}", o.sat)?;
            // order of the header: C1 C2 L1 L2 D1 D2 S1 S2
            let pick = |k: usize, s: &Signal| match k {
                0 => s.code,
                1 => s.phase,
                2 => s.doppler,
                _ => s.cn0,
            };
            for k in 0..4 {
                for s in &o.signals {
                    match pick(k, s) {
                        Some(v) if k == 1 && s.lli != 0 => write!(w, "{v:14.3}{}", s.lli)?,
                        Some(v) => write!(w, "{v:14.3} ")?,
                        None => write!(w, "{:15}", "")?,
                    }
                    write!(w, " ")?;
                }
            }
            writeln!(w)?;
        }
    }
    Ok(())
}

/// One UBX packet: sync, class, id, length, payload, Fletcher checksum.
fn ubx_packet(out: &mut Vec<u8>, class: u8, id: u8, payload: &[u8]) {
    let start = out.len();
    out.extend_from_slice(&[0xb5, 0x62, class, id]);
    out.extend_from_slice(&(payload.len() as u16).to_le_bytes());
    out.extend_from_slice(payload);
    let (mut a, mut b) = (0u8, 0u8);
    for byte in &out[start + 2..] {
        a = a.wrapping_add(*byte);
        b = b.wrapping_add(a);
    }
    out.extend_from_slice(&[a, b]);
}

/// An RXM-SFRBX packet (version 2): the system, satellite and signal, and the words.
fn sfrbx(out: &mut Vec<u8>, gnss_id: u8, sv_id: u8, sig_id: u8, words: &[u32]) {
    let mut p = Vec::with_capacity(8 + 4 * words.len());
    p.extend_from_slice(&[gnss_id, sv_id, sig_id, 0, words.len() as u8, 0, 2, 0]);
    for w in words {
        p.extend_from_slice(&w.to_le_bytes());
    }
    ubx_packet(out, 0x02, 0x13, &p);
}

/// Writes epochs as a u-blox log: an RXM-RAWX (version 1) per epoch, and for each GPS
/// satellite the RXM-SFRBX subframes 1–3 of its broadcast record
/// ([`gnss::lnav::encode`]), for each Galileo satellite the I/NAV pages of
/// word types 0–5 ([`gnss::inav`]), for each BeiDou MEO or IGSO satellite
/// the D1 subframes 1–3 and for each GEO the D2 pages 1–10 ([`gnss::bds`]),
/// before its first observation and whenever the record in use changes, with the broadcast
/// ionosphere (subframe 4 page 18) first. Signals: GPS L1 C/A (sigId 0) and L2 CL (sigId
/// 3), Galileo E1 B (sigId 1) and E5a I (sigId 3), BeiDou B1I (sigId 0); `leap`: GPS −
/// UTC, s.
pub fn write_ubx(
    epochs: &[ObsEpoch],
    eph: &Ephemerides,
    klobuchar: Option<&Klobuchar>,
    leap: i8,
) -> Vec<u8> {
    let mut out = Vec::new();
    // the ionosphere (subframe 4, page 18) once, from the first satellite
    if let (Some(k), Some(e)) = (klobuchar, epochs.first())
        && let Some(o) = e.sats.iter().find(|o| o.sat.sys == gnss::System::Gps)
    {
        let sf = gnss::lnav::encode_ionosphere(k, e.time.tow);
        sfrbx(&mut out, 0, o.sat.prn, 0, &sf);
    }
    let mut sent: BTreeMap<Sat, (i32, f64)> = BTreeMap::new();
    let mut lock: BTreeMap<(Sat, usize), (GpsTime, GpsTime)> = BTreeMap::new();
    for e in epochs {
        for o in &e.sats {
            let galileo = o.sat.sys == gnss::System::Galileo;
            let beidou = o.sat.sys == gnss::System::BeiDou;
            if o.sat.sys != gnss::System::Gps && !galileo && !beidou {
                continue;
            }
            let Some(r) = eph.select(o.sat, &e.time) else { continue };
            if sent.get(&o.sat) == Some(&(r.iode, r.toe.tow)) {
                continue;
            }
            sent.insert(o.sat, (r.iode, r.toe.tow));
            if galileo {
                // word types 0–4, 6 (GST − UTC) and 5 as E1-B I/NAV nominal pages (sigId 1)
                use gnss::inav;
                let [w0, w1, w2, w3, w4, w5] = inav::encode(r, e.time.tow);
                let utc = inav::encode_utc(leap, e.time.week, e.time.tow);
                // nine words, the ninth reserved (zero), as u-blox receivers send them and
                // RTKLIB's reader requires
                for w in [w0, w1, w2, w3, w4, utc, w5] {
                    let [a, b, c, d, f, g, h, i] = inav::encode_page(w);
                    sfrbx(&mut out, 2, o.sat.prn, 1, &[a, b, c, d, f, g, h, i, 0]);
                }
                continue;
            }
            if beidou {
                // D1 subframes 1–3 (sigId 0: B1I D1), or a GEO's D2 pages 1–10 (sigId 1:
                // B1I D2), timed in BDT
                use gnss::bds;
                let bdt = e.time.add(gnss::time::BDT_MINUS_GPST).tow;
                let geo = o.sat.beidou_geo();
                let frames = if geo {
                    bds::encode_d2(r, bdt).to_vec()
                } else {
                    bds::encode(r, bdt).to_vec()
                };
                for sf in frames {
                    sfrbx(&mut out, 3, o.sat.prn, u8::from(geo), &sf);
                }
                continue;
            }
            for sf in gnss::lnav::encode(r, e.time.tow) {
                sfrbx(&mut out, 0, o.sat.prn, 0, &sf);
            }
        }
        let mut p = Vec::with_capacity(16 + 64 * e.sats.len());
        p.extend_from_slice(&e.time.tow.to_le_bytes());
        p.extend_from_slice(&(e.time.week as u16).to_le_bytes());
        let meas: Vec<(Sat, usize, &Signal)> = e
            .sats
            .iter()
            .flat_map(|o| {
                o.signals
                    .iter()
                    .enumerate()
                    .filter(|(_, s)| s.code.is_some())
                    .map(move |(k, s)| (o.sat, k, s))
            })
            .collect();
        p.extend_from_slice(&[leap as u8, meas.len() as u8, 1, 1, 0, 0]);
        for (sat, k, s) in meas {
            let (gnss_id, sig_id) = match (sat.sys, k) {
                (gnss::System::Gps, 0) => (0u8, 0u8),
                (gnss::System::Gps, _) => (0, 3),
                (gnss::System::Galileo, 0) => (2, 1),
                (gnss::System::Galileo, _) => (2, 3),
                (gnss::System::BeiDou, _) => (3, 0),
                (gnss::System::Qzss, 0) => (5, 0),
                (_, _) => (5, 4),
            };
            // lock time: from the arc's start (a slip, or the satellite back after a gap)
            let entry = lock.entry((sat, k)).or_insert((e.time, e.time));
            if s.lli & 1 != 0 || e.time.diff(&entry.1) > 1.5 {
                entry.0 = e.time;
            }
            entry.1 = e.time;
            let lock_ms = (e.time.diff(&entry.0) * 1000.0).clamp(0.0, 64_500.0) as u16;
            p.extend_from_slice(&s.code.unwrap_or(0.0).to_le_bytes());
            // (a BeiDou GEO's phase half a cycle short, as u-blox receivers give it)
            let half = if sat.beidou_geo() { 0.5 } else { 0.0 };
            p.extend_from_slice(&s.phase.map_or(0.0, |l| l - half).to_le_bytes());
            p.extend_from_slice(&(s.doppler.unwrap_or(0.0) as f32).to_le_bytes());
            let cn0 = s.cn0.unwrap_or(0.0).round().clamp(0.0, 255.0) as u8;
            let trk = 1 | if s.phase.is_some() { 2 | 4 } else { 0 };
            p.extend_from_slice(&[gnss_id, sat.prn, sig_id, 0]);
            p.extend_from_slice(&lock_ms.to_le_bytes());
            p.extend_from_slice(&[cn0, 5, 2, 4, trk, 0]);
        }
        ubx_packet(&mut out, 0x02, 0x15, &p);
    }
    out
}
