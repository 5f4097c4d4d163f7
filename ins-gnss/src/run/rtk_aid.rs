//! RTK in a run (`gnss.coupling = "rtk"`): each rover epoch's double differences against
//! the base station, solved by two RTK filters, and what they add fed to the INS as a
//! position fix.
//!
//! - **Alone** (the filter of `ins-gnss rtk`, the code's persisting biases as states):
//!   each epoch from its single point, independent of the INS. Until the INS is
//!   *anchored*, its fixes go to the INS as they are (nothing of the INS in them): the
//!   INS started from single points is metres off, with a σ its persisting errors make
//!   too small, and a prior from it leads the ambiguities astray (on `benches/rtk_run.py`,
//!   10 seeds: single frequency 717 of 2,396 fixed rows more than 10 cm off with the
//!   INS's prior from the start; 176 of 3,483 with the alone filter until the first fix,
//!   all but 19 of them one seed's, where `ins-gnss rtk` fixes wrongly too), and a gate
//!   by it refused the true fixes of a start 27 m off (3.6σ) until the INS had drifted
//!   kilometres (one seed of 10 with two frequencies).
//! - **Aided** (the code white; `examples/rtk_ins.rs`): once anchored by a fix, the INS
//!   prediction of the antenna (its covariance from the attitude and position blocks) is
//!   its prior for the rover, and a fix goes back as [`information_beyond`] it — what
//!   keeps the fix through a tunnel or a canyon of 3 satellites.
//! - **Validation**: a fix of the aided filter the alone filter's fix contradicts (their
//!   difference beyond χ²₃ 99.9 % of their covariances; or its float solution's, its σ
//!   taken [`FLOAT_SIGMA_FACTOR`]× larger) is not used, nor the aided
//!   filter's float solution where the alone one fixes (the INS's prior may be what
//!   keeps it from fixing): the alone filter's fix is used instead. An alone fix the INS
//!   prediction contradicts says the INS is off by about the difference — an IMU glitch,
//!   a wrong fix it held: its position's variance is widened by the difference² and its
//!   velocity's by (difference / time since its last fix)², so that its own gate takes
//!   the fix (a 1 m/s glitch of the IMU: the INS ran 33 m off behind the gate, now back
//!   within 2 s, `tests/rtk_run.rs`), and the fix anchors it again (the aided filter
//!   restarts). The anchor is dropped too when the INS's position σ exceeds
//!   [`ANCHOR_SIGMA`].
//!
//! A float epoch gives the INS the alone filter's float solution (or, without one, the
//! single point) only while the INS knows its position less well than that solution
//! does: their errors persist for minutes, and fed at every epoch they would hold the
//! INS off with a σ far too small. On `benches/rtk_run.py` (10 seeds, single frequency)
//! the float solution as this leash instead of the single point took the smoothed
//! horizontal RMS from 2.66 to 0.19 m (median), the share of smoothed epochs beyond
//! their 99 % ellipse from 27.6 to 13.6 % (its covariance the smoothed σ's floor), the
//! forward one from 15.1 to 16.5 %. The float solution's σ is taken
//! [`FLOAT_SIGMA_FACTOR`]× larger here too (before a fix it covers its error about 2.5×
//! short): over 20 seeds, single frequency, the forward and smoothed shares beyond 11.8
//! → 3.0 % and 8.7 → 1.0 % (×3: 1.2 and 0.8 %, the canyon's end worse), the RMS within a
//! seed's noise; two frequencies 4.7 → 3.9 % and 6.0 → 5.5 %.

use super::aid::{RtkPair, RtkSetup};
use gnss::rtk::RtkRun;
use gnss::rtk::{information_beyond, Rtk, RtkEpoch, RtkFailure, RtkOptions, POSITION_SIGMA0};
use ins_gnss_core::earth::{ecef_to_geodetic, ecef_to_ned_rotation, geodetic_to_ecef};
use ins_gnss_core::{GeoPos, GnssEpoch, InsState};
use manifolds::hat;
use nalgebra::{Matrix3, SMatrix, Vector3};

/// χ²₃ 99.9 %: the aided and alone filters' fixes further apart than this disagree.
pub const RTK_GATE: f64 = 16.27;

/// A fixed epoch is written with Q = 1 when its double differences know the position to
/// better than this (m) in every direction beyond what the filter started the epoch
/// from; else (a canyon's two double differences a frequency leave one direction to the
/// INS) Q = 2.
pub const FIXED_SIGMA: f64 = 1.0;

