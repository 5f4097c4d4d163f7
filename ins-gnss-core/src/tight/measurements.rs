//! The tightly coupled measurement models: a satellite's pseudorange and range rate from
//! the antenna, the time-differenced carrier rows, each satellite its own stream, and the
//! same models applied to the 26-state filter.

use super::*;

/// A satellite model of [`InsStateTc`] applied to [`InsStateTc21`]: the same prediction
/// from [`InsStateTc21::tc`], `H`'s columns of the clock and the inter-system biases moved
/// past the scale factors (whose columns are zero: a satellite sees them only through
/// the navigation states they drive).
#[derive(Debug)]
pub struct OnTc<'a, M>(pub &'a M);

impl<M> Clone for OnTc<'_, M> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<M> Copy for OnTc<'_, M> {}

impl<M> MeasurementModel for OnTc<'_, M>
where
    M: MeasurementModel<State = InsStateTc, Measurement = Vector1<f64>>,
{
    type State = InsStateTc21;
    type Measurement = Vector1<f64>;

    fn predict(&self, x: &InsStateTc21) -> Vector1<f64> {
        self.0.predict(&x.tc())
    }

    fn jacobian(&self, x: &InsStateTc21) -> JacobiansOf<Self> {
        MeasurementJacobians { H: widen(&self.0.jacobian(&x.tc()).H) }
    }

    fn linearize(&self, x: &InsStateTc21) -> (Vector1<f64>, JacobiansOf<Self>) {
        let (z, j) = self.0.linearize(&x.tc());
        (z, MeasurementJacobians { H: widen(&j.H) })
    }

    fn stream(&self) -> StreamId {
        self.0.stream()
    }
}

/// A row of the 20-state `H` in the 26-state layout.
fn widen(h: &SMatrix<f64, 1, 20>) -> SMatrix<f64, 1, 26> {
    const NAV15: usize = 15;
    let mut out = SMatrix::<f64, 1, 26>::zeros();
    out.fixed_view_mut::<1, NAV15>(0, 0).copy_from(&h.fixed_view::<1, NAV15>(0, 0));
    out.fixed_view_mut::<1, 5>(0, InsStateTc21::CLOCK.start())
        .copy_from(&h.fixed_view::<1, 5>(0, InsStateTc::CLOCK.start()));
    out
}

/// The stream of a satellite's pseudoranges (`"pr G05"`) or range rates (`"rr G05"`):
/// each satellite is a stream of its own. The names are made once per satellite.
pub fn satellite_stream(sat: Sat, rate: bool) -> StreamId {
    static NAMES: OnceLock<Mutex<HashMap<(Sat, bool), StreamId>>> = OnceLock::new();
    let map = NAMES.get_or_init(|| Mutex::new(HashMap::new()));
    let mut m = match map.lock() {
        Ok(m) => m,
        Err(poisoned) => poisoned.into_inner(),
    };
    *m.entry((sat, rate)).or_insert_with(|| {
        let name: &'static str =
            Box::leak(format!("{} {sat}", if rate { "rr" } else { "pr" }).into_boxed_str());
        StreamId::named(name)
    })
}

/// What the satellite models and the navigator's raw epochs need of the state: the
/// antenna (geodetic and ECEF) and the NED frame there.
pub(crate) struct Antenna {
    pub(crate) c_nb: Matrix3<f64>,
    pub(crate) c_ne: Matrix3<f64>,
    pub(crate) pos: crate::position::GeoPos,
    pub(crate) r: Vector3<f64>,
    pub(crate) lever_n: Vector3<f64>,
}

impl Antenna {
    /// The antenna of state `x` with lever arm `lever` (FRD).
    pub(crate) fn at(x: &InsState, lever: &Vector3<f64>) -> Self {
        let c_nb = x.att.matrix();
        let lever_n = c_nb * lever;
        let p = x.pos.oplus(&lever_n);
        Self {
            c_nb,
            c_ne: ecef_to_ned_rotation(p.lat, p.lon),
            pos: p,
            r: geodetic_to_ecef(p.lat, p.lon, p.h),
            lever_n,
        }
    }

    /// Range with the Sagnac term and the unit vector antenna → satellite (ECEF).
    fn range(&self, rs: &Vector3<f64>) -> (f64, Vector3<f64>) {
        geometry(rs, &self.r)
    }
}

/// A satellite's pseudorange: the prepared satellite, the corrections `I + T` (m) and the
/// lever arm.
#[derive(Clone, Copy, Debug)]
pub struct Pseudorange<'a> {
    /// The satellite at its transmission time, and the code.
    pub sat: &'a Prepared,
    /// Ionosphere plus troposphere delay, m.
    pub corrections: f64,
    /// Antenna lever arm (FRD), m.
    pub lever_arm: Vector3<f64>,
}

impl MeasurementModel for Pseudorange<'_> {
    type State = InsStateTc;
    type Measurement = Vector1<f64>;

    fn predict(&self, x: &InsStateTc) -> Vector1<f64> {
        self.linearize(x).0
    }

    fn jacobian(&self, x: &InsStateTc) -> JacobiansOf<Self> {
        self.linearize(x).1
    }

    fn linearize(&self, x: &InsStateTc) -> (Vector1<f64>, JacobiansOf<Self>) {
        let a = Antenna::at(&x.nav, &self.lever_arm);
        let (rho, u) = a.range(&self.sat.state.pos);
        let isb = isb_index(self.sat.sat.sys).map_or(0.0, |k| x.isb[k]);
        let z = rho + x.clock[0] + isb - C * self.sat.state.clock + self.corrections;
        let u_n = a.c_ne * u;
        let mut H = SMatrix::<f64, 1, 20>::zeros();
        let att = u_n.transpose() * a.c_nb * hat(&self.lever_arm);
        for k in 0..3 {
            H[(0, ATT + k)] = att[(0, k)];
            H[(0, POS + k)] = -u_n[k];
        }
        H[(0, CLOCK_BIAS)] = 1.0;
        if let Some(k) = isb_index(self.sat.sat.sys) {
            H[(0, ISB + k)] = 1.0;
        }
        (Vector1::new(z), MeasurementJacobians { H })
    }

    fn stream(&self) -> StreamId {
        satellite_stream(self.sat.sat, false)
    }
}

