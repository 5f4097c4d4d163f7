//! Tight coupling in the navigator: raw epochs of satellites, each pseudorange, range
//! rate and time-differenced carrier phase an update of its own stream, and the error
//! floor the satellites' persisting errors leave the reported σ.

use super::*;

/// One epoch of raw observations for the tightly coupled navigator: the satellites at
/// their transmission times ([`::gnss::spp::prepare`]) and the epoch's time on the
/// navigator's clock.
#[derive(Clone, Debug)]
pub struct RawEpoch {
    /// Time on the navigator's (the IMU's) clock, s.
    pub t: f64,
    /// The receiver's GPS time stamp (for the ionosphere's local time).
    pub time: GpsTime,
    /// The satellites.
    pub sats: Vec<Prepared>,
    /// A moving-base receiver's heading at this epoch (applied after the satellites).
    pub heading: Option<crate::heading::AntennaHeading>,
}

/// How raw observations are used.
#[derive(Clone, Debug, PartialEq)]
pub struct TightConfig {
    /// Elevation mask, models and code weighting (the single point's options).
    pub models: SppOptions,
    /// The broadcast ionosphere.
    pub klobuchar: Klobuchar,
    /// Use the Dopplers (range rates) as well as the codes.
    pub use_doppler: bool,
    /// Keep the position's and the receiver clock's covariance at least the one the
    /// epoch's satellite errors that persist from epoch to epoch (orbit and clock, code
    /// bias, atmosphere residuals) leave a single point with
    /// ([`satellite_error_floor`]): the filter absorbs such errors into its position and
    /// clock and, counting each epoch's code as new information, would otherwise shrink
    /// their σ below the error they leave.
    pub error_floor: bool,
    /// Use the carrier phases differenced in time between consecutive epochs (a velocity
    /// measurement of millimetres per second; satellites flagged for a slip, or whose
    /// phase change disagrees with their Doppler by more than [`SLIP_RATE`], are left out).
    pub carrier: bool,
    /// σ of a carrier phase, m.
    pub phase_std: f64,
}

/// A phase change (m/s over the interval) farther than this from the Doppler's range rate
/// is a cycle slip the receiver did not flag.
pub const SLIP_RATE: f64 = 2.0;

/// The longest interval a phase is differenced over, s.
pub const CARRIER_MAX_GAP: f64 = 2.5;

/// The receiver clock at the start of a tightly coupled run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClockInit {
    /// Bias `c·dt` (m) and drift `c·ḋt` (m/s), e.g. from a single point.
    pub clock: (f64, f64),
    /// Their 1σ.
    pub std: (f64, f64),
    /// 1σ of the inter-system biases, m.
    pub isb_std: f64,
}

/// A tightly coupled state: the 15- or 21-state INS, then the receiver clock and the
/// inter-system biases ([`InsStateTc`], [`InsStateTc21`]). The satellite models are
/// written once, for [`InsStateTc`]; each state applies them its own way.
pub trait TightState: NavState
where
    DefaultAllocator: DimAlloc<Self::Dim>,
{
    /// Update `filter` with a scalar satellite model of [`InsStateTc`]: measurement `z`,
    /// variance `r`.
    fn update_tc<A, MM, O>(
        filter: &mut ErrorStateFilter<Self, A>,
        model: &MM,
        z: f64,
        r: f64,
        observer: &mut O,
    ) -> Result<UpdateSummary, FilterError>
    where
        A: NoiseStrategy,
        MM: MeasurementModel<State = InsStateTc, Measurement = nalgebra::Vector1<f64>>,
        O: Observer;
}

impl TightState for InsStateTc {
    fn update_tc<A, MM, O>(
        filter: &mut ErrorStateFilter<Self, A>,
        model: &MM,
        z: f64,
        r: f64,
        observer: &mut O,
    ) -> Result<UpdateSummary, FilterError>
    where
        A: NoiseStrategy,
        MM: MeasurementModel<State = InsStateTc, Measurement = nalgebra::Vector1<f64>>,
        O: Observer,
    {
        let (z, r) = (nalgebra::Vector1::new(z), nalgebra::Matrix1::new(r));
        filter.update_observed(model, &z, &r, observer).map(|r| r.summary())
    }
}