/// The alone filter's float solution checks the aided filter's fix, and leashes the INS,
/// with its σ taken this many times larger: on `benches/rtk_run.py 10`, single frequency,
/// wrong fixed rows 157 → 81 (1: 54, but two frequencies' worst seed 92.7 → 84.3 % fixed;
/// 3: 117); two frequencies unchanged. (The leash: the module's notes.)
pub const FLOAT_SIGMA_FACTOR: f64 = 2.0;

/// The INS is a prior for the aided filter only while its antenna's position σ (its
/// largest direction, m) is at most this.
pub const ANCHOR_SIGMA: f64 = 1.0;

/// The run's RTK filters and what they found.
pub(crate) struct RtkAid {
    alone: Rtk,
    aided: Rtk,
    aided_options: RtkOptions,
    /// The INS took a fix since it was last without one (see the module's notes).
    anchored: bool,
    setup: RtkSetup,
    /// The antenna's lever arm (body, FRD), m.
    lever: Vector3<f64>,
    /// Each epoch's solution the run used (the aided filter's when anchored), and the
    /// failures (the summary's metrics).
    pub(crate) run: RtkRun,
    /// Fixes of the aided filter the alone filter's contradicted (not used).
    pub(crate) gated: usize,
    /// When the INS last took a fix.
    last_fix: Option<f64>,
}

/// What one rover epoch gave the INS: a fix (the RTK's, or the single point as a leash)
/// and the epoch's RTKLIB quality (1 fixed, 2 float).
pub(crate) struct RtkStep {
    pub(crate) fix: Option<GnssEpoch>,
    pub(crate) quality: u8,
    /// A fixed solution's NED variances: what the smoothed position's σ cannot go below
    /// (the fixes' errors persist — the atmosphere's residuals, multipath — and the
    /// smoother, taking them for white, would average them down).
    pub(crate) floor: Option<[f64; 3]>,
    /// Variances (N, E, D) to add to the INS's position (m²) and velocity (m²/s²) before
    /// the fix: an independent fix contradicted the INS by about the difference, which a
    /// velocity error may have made since the last fix the INS took.
    pub(crate) widen: Option<(Vector3<f64>, Vector3<f64>)>,
}

impl RtkStep {
    /// A float epoch: the leash if the INS takes it, and its covariance the smoothed
    /// position σ's floor (the float solution's errors persist as the fixes' do).
    fn float(fix: Option<GnssEpoch>) -> Self {
        let floor = fix.map(|f| {
            let v = f.position_covariance().diagonal();
            [v.x, v.y, v.z]
        });
        Self { fix, quality: 2, floor, widen: None }
    }
}

impl RtkAid {
    pub(crate) fn new(setup: &RtkSetup, lever: Vector3<f64>) -> Self {
        // the aided filter's code white: with the code biases as states the INS-aided
        // single-frequency runs fixed less and wrongly more (`docs/results.md`)
        let aided_options = RtkOptions { code_bias_sigma: 0.0, ..setup.options.clone() };
        Self {
            alone: Rtk::new(setup.base, setup.options.clone()),
            aided: Rtk::new(setup.base, aided_options.clone()),
            aided_options,
            anchored: false,
            setup: setup.clone(),
            lever,
            run: RtkRun { base: setup.base, notes: setup.notes.clone(), ..Default::default() },
            gated: 0,
            last_fix: None,
        }
    }

    /// A run none of whose rover epochs found a base epoch recent enough (the base file
    /// of another day, another time scale): refused, naming `data.base`, rather than left
    /// to the INS alone (and blamed on the rover's file).
    pub(crate) fn check_base_overlap(
        &self,
        config: &crate::config::Config,
    ) -> Result<(), super::RunError> {
        let unpaired = self.run.failures.get(gnss::rtk::NO_BASE_EPOCH).copied().unwrap_or(0);
        if self.run.epochs == 0 || unpaired < self.run.epochs {
            return Ok(());
        }
        let base = config.data.base.as_deref().unwrap_or(std::path::Path::new("data.base"));
        Err(super::RunError::Start(format!(
            "{}: none of the rover's {} epochs in the IMU span has a base epoch at most \
             {} s older (`gnss.rtk.max_age`): check that `data.base` covers the rover's \
             time (the same day and time scale)",
            base.display(),
            self.run.epochs,
            self.setup.options.max_age
        )))
    }

    /// A rover epoch without a base epoch recent enough.
    pub(crate) fn unpaired(&mut self) {
        self.run.epochs += 1;
        self.run.fail(gnss::rtk::NO_BASE_EPOCH);
    }