/// A satellite's range rate (from its Doppler): the prepared satellite, the lever arm and
/// the gyro rate (for the lever arm's velocity).
#[derive(Clone, Copy, Debug)]
pub struct RangeRate<'a> {
    /// The satellite at its transmission time.
    pub sat: &'a Prepared,
    /// Antenna lever arm (FRD), m.
    pub lever_arm: Vector3<f64>,
    /// Measured body rate `ω_ib^b` (before the bias correction), rad/s.
    pub gyro_rate: Vector3<f64>,
}

impl MeasurementModel for RangeRate<'_> {
    type State = InsStateTc;
    type Measurement = Vector1<f64>;

    fn predict(&self, x: &InsStateTc) -> Vector1<f64> {
        self.linearize(x).0
    }

    fn jacobian(&self, x: &InsStateTc) -> JacobiansOf<Self> {
        self.linearize(x).1
    }

    fn linearize(&self, x: &InsStateTc) -> (Vector1<f64>, JacobiansOf<Self>) {
        let n = &x.nav;
        let a = Antenna::at(n, &self.lever_arm);
        let (_, u) = a.range(&self.sat.state.pos);
        let e = LocalEarth::at(&n.pos);
        let w_in = e.earth_rate() + e.transport_rate(&n.vel);
        let w = self.gyro_rate - n.bg;
        let wl = w.cross(&self.lever_arm);
        let v_a_n = n.vel + a.c_nb * wl - w_in.cross(&a.lever_n);
        let vr = a.c_ne.transpose() * v_a_n;
        let rate = range_rate(&self.sat.state.pos, &self.sat.state.vel, &a.r, &vr, &u);
        let z = rate + x.clock[1] - C * self.sat.state.drift;
        let u_n = a.c_ne * u;
        let mut H = SMatrix::<f64, 1, 20>::zeros();
        let att = u_n.transpose() * a.c_nb * hat(&wl);
        let bg = -(u_n.transpose() * a.c_nb * hat(&self.lever_arm));
        for k in 0..3 {
            H[(0, ATT + k)] = att[(0, k)];
            H[(0, VEL + k)] = -u_n[k];
            H[(0, BG + k)] = bg[(0, k)];
        }
        H[(0, CLOCK_DRIFT)] = 1.0;
        (Vector1::new(z), MeasurementJacobians { H })
    }

    fn stream(&self) -> StreamId {
        satellite_stream(self.sat.sat, true)
    }
}

/// The error-state vector type of [`InsStateTc`].
pub type V20 = SVector<f64, 20>;

/// One row of an epoch's time-differenced carrier phases, whitened: the phases' changes
/// since the last epoch, differenced against the highest satellite's (the receiver clock
/// cancels), decorrelated by the Cholesky factor of their covariance, so each row is an
/// independent scalar of unit variance. Its error is, to first order, that of the
/// antenna's displacement over the interval, `Δt δv + ½ Δt² C_nb ([f^b×] δθ + δb_a)` (the anchor of
/// the last epoch being the filter's own position then): `predict(x) = c + hᵀ (v − v₀) +
/// h_attᵀ (att ⊖ att₀)` around the state the rows were formed at.
#[derive(Clone, Debug)]
pub struct CarrierRow {
    /// The row's sensitivity to the velocity (NED).
    pub h: Vector3<f64>,
    /// Its sensitivity to the attitude error (body frame).
    pub h_att: Vector3<f64>,
    /// Its sensitivity to the accelerometer bias error.
    pub h_ba: Vector3<f64>,
    /// The row's prediction at the state it was formed at.
    pub c: f64,
    /// The velocity the rows were formed at.
    pub v0: Vector3<f64>,
    /// The attitude the rows were formed at.
    pub att0: manifolds::So3,
    /// The accelerometer bias the rows were formed at.
    pub ba0: Vector3<f64>,
}

/// The stream of the time-differenced carrier phases.
pub fn carrier_stream() -> StreamId {
    StreamId::named("tdcp")
}

impl MeasurementModel for CarrierRow {
    type State = InsStateTc;
    type Measurement = Vector1<f64>;

    fn predict(&self, x: &InsStateTc) -> Vector1<f64> {
        let d_att = x.nav.att.ominus(&self.att0);
        Vector1::new(
            self.c
                + self.h.dot(&(x.nav.vel - self.v0))
                + self.h_att.dot(&d_att)
                + self.h_ba.dot(&(x.nav.ba - self.ba0)),
        )
    }

    fn jacobian(&self, _x: &InsStateTc) -> JacobiansOf<Self> {
        let mut H = SMatrix::<f64, 1, 20>::zeros();
        for k in 0..3 {
            H[(0, ATT + k)] = self.h_att[k];
            H[(0, VEL + k)] = self.h[k];
            H[(0, BA + k)] = self.h_ba[k];
        }
        MeasurementJacobians { H }
    }

    fn stream(&self) -> StreamId {
        carrier_stream()
    }
}