impl TightState for InsStateTc21 {
    fn update_tc<A, MM, O>(
        filter: &mut ErrorStateFilter<Self, A>,
        model: &MM,
        z: f64,
        r: f64,
        observer: &mut O,
    ) -> Result<UpdateSummary, FilterError>
    where
        A: NoiseStrategy,
        MM: MeasurementModel<State = InsStateTc, Measurement = nalgebra::Vector1<f64>>,
        O: Observer,
    {
        let (z, r) = (nalgebra::Vector1::new(z), nalgebra::Matrix1::new(r));
        filter.update_observed(&OnTc(model), &z, &r, observer).map(|r| r.summary())
    }
}

impl<A: NoiseStrategy, S: TightState> Navigator<A, S>
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    /// One IMU sample with the raw epochs of its interval (sorted): each satellite's
    /// pseudorange (and range rate) is an update of its own stream, at the epoch's time.
    pub fn process_raw<O: Observer>(
        &mut self,
        imu: &ImuSample,
        raw: &[RawEpoch],
        cfg: &TightConfig,
        observer: &mut O,
        out: &mut Vec<UpdateSummary>,
    ) -> Result<(), NavError> {
        self.process_raw_recorded(imu, raw, cfg, observer, out, &mut ())
    }

    /// [`process_raw`](Self::process_raw) telling `recorder` of every prediction and
    /// update (a smoother).
    pub fn process_raw_recorded<O: Observer, R: StepRecorder<S, ImuInput>>(
        &mut self,
        imu: &ImuSample,
        raw: &[RawEpoch],
        cfg: &TightConfig,
        observer: &mut O,
        out: &mut Vec<UpdateSummary>,
        recorder: &mut R,
    ) -> Result<(), NavError> {
        self.process_events(
            imu,
            raw,
            |e| e.t,
            observer,
            out,
            recorder,
            |nav, e, obs, out, rec| nav.update_raw(e, cfg, obs, out, rec),
        )
    }

    /// The satellites of one epoch, one update each (now: the epoch's time is the
    /// navigator's).
    fn update_raw<O: Observer, R: StepRecorder<S, ImuInput>>(
        &mut self,
        e: &RawEpoch,
        cfg: &TightConfig,
        observer: &mut O,
        out: &mut Vec<UpdateSummary>,
        recorder: &mut R,
    ) -> Result<(), NavError> {
        let err = |source| NavError::Measurement { t: e.t, source };
        self.vehicle.last_gnss = e.t;
        let lever = self.gnss.lever_arm;
        if cfg.carrier {
            self.update_carrier(e, cfg, observer, out, recorder)?;
        }
        // the persisting errors' normal equations: position (NED), a clock per system
        let mut normal = nalgebra::SMatrix::<f64, 7, 7>::zeros();
        let mut used = 0;
        for s in &e.sats {
            // the geometry at the state as it stands (earlier satellites of the epoch moved it)
            let a = Antenna::at(self.filter.state().nav(), &lever);
            let ant = a.pos;
            let d = s.state.pos - a.r;
            let (az, el) = azel(ant.lat, ant.lon, &(d / d.norm()));
            if el < cfg.models.elevation_mask {
                continue;
            }
            let (corr, var) = corrections(
                &cfg.models,
                &cfg.klobuchar,
                (ant.lat, ant.lon, ant.h),
                (az, el),
                e.time,
                s,
            );
            let model = Pseudorange { sat: s, corrections: corr, lever_arm: lever };
            recorder.before_update(&self.filter);
            let report =
                S::update_tc(&mut self.filter, &model, s.range, var, observer).map_err(err)?;
            out.push(report);
            if report.verdict != estimator_core::Verdict::Rejected {
                let persisting = var - code_noise_variance(&cfg.models, el, s);
                let u = a.c_ne * (d / d.norm());
                let mut h = nalgebra::SVector::<f64, 7>::zeros();
                h.fixed_rows_mut::<3>(0).copy_from(&(-u));
                h[3 + system_column(s.sat.sys)] = 1.0;
                normal += h * h.transpose() / persisting.max(1e-6);
                used += 1;
            }
            if let (true, Some(rate)) = (cfg.use_doppler, s.range_rate) {
                let model = RangeRate { sat: s, lever_arm: lever, gyro_rate: self.rate };
                let v = cfg.models.doppler_std.powi(2);
                recorder.before_update(&self.filter);
                let report =
                    S::update_tc(&mut self.filter, &model, rate, v, observer).map_err(err)?;
                out.push(report);
            }
        }
        if cfg.error_floor
            && used >= 4
            && let Some(f) = satellite_error_floor(&normal)
        {
            self.floor = Some(f);
        }
        if cfg.carrier {
            // this epoch's phases, for the next one
            let a = Antenna::at(self.filter.state().nav(), &lever);
            let (anchor, llh) = (a.r, (a.pos.lat, a.pos.lon, a.pos.h));
            let sats = e
                .sats
                .iter()
                .filter_map(|s| {
                    let p = s.phase?;
                    let atm = phase_atmosphere(cfg, llh, &anchor, e.time, s);
                    Some((s.sat, p, s.state.pos, s.state.clock, atm))
                })
                .collect();
            self.carrier = Some(CarrierEpoch { t: e.t, anchor, sats });
        }
        self.update_heading(e.heading.as_ref(), observer, out, recorder)
    }

    /// The time-differenced carrier phases of epoch `e` against the last epoch's, as
    /// whitened single differences ([`crate::tight::CarrierRow`]), before the epoch's codes.
    fn update_carrier<O: Observer, R: StepRecorder<S, ImuInput>>(
        &mut self,
        e: &RawEpoch,
        cfg: &TightConfig,
        observer: &mut O,
        out: &mut Vec<UpdateSummary>,
        recorder: &mut R,
    ) -> Result<(), NavError> {
        let Some(prev) = self.carrier.take() else { return Ok(()) };
        let dt = e.t - prev.t;
        if !(dt > 0.0 && dt <= CARRIER_MAX_GAP) {
            return Ok(());
        }
        let x = self.filter.state().nav();
        let (v0, att0, ba0) = (x.vel, x.att, x.ba);
        // the interval's displacement error: Δt δv + ½ Δt² C_nb [f^b×] δθ (δv̇ = −C_nb [f^b×] δθ
        // for the body-frame attitude error), with the last sample's specific force
        let f_b = self.prev.map_or_else(Vector3::zeros, |p| p.dvel / p.dt.max(1e-9)) - x.ba;
        let a_acc = x.att.matrix() * (0.5 * dt * dt);
        let a_att = a_acc * manifolds::hat(&f_b);
        let Antenna { pos: ant, r: r_a, c_ne, .. } = Antenna::at(x, &self.gnss.lever_arm);
        // per satellite: elevation, the residual of its phase change (m), its line of sight
        let rows = carrier_rows(e, &prev, cfg, dt, (&ant, &r_a, &c_ne));
        if rows.len() < 2 {
            return Ok(());
        }
        // single differences against the highest satellite: the receiver clock cancels
        let r = (0..rows.len()).max_by(|&a, &b| rows[a].0.total_cmp(&rows[b].0)).unwrap_or(0);
        let (_, y_r, u_r) = rows[r];
        let n = rows.len() - 1;
        let var = 2.0 * cfg.phase_std.powi(2);
        // covariance of the differences: var (I + 1 1ᵀ)
        let cov = nalgebra::DMatrix::from_fn(n, n, |i, j| if i == j { 2.0 * var } else { var });
        let Some(chol) = cov.cholesky() else { return Ok(()) };
        let mut y = nalgebra::DVector::zeros(n);
        let mut h = nalgebra::DMatrix::zeros(n, 9);
        let others = rows.iter().enumerate().filter(|(k, _)| *k != r).map(|(_, v)| v);
        for (k, (_, y_i, u_i)) in others.enumerate() {
            y[k] = y_i - y_r;
            let du = u_r - u_i;
            let (hv, ha, hb) = (du * dt, a_att.transpose() * du, a_acc.transpose() * du);
            for c in 0..3 {
                h[(k, c)] = hv[c];
                h[(k, 3 + c)] = ha[c];
                h[(k, 6 + c)] = hb[c];
            }
        }
        let l = chol.l();
        let (Some(y), Some(h)) = (l.solve_lower_triangular(&y), l.solve_lower_triangular(&h))
        else {
            return Ok(());
        };
        let err = |source| NavError::Measurement { t: e.t, source };
        for k in 0..n {
            let model = crate::tight::CarrierRow {
                h: Vector3::new(h[(k, 0)], h[(k, 1)], h[(k, 2)]),
                h_att: Vector3::new(h[(k, 3)], h[(k, 4)], h[(k, 5)]),
                h_ba: Vector3::new(h[(k, 6)], h[(k, 7)], h[(k, 8)]),
                c: 0.0,
                v0,
                att0,
                ba0,
            };
            recorder.before_update(&self.filter);
            let report =
                S::update_tc(&mut self.filter, &model, y[k], 1.0, observer).map_err(err)?;
            out.push(report);
        }
        Ok(())
    }
}

