//! GNSS-only RTK: a rover's position relative to a base station of known position from
//! double-differenced pseudoranges and carrier phases, the ambiguities as float states of a
//! Kalman filter, resolved to integers by [`super::lambda`] with the ratio test.
//!
//! Per epoch (the rover, and the base at the same instant or up to `max_age` before):
//!
//! - the satellites both receivers track with code and phase on each frequency used, above
//!   the elevation mask at the base; each one's state at its transmission time, for each
//!   receiver (the base's range from its known position);
//! - single differences (rover − base) remove the satellite clock and orbit error and,
//!   over a short baseline, the atmosphere; double differences against the highest
//!   satellite remove the receivers' clocks. The states: the rover's ECEF position and, per
//!   satellite and frequency, the single-differenced ambiguity in metres (its double
//!   difference is what the data tell). A new satellite, one whose phase either receiver
//!   flags (LLI), one missing the epoch before, one whose phase left its receiver's
//!   integrated Doppler by [`DOPPLER_SLIP`] or whose geometry-free combination jumped by
//!   [`GF_SLIP`], and every satellite after a gap of more than [`GAP_INTERVALS`] intervals
//!   start again with the code's value and a σ of [`AMBIGUITY_SIGMA0`];
//! - per satellite and frequency, the single-differenced code bias (the two receivers'
//!   multipath and code biases: decimetres that persist for minutes), a first-order
//!   Gauss–Markov state of σ [`RtkOptions::code_bias_sigma`] and correlation time
//!   [`RtkOptions::code_bias_tau`] (0.3 m, 60 s), started at 0 with a new satellite, one
//!   missed, or a gap — what the double-differenced code cannot tell the ambiguities (taken
//!   as white noise, the float ambiguities converge on the code's biases and the ratio test
//!   fixes them wrongly);
//! - the modelled single difference: each receiver's range to the satellite at its own
//!   transmission time, minus the satellite clock then, plus the troposphere at that
//!   receiver's height and elevation ([`RtkOptions::troposphere`], as RTKLIB's relative
//!   positioning models it: centimetres of height where the two stand at different
//!   heights);
//! - the update (iterated once, linearized at its own first result: the troposphere
//!   depends on the rover's height) takes the double differences with their covariance (the reference
//!   satellite's noise is common to all: `R = D diag(σ²_sd) Dᵀ`), σ of a single difference
//!   `√2 (a² + b²/sin² el)^{½}` with RTKLIB's defaults (a = b = 3 mm for phase, the code
//!   100× the phase);
//! - the double-differenced ambiguities in cycles, `â = G b`, `Q = G P Gᵀ`, are searched
//!   for the two best integer vectors; when the second's squared norm is at least
//!   [`RtkOptions::ratio`] times the best's, the position is conditioned on the best:
//!   `x̌ = x̂ − P_xa Q⁻¹ (â − ǎ)`, `P̌ = P_xx − P_xa Q⁻¹ P_ax` (fixed, Q = 1); otherwise
//!   the float solution is the answer (Q = 2);
//! - fix-and-hold ([`RtkOptions::hold`], two frequencies): after 5 fixes in a row, a fix
//!   whose float covariance promised a success rate of [`HOLD_SUCCESS_RATE`] goes back
//!   into the filter as measurements of its double-differenced ambiguities, which keep it.
//!
//! Static mode keeps the position as a constant; kinematic mode restarts it each epoch
//! from the rover's single point (σ 30 m), or from a prior the caller knows better (an
//! INS prediction: [`Rtk::step_with_prior`], and [`information_beyond`] for what the epoch
//! adds to it), and keeps the ambiguities. Partial fixing is [`RtkOptions::partial`]. Not
//! here yet (issue 74): the ambiguities as states of the INS filter itself.

use std::collections::HashMap;

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use super::ephemeris::C;
use super::lambda;
use super::obs::{frequency, ObsEpoch};
use super::spp::{azel, geometry, prepare, Prepared, Troposphere};
use super::{Ephemerides, GpsTime, Sat};
use crate::geodesy::ecef_to_geodetic;

mod metrics;
mod options;
mod resolve;

pub use metrics::*;
pub use options::*;