    /// The rover epoch `pair` with its single point `spp` (a fix at the stamp), the INS
    /// at `x` (time `t_x`) with the covariance `p9` of its attitude, velocity and position
    /// errors (NED).
    pub(crate) fn step(
        &mut self,
        pair: &RtkPair,
        spp: Option<&GnssEpoch>,
        x: &InsState,
        t_x: f64,
        p9: &SMatrix<f64, 9, 9>,
    ) -> RtkStep {
        self.run.epochs += 1;
        let (prior, p_ned) = self.antenna_prior(pair.t, x, t_x, p9);
        let c = ecef_to_ned_rotation(x.pos.lat, x.pos.lon);
        let p = c.transpose() * p_ned * c;
        let spp_pos = spp.map(|f| geodetic_to_ecef(f.pos.lat, f.pos.lon, f.pos.h));
        if self.anchored && p_ned.symmetric_eigen().eigenvalues.max().sqrt() > ANCHOR_SIGMA {
            self.drop_anchor();
        }
        let eph = &self.setup.ephemerides;
        let alone = self.alone.step(&pair.rover, &pair.base, eph, spp_pos);
        // the leash at a float epoch: the alone filter's float solution (independent of
        // the INS) when it has one, else the single point
        let leash = match &alone {
            Ok(b) => Some(fix_of(pair.t, &b.pos, &alone_cov(b))),
            Err(_) => spp.copied(),
        };
        let (sol, anchored, confirmed) = self.choose(pair, spp_pos, alone, (prior, p));
        if !anchored {
            self.drop_anchor();
        }
        match self.record(pair, sol) {
            Some(sol) if sol.fixed => self.fixed(pair, &sol, (anchored, confirmed), (prior, p), &c),
            _ => RtkStep::float(self.leash(leash.as_ref(), &p_ned, pair.t)),
        }
    }

    /// The solution the INS takes — the aided filter's once anchored, unless the alone
    /// filter's fix contradicts its fix or fixes where it floats; the alone filter's
    /// otherwise — whether it is the aided filter's, and whether the alone filter
    /// confirms it (or it is the alone filter's own).
    fn choose(
        &mut self,
        pair: &RtkPair,
        spp_pos: Option<Vector3<f64>>,
        alone: Result<RtkEpoch, RtkFailure>,
        prior: (Vector3<f64>, Matrix3<f64>),
    ) -> (Result<RtkEpoch, RtkFailure>, bool, bool) {
        if !self.anchored {
            return (alone, false, true);
        }
        let eph = &self.setup.ephemerides;
        let aided = self.aided.step_with_prior(&pair.rover, &pair.base, eph, spp_pos, Some(prior));
        match (&aided, &alone) {
            // (its prior, the INS, may be what keeps the aided filter from fixing)
            (Ok(a), Ok(b)) if !a.fixed && b.fixed => (alone, false, true),
            // a fix the alone filter's solution contradicts — its fix, or its float
            // solution with its σ taken [`FLOAT_SIGMA_FACTOR`]× larger — is not used; one
            // it fixes too is confirmed
            (Ok(a), Ok(b)) if a.fixed => {
                if beyond_gate(&(a.pos - b.pos), &(a.cov + alone_cov(b))) {
                    self.gated += 1;
                    (alone, false, true)
                } else {
                    (aided, true, b.fixed)
                }
            }
            _ => (aided, true, false),
        }
    }

    /// A fixed solution `sol` for the INS: what it adds to the aided filter's prior
    /// (`anchored`), or itself (the alone filter's, which anchors the INS), with its
    /// quality, its floor and, `confirmed` and contradicting the INS prediction
    /// (`prior`; `c` the NED rotation there), how far to widen the INS first.
    fn fixed(
        &mut self,
        pair: &RtkPair,
        sol: &RtkEpoch,
        (anchored, confirmed): (bool, bool),
        (prior, p): (Vector3<f64>, Matrix3<f64>),
        c: &Matrix3<f64>,
    ) -> RtkStep {
        // what the epoch's double differences added to what the filter started from: the
        // INS's prior (aided), or a single point with σ 30 m (alone)
        let start_inv = match anchored {
            true => p.cholesky().map(|c| c.inverse()),
            false => Some(Matrix3::identity() / POSITION_SIGMA0.powi(2)),
        };
        let added = sol.cov.cholesky().map(|c| c.inverse()).zip(start_inv).map(|(a, b)| a - b);
        let everywhere = added.is_some_and(|i| {
            ((i + i.transpose()) * 0.5).symmetric_eigen().eigenvalues.min() >= FIXED_SIGMA.powi(-2)
        });
        let quality = if everywhere { 1 } else { 2 };
        let v = fix_of(pair.t, &sol.pos, &sol.cov).position_covariance().diagonal();
        let floor = Some([v.x, v.y, v.z]);
        let beyond = match anchored {
            true => information_beyond((&prior, &p), (&sol.pos, &sol.cov)),
            false => Some((sol.pos, sol.cov)),
        };
        let Some((z, r)) = beyond else {
            return RtkStep { fix: None, quality, floor, widen: None };
        };
        // a confirmed fix the INS prediction contradicts says the INS is off by about the
        // difference: its position's variance widened by it, its velocity's by it over the
        // time since its last fix, so that its gate takes the fix
        let d = z - prior;
        let widen = (confirmed && beyond_gate(&d, &(p + r))).then(|| {
            let d = c * d;
            let dt = self.last_fix.map_or(1.0, |t| (pair.t - t).max(1.0));
            (d.map(|v| v * v), d.map(|v| (v / dt).powi(2)))
        });
        if !anchored && everywhere {
            self.anchored = true;
            self.aided = Rtk::new(self.setup.base, self.aided_options.clone());
        }
        self.last_fix = Some(pair.t);
        RtkStep { fix: Some(fix_of(pair.t, &z, &r)), quality, floor, widen }
    }