/// Each satellite's phase change since the last epoch `prev` (over `dt` s) seen from the
/// antenna (`ant`: geodetic, ECEF, and the ECEF-to-NED rotation): its elevation, the
/// change's residual (m) after the satellites' clocks, the geometry and the atmosphere,
/// and its line of sight (NED); the satellites below the mask, slipped or whose phase's
/// rate is far from their Doppler's left out.
fn carrier_rows(
    e: &RawEpoch,
    prev: &CarrierEpoch,
    cfg: &TightConfig,
    dt: f64,
    (ant, r_a, c_ne): (&crate::GeoPos, &Vector3<f64>, &nalgebra::Matrix3<f64>),
) -> Vec<(f64, f64, Vector3<f64>)> {
    let mut rows: Vec<(f64, f64, Vector3<f64>)> = Vec::with_capacity(e.sats.len());
    for s in &e.sats {
        let (Some(phase), false) = (s.phase, s.slip) else { continue };
        let Some(&(_, p0, pos0, clk0, atm0)) = prev.sats.iter().find(|p| p.0 == s.sat) else {
            continue;
        };
        let (rho, u) = ::gnss::spp::geometry(&s.state.pos, r_a);
        let (rho0, _) = ::gnss::spp::geometry(&pos0, &prev.anchor);
        let (_, el) = azel(ant.lat, ant.lon, &u);
        if el < cfg.models.elevation_mask {
            continue;
        }
        let change = phase - p0;
        // a slip the receiver did not flag: the phase's rate far from the Doppler's
        if let Some(rate) = s.range_rate
            && (change / dt - rate).abs() > SLIP_RATE
        {
            continue;
        }
        let sat_clock = ::gnss::ephemeris::C * (s.state.clock - clk0);
        let atm = phase_atmosphere(cfg, (ant.lat, ant.lon, ant.h), r_a, e.time, s);
        rows.push((el, change + sat_clock - (rho - rho0) - (atm - atm0), c_ne * u));
    }
    rows
}