/// One epoch's solution.
#[derive(Clone, Debug, PartialEq)]
pub struct RtkEpoch {
    /// The rover's time stamp.
    pub time: GpsTime,
    /// The rover's ECEF position, m.
    pub pos: Vector3<f64>,
    /// Its covariance, m².
    pub cov: Matrix3<f64>,
    /// The ambiguities resolved (the ratio test passed), all or a subset.
    pub fixed: bool,
    /// How many double-differenced ambiguities (or, partially fixed, their integer
    /// combinations) the position is conditioned on; 0 when float.
    pub fixed_ambiguities: usize,
    /// The ratio of the integer search (NaN: not searched).
    pub ratio: f64,
    /// Satellites in the double differences.
    pub sats: usize,
}

/// Why an epoch has no solution.
#[derive(Clone, Debug, PartialEq)]
pub enum RtkFailure {
    /// Fewer than two satellites common to both receivers with phase and code.
    TooFewSatellites(usize),
    /// The rover has no single point yet (its first position).
    NoSinglePoint,
    /// The update's innovation covariance is not positive definite.
    Singular,
}

impl RtkFailure {
    /// The reason in words, as a run's failures count it.
    pub fn reason(&self) -> &'static str {
        match self {
            RtkFailure::TooFewSatellites(_) => "too few common satellites",
            RtkFailure::NoSinglePoint => "no single point yet",
            RtkFailure::Singular => "singular update",
        }
    }
}

/// What an epoch's solution `post` (ECEF position and covariance) adds to the `prior` it
/// started from, as an independent measurement of the position: `R⁻¹ = P_post⁻¹ −
/// P_prior⁻¹`, `z = x_prior + R P_post⁻¹ (x_post − x_prior)` (the information form of the
/// Kalman update, run backwards). A direction in which the observations added less than
/// [`LEAST_INFORMATION`] (fewer double differences than dimensions: a canyon) gets that
/// much, a variance no update notices. `None` when they added nothing.
pub fn information_beyond(
    prior: (&Vector3<f64>, &Matrix3<f64>),
    post: (&Vector3<f64>, &Matrix3<f64>),
) -> Option<(Vector3<f64>, Matrix3<f64>)> {
    let post_inv = post.1.cholesky()?.inverse();
    let prior_inv = prior.1.cholesky()?.inverse();
    let info = post_inv - prior_inv;
    let eig = ((info + info.transpose()) * 0.5).symmetric_eigen();
    if eig.eigenvalues.max() <= LEAST_INFORMATION {
        return None;
    }
    let var = eig.eigenvalues.map(|l| 1.0 / l.max(LEAST_INFORMATION));
    let r = eig.eigenvectors * Matrix3::from_diagonal(&var) * eig.eigenvectors.transpose();
    let z = prior.0 + r * post_inv * (post.0 - prior.0);
    Some((z, (r + r.transpose()) * 0.5))
}

/// The least information (1/m²) [`information_beyond`] gives a direction: a σ of 1 km.
pub const LEAST_INFORMATION: f64 = 1e-6;

/// One satellite and frequency in both receivers: the single differences (m) and what
/// the model needs.
#[derive(Clone, Copy, Debug)]
struct Common {
    key: (Sat, usize),
    code: f64,
    phase: f64,
    wavelength: f64,
    elevation: f64,
    rover: Prepared,
    base: Prepared,
    slipped: bool,
    /// Each receiver's (rover, base) phase (cycles) and Doppler (Hz).
    raw: [(f64, Option<f64>); 2],
}

/// A phase that moved more than this (m) from where the receiver's own Doppler, integrated
/// over at most [`DOPPLER_SPAN`], puts it has slipped (with the simulator's 0.1 m/s Doppler
/// noise the integral's σ over 1 s is 0.07 m; the smallest slip it sees is 3 L1 cycles).
pub const DOPPLER_SLIP: f64 = 0.5;

/// The longest interval (s) over which the Doppler is integrated to check the phase.
pub const DOPPLER_SPAN: f64 = 2.0;

/// A geometry-free combination of the single differences (L1 − L2 phase, m) that moved
/// more than this between consecutive epochs has slipped on one of the frequencies
/// (RTKLIB's default threshold; the ionosphere's change over a second is millimetres).
pub const GF_SLIP: f64 = 0.05;