    /// The INS is no longer a prior: the aided filter starts again at the next anchor.
    fn drop_anchor(&mut self) {
        self.anchored = false;
    }

    /// The epoch's solution in the run's metrics (its time the instant of the rover's
    /// position), or its failure; the solution if any.
    fn record(&mut self, pair: &RtkPair, sol: Result<RtkEpoch, RtkFailure>) -> Option<RtkEpoch> {
        match sol {
            Ok(s) => {
                let time = pair.rover.time.add(pair.clock);
                self.run.solutions.push(RtkEpoch { time, ..s.clone() });
                Some(s)
            }
            Err(f) => {
                self.run.fail(f.reason());
                None
            }
        }
    }

    /// The leash (the alone filter's float solution, or the single point), when the INS
    /// knows its position less well than it does.
    fn leash(&self, leash: Option<&GnssEpoch>, p_ned: &Matrix3<f64>, t: f64) -> Option<GnssEpoch> {
        let f = leash?;
        (p_ned.trace() > f.position_covariance().trace()).then_some(GnssEpoch { t, ..*f })
    }

    /// The antenna's predicted position at `t` (ECEF) and its covariance (NED): the INS
    /// at `t_x` moved on by its velocity (a sample's interval at most), the lever arm
    /// turned by the attitude, whose error it carries (`[−C[l×], 0, I]`).
    fn antenna_prior(
        &self,
        t: f64,
        x: &InsState,
        t_x: f64,
        p9: &SMatrix<f64, 9, 9>,
    ) -> (Vector3<f64>, Matrix3<f64>) {
        let c_nb = x.att.matrix();
        let c_en = ecef_to_ned_rotation(x.pos.lat, x.pos.lon).transpose();
        let ned = c_nb * self.lever + x.vel * (t - t_x);
        let at = geodetic_to_ecef(x.pos.lat, x.pos.lon, x.pos.h) + c_en * ned;
        let mut j = SMatrix::<f64, 3, 9>::zeros();
        j.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-c_nb * hat(&self.lever)));
        j.fixed_view_mut::<3, 3>(0, 6).copy_from(&Matrix3::identity());
        let p = j * p9 * j.transpose();
        (at, (p + p.transpose()) * 0.5)
    }
}

/// The alone filter's covariance as the run takes it: a fix's as it is, a float
/// solution's with its σ taken [`FLOAT_SIGMA_FACTOR`]× larger (before a fix it covers its
/// error about 2.5× short).
fn alone_cov(e: &RtkEpoch) -> Matrix3<f64> {
    if e.fixed {
        e.cov
    } else {
        e.cov * FLOAT_SIGMA_FACTOR.powi(2)
    }
}

/// Whether a difference `d` of two positions lies beyond [`RTK_GATE`] of their summed
/// covariance `s` (or `s` is not positive definite).
fn beyond_gate(d: &Vector3<f64>, s: &Matrix3<f64>) -> bool {
    s.cholesky().is_none_or(|ch| d.dot(&ch.solve(d)) > RTK_GATE)
}

/// A position (ECEF, m) and its covariance (m²) as a fix at `t`: geodetic, the covariance
/// turned to NED there (symmetric).
fn fix_of(t: f64, pos: &Vector3<f64>, cov: &Matrix3<f64>) -> GnssEpoch {
    let (lat, lon, h) = ecef_to_geodetic(pos);
    let c = ecef_to_ned_rotation(lat, lon);
    let r = c * cov * c.transpose();
    let r = (r + r.transpose()) * 0.5;
    let mut g = GnssEpoch::new(t, GeoPos { lat, lon, h }, r.diagonal().map(f64::sqrt), None);
    g.pos_cov = Some(r);
    g
}