/// The atmosphere's delay of a satellite's carrier phase at the antenna `r` (ECEF, at
/// geodetic `llh`): `T − I` (the phase is advanced by the ionosphere).
fn phase_atmosphere(
    cfg: &TightConfig,
    llh: (f64, f64, f64),
    r: &Vector3<f64>,
    time: GpsTime,
    s: &Prepared,
) -> f64 {
    let d = s.state.pos - r;
    let azel = azel(llh.0, llh.1, &(d / d.norm()));
    let ((iono, _), (tropo, _)) =
        ::gnss::spp::atmosphere(&cfg.models, &cfg.klobuchar, llh, azel, time, s);
    tropo - iono
}

/// The column of a system's clock in [`satellite_error_floor`]'s normal equations: GPS
/// (and any other system) 0, Galileo 1, BeiDou 2, QZSS 3.
fn system_column(sys: System) -> usize {
    crate::tight::isb_index(sys).map_or(0, |k| k + 1)
}

/// The covariance of position (NED) and GPS clock that the persisting satellite errors
/// leave a single point of the epoch's geometry: the first 4×4 block of the inverse of
/// the normal equations `Σ h hᵀ / σ²_persisting` (rows of position and a clock per
/// system; the columns of systems not seen are left out). `None` when the geometry does
/// not fix them. With errors constant per satellite, a filter that averages epochs cannot
/// do better than this: it is the σ below which its position and clock must not shrink.
pub fn satellite_error_floor(
    normal: &nalgebra::SMatrix<f64, 7, 7>,
) -> Option<nalgebra::Matrix4<f64>> {
    // the systems seen keep their clock column; the others are fixed at 0 (unit diagonal)
    let mut n = *normal;
    for k in 3..7 {
        if n[(k, k)] == 0.0 {
            n[(k, k)] = 1.0;
        }
    }
    if normal[(3, 3)] == 0.0 {
        // no GPS satellite: the GPS clock is not fixed by this epoch
        return None;
    }
    let inv = n.cholesky()?.inverse();
    Some(inv.fixed_view::<4, 4>(0, 0).into_owned())
}