/// The filter over epochs.
#[derive(Clone, Debug)]
pub struct Rtk {
    opt: RtkOptions,
    base: Vector3<f64>,
    x: DVector<f64>,
    p: DMatrix<f64>,
    /// The state index of each satellite and frequency's ambiguity, and the epoch it was
    /// last used in.
    slots: HashMap<(Sat, usize), (usize, u64)>,
    /// The same for each satellite and frequency's code bias
    /// ([`RtkOptions::code_bias_sigma`] > 0).
    biases: HashMap<(Sat, usize), (usize, u64)>,
    epoch: u64,
    started: bool,
    /// Consecutive fixed epochs.
    fixed_run: usize,
    /// The last epoch's time and the shortest interval between epochs seen (s).
    last: Option<(GpsTime, f64)>,
    /// Each satellite, frequency and receiver's (rover: `true`) last phase (cycles) and
    /// Doppler (Hz), and when.
    phases: HashMap<(Sat, usize, bool), LastPhase>,
    /// Each satellite's last geometry-free combination of the single differences (m), and
    /// the epoch.
    gf: HashMap<Sat, (u64, f64)>,
}

/// A receiver's last phase of a satellite and frequency: when, the phase (cycles) and the
/// Doppler (Hz).
type LastPhase = (GpsTime, f64, Option<f64>);

/// A gap of more than this many intervals between epochs restarts every ambiguity (the
/// receivers cannot be trusted to have kept lock, nor to flag it when they lost it).
pub const GAP_INTERVALS: f64 = 2.5;

impl Rtk {
    /// A filter for a base at ECEF `base` (m).
    pub fn new(base: Vector3<f64>, opt: RtkOptions) -> Self {
        Self {
            opt,
            base,
            x: DVector::zeros(3),
            p: DMatrix::identity(3, 3) * POSITION_SIGMA0.powi(2),
            slots: HashMap::new(),
            biases: HashMap::new(),
            epoch: 0,
            started: false,
            fixed_run: 0,
            last: None,
            phases: HashMap::new(),
            gf: HashMap::new(),
        }
    }

    /// The epoch of rover and base (the base at the same instant or up to
    /// [`RtkOptions::max_age`] before), with the rover's single
    /// point `spp` (ECEF, m) when there is one (the start; kinematic mode each epoch, the
    /// position free again around it, or around the last one without it).
    pub fn step(
        &mut self,
        rover: &ObsEpoch,
        base: &ObsEpoch,
        eph: &Ephemerides,
        spp: Option<Vector3<f64>>,
    ) -> Result<RtkEpoch, RtkFailure> {
        self.step_with_prior(rover, base, eph, spp, None)
    }

    /// Whether the data had a gap before `time` (more than [`GAP_INTERVALS`] of the
    /// shortest interval seen): every ambiguity starts again after one.
    fn gap(&mut self, time: GpsTime) -> bool {
        match self.last {
            Some((t, interval)) => {
                let dt = time.diff(&t);
                self.last = Some((time, if dt > 1e-3 { interval.min(dt) } else { interval }));
                dt > GAP_INTERVALS * interval
            }
            None => {
                self.last = Some((time, f64::INFINITY));
                false
            }
        }
    }

    /// Each common satellite's ambiguity its slot (a new one grown), started again from
    /// the code when new, slipped, missed at the last epoch or after a `gap`.
    fn restart_ambiguities(&mut self, common: &[Common], gap: bool) {
        for c in common {
            let fresh = match self.slots.get(&c.key) {
                Some(&(_, last)) => gap || c.slipped || last + 1 < self.epoch,
                None => true,
            };
            let i = match self.slots.get(&c.key) {
                Some(&(i, _)) => i,
                None => self.grow(),
            };
            if fresh {
                self.restart(i, c.phase - c.code, AMBIGUITY_SIGMA0.powi(2));
            }
            self.slots.insert(c.key, (i, self.epoch));
        }
        if self.opt.code_bias_sigma <= 0.0 {
            return;
        }
        for c in common {
            let (i, fresh) = match self.biases.get(&c.key) {
                Some(&(i, last)) => (i, gap || last + 1 < self.epoch),
                None => (self.grow(), true),
            };
            if fresh {
                self.restart(i, 0.0, self.opt.code_bias_sigma.powi(2));
            }
            self.biases.insert(c.key, (i, self.epoch));
        }
    }

    /// The code biases' Gauss–Markov step over `dt` seconds.
    fn propagate_biases(&mut self, dt: f64) {
        let (sigma, tau) = (self.opt.code_bias_sigma, self.opt.code_bias_tau);
        if sigma <= 0.0 || !tau.is_finite() || dt <= 0.0 {
            return;
        }
        let phi = (-dt / tau).exp();
        let idx: Vec<usize> = self.biases.values().map(|&(i, _)| i).collect();
        for i in idx {
            self.x[i] *= phi;
            self.p.row_mut(i).scale_mut(phi);
            self.p.column_mut(i).scale_mut(phi);
            self.p[(i, i)] += sigma * sigma * (1.0 - phi * phi);
        }
    }

    /// [`step`](Self::step) with, in kinematic mode, the rover's position known beforehand
    /// — `prior`: an INS filter's prediction (ECEF, m, and its covariance, m²) — as the
    /// position's start instead of the single point with σ [`POSITION_SIGMA0`]. What the
    /// epoch's observations add to the prior is [`information_beyond`] the prior.
    pub fn step_with_prior(
        &mut self,
        rover: &ObsEpoch,
        base: &ObsEpoch,
        eph: &Ephemerides,
        spp: Option<Vector3<f64>>,
        prior: Option<(Vector3<f64>, Matrix3<f64>)>,
    ) -> Result<RtkEpoch, RtkFailure> {
        self.epoch += 1;
        let kinematic = self.opt.mode == RtkMode::Kinematic;
        if !self.started && spp.is_none() && prior.is_none() {
            return Err(RtkFailure::NoSinglePoint);
        }
        // (kinematic: the position free again, around the prior, the single point or,
        // without either, where it was)
        if !self.started || kinematic {
            let (start, cov) = match (prior, spp) {
                (Some((x, p)), _) => (Some(x), p),
                (None, s) => (s, Matrix3::identity() * POSITION_SIGMA0.powi(2)),
            };
            if let Some(s) = start {
                self.x.fixed_rows_mut::<3>(0).copy_from(&s);
            }
            let n = self.x.len();
            self.p.view_mut((0, 0), (3, n)).fill(0.0);
            self.p.view_mut((0, 0), (n, 3)).fill(0.0);
            self.p.fixed_view_mut::<3, 3>(0, 0).copy_from(&cov);
            self.started = true;
        }
        let mut common = self.common(rover, base, eph);
        self.detect_slips(&mut common, rover.time, base.time);
        if let Some((t, _)) = self.last {
            self.propagate_biases(rover.time.diff(&t));
        }
        let gap = self.gap(rover.time);
        self.restart_ambiguities(&common, gap);
        let mut used = 0;
        let mut groups = Vec::new();
        for f in 0..self.opt.frequencies {
            // (highest first: the first of a group is its reference satellite)
            let mut g: Vec<Common> = common.iter().filter(|c| c.key.1 == f).copied().collect();
            g.sort_by(|a, b| b.elevation.total_cmp(&a.elevation));
            if g.len() >= 2 {
                used = used.max(g.len());
                groups.push(g);
            }
        }
        if groups.is_empty() {
            return Err(RtkFailure::TooFewSatellites(common.len()));
        }
        let (x0, p0) = (self.x.clone(), self.p.clone());
        self.update(&groups, rover.time, &x0)?;
        if self.opt.troposphere != Troposphere::Off {
            // once more from the same prior, linearized where the first update put the
            // rover: the troposphere's model depends on its height, which the single point
            // has metres off
            let lin = std::mem::replace(&mut self.x, x0);
            self.p = p0;
            self.update(&groups, rover.time, &lin)?;
        }
        let (solved, fix) = self.resolve(rover.time, &groups, used);
        self.fixed_run = if solved.fixed { self.fixed_run + 1 } else { 0 };
        // (held only where a slip can be seen: the geometry-free combination of two
        // frequencies; a single frequency's slip of a cycle or two passes the Doppler's test
        // and a held ambiguity would carry it)
        if let (Some(after), Some(fix)) = (self.opt.hold, fix)
            && self.fixed_run >= after
            && self.opt.frequencies >= 2
        {
            self.hold(&fix);
        }
        Ok(solved)
    }

    /// A new ambiguity state (zero, uncorrelated); its index.
    fn grow(&mut self) -> usize {
        let n = self.x.len();
        self.x = self.x.clone().insert_row(n, 0.0);
        self.p = self.p.clone().insert_row(n, 0.0).insert_column(n, 0.0);
        n
    }

    /// The satellites and frequencies both receivers track with code and phase, above
    /// the mask at the base.
    fn common(&self, rover: &ObsEpoch, base: &ObsEpoch, eph: &Ephemerides) -> Vec<Common> {
        let (r, _) = prepare(rover, eph, &self.opt.spp);
        let (b, _) = prepare(base, eph, &self.opt.spp);
        let (lat, lon, _) = ecef_to_geodetic(&self.base);
        let mut out = Vec::new();
        for rp in &r {
            let Some(bp) = b.iter().find(|p| p.sat == rp.sat) else { continue };
            let (Some(ro), Some(bo)) = (
                rover.sats.iter().find(|o| o.sat == rp.sat),
                base.sats.iter().find(|o| o.sat == rp.sat),
            ) else {
                continue;
            };
            let (_, e) = geometry(&bp.state.pos, &self.base);
            let (_, el) = azel(lat, lon, &e);
            if el < self.opt.elevation_mask {
                continue;
            }
            for f in 0..self.opt.frequencies.min(2) {
                let (rs, bs) = (&ro.signals[f], &bo.signals[f]);
                let (Some(rc), Some(rl), Some(bc), Some(bl)) =
                    (rs.code, rs.phase, bs.code, bs.phase)
                else {
                    continue;
                };
                let wavelength = C / frequency(rp.sat.sys, f);
                out.push(Common {
                    key: (rp.sat, f),
                    code: rc - bc,
                    phase: (rl - bl) * wavelength,
                    wavelength,
                    elevation: el,
                    rover: *rp,
                    base: *bp,
                    slipped: (rs.lli | bs.lli) & 1 != 0,
                    raw: [(rl, rs.doppler), (bl, bs.doppler)],
                });
            }
        }
        out
    }

    /// Marks as slipped the phases that left their Doppler's prediction (each receiver) or
    /// whose satellite's geometry-free combination jumped (two frequencies), beside the
    /// receivers' own flags; remembers this epoch's phases.
    fn detect_slips(&mut self, common: &mut [Common], rover: GpsTime, base: GpsTime) {
        for c in common.iter_mut() {
            for (k, time) in [(0, rover), (1, base)] {
                let (phase, doppler) = c.raw[k];
                let key = (c.key.0, c.key.1, k == 0);
                if let Some((t0, phase0, Some(d0))) = self.phases.get(&key).copied() {
                    let dt = time.diff(&t0);
                    if let (Some(d), true) = (doppler, dt > 0.0 && dt <= DOPPLER_SPAN) {
                        let predicted = phase0 - 0.5 * (d0 + d) * dt;
                        c.slipped |= ((phase - predicted) * c.wavelength).abs() > DOPPLER_SLIP;
                    }
                }
                self.phases.insert(key, (time, phase, doppler));
            }
        }
        let mut slipped = Vec::new();
        for c in common.iter().filter(|c| c.key.1 == 0) {
            let Some(c2) = common.iter().find(|d| d.key == (c.key.0, 1)) else { continue };
            let gf = c.phase - c2.phase;
            if let Some(&(epoch, gf0)) = self.gf.get(&c.key.0)
                && epoch + 1 == self.epoch
                && (gf - gf0).abs() > GF_SLIP
            {
                slipped.push(c.key.0);
            }
            self.gf.insert(c.key.0, (self.epoch, gf));
        }
        for c in common.iter_mut().filter(|c| slipped.contains(&c.key.0)) {
            c.slipped = true;
        }
    }

    /// One receiver's phase variance at elevation `el` (m²).
    fn phase_variance(&self, el: f64) -> f64 {
        let (a, b) = self.opt.phase_sigma;
        a * a + (b / el.sin().max(0.05)).powi(2)
    }

    /// The Kalman update on the double differences of each frequency's group (the first
    /// of a group, its highest satellite, is the reference), the model linearized at the
    /// state `lin` (an iterated update's step: the prior is `self.x`).
    fn update(
        &mut self,
        groups: &[Vec<Common>],
        time: GpsTime,
        lin: &DVector<f64>,
    ) -> Result<(), RtkFailure> {
        let n = self.x.len();
        let rover = Vector3::new(lin[0], lin[1], lin[2]);
        let (lat_r, lon_r, h_r) = ecef_to_geodetic(&rover);
        let (lat_b, lon_b, h_b) = ecef_to_geodetic(&self.base);
        let tropo = self.opt.troposphere;
        let rows: usize = groups.iter().map(|g| 2 * (g.len() - 1)).sum();
        let (mut h, mut v, mut r) =
            (DMatrix::zeros(rows, n), DVector::zeros(rows), DMatrix::zeros(rows, rows));
        let mut row = 0;
        for g in groups {
            // the single differences' modelled values and their rover Jacobians: each
            // receiver's range to the satellite at its own transmission time, minus the
            // satellite clock then (they cancel only when both observe at the same
            // instant), plus the troposphere at that receiver
            let model: Vec<(f64, Vector3<f64>)> = g
                .iter()
                .map(|c| {
                    let (rr, e) = geometry(&c.rover.state.pos, &rover);
                    let (rb, eb) = geometry(&c.base.state.pos, &self.base);
                    let (_, el_r) = azel(lat_r, lon_r, &e);
                    let (_, el_b) = azel(lat_b, lon_b, &eb);
                    let t_r = tropo.delay(lat_r, h_r, el_r, time);
                    let t_b = tropo.delay(lat_b, h_b, el_b, time);
                    (rr - C * c.rover.state.clock + t_r - (rb - C * c.base.state.clock + t_b), -e)
                })
                .collect();
            let var: Vec<f64> = g.iter().map(|c| 2.0 * self.phase_variance(c.elevation)).collect();
            let k = g.len() - 1;
            for (phase, block) in [(true, row), (false, row + k)] {
                let scale = if phase { 1.0 } else { self.opt.code_over_phase.powi(2) };
                for s in 1..g.len() {
                    let i = block + s - 1;
                    let range = model[s].0 - model[0].0;
                    let obs = if phase { g[s].phase - g[0].phase } else { g[s].code - g[0].code };
                    let mut pred = range;
                    for c in 0..3 {
                        h[(i, c)] = model[s].1[c] - model[0].1[c];
                    }
                    // (the phase's ambiguities; the code's biases, when they are states)
                    let states = if phase { &self.slots } else { &self.biases };
                    if let (Some(&(js, _)), Some(&(j0, _))) =
                        (states.get(&g[s].key), states.get(&g[0].key))
                    {
                        pred += lin[js] - lin[j0];
                        h[(i, js)] = 1.0;
                        h[(i, j0)] = -1.0;
                    }
                    v[i] = obs - pred;
                    for t in 1..g.len() {
                        r[(i, block + t - 1)] = scale * var[0];
                    }
                    r[(i, i)] += scale * var[s];
                }
            }
            row += 2 * k;
        }
        // (the innovation about the prior: z − h(lin) − H (prior − lin))
        v += &h * (lin - &self.x);
        let s = &h * &self.p * h.transpose() + &r;
        let chol = s.cholesky().ok_or(RtkFailure::Singular)?;
        self.correct(&h, &v, &r, chol.inverse());
        Ok(())
    }

    /// The Kalman correction of the states by the innovation `v` of the measurements `h x`
    /// with noise `r`, given the innovation covariance's inverse `s_inv` (Joseph's form).
    fn correct(
        &mut self,
        h: &DMatrix<f64>,
        v: &DVector<f64>,
        r: &DMatrix<f64>,
        s_inv: DMatrix<f64>,
    ) {
        let n = self.x.len();
        let k = &self.p * h.transpose() * s_inv;
        self.x += &k * v;
        let i_kh = DMatrix::identity(n, n) - &k * h;
        self.p = &i_kh * &self.p * i_kh.transpose() + &k * r * k.transpose();
        self.p = (&self.p + self.p.transpose()) * 0.5;
    }

    /// State `i` started again: `value`, `variance`, uncorrelated with the others.
    fn restart(&mut self, i: usize, value: f64, variance: f64) {
        self.p.row_mut(i).fill(0.0);
        self.p.column_mut(i).fill(0.0);
        self.p[(i, i)] = variance;
        self.x[i] = value;
    }
}
