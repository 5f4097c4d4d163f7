//! Strapdown mechanization for increment-type IMU data.
//!
//! **WGS-84 NED** (the fidelity of the best open implementations): two-sample coning and
//! sculling corrections (Savage 1998, *Strapdown Analytics* §7; Shin 2001, thesis §2.2),
//! Earth rate, transport rate, normal gravity, Coriolis; midpoint navigation quantities
//! by one predictor–corrector pass. For an interval of length `dt` with corrected
//! increments `(Δθ₋, Δv₋)` before and `(Δθ, Δv)` now:
//!
//! ```text
//! Δv_b  = Δv + ½ Δθ × Δv + (Δθ₋ × Δv + Δv₋ × Δθ)/12      rotation + sculling
//! ζ     = (ω_ie^n + ω_en^n)_mid · dt                      nav-frame rotation
//! v⁺    = v + (I − ½[ζ×]) R_nb Δv_b + (g − (2ω_ie + ω_en) × v)_mid · dt
//! p⁺    = p + ½ (v + v⁺) dt                               in (φ, λ, h) with midpoint radii
//! φ_b   = Δθ + (Δθ₋ × Δθ)/12                              coning
//! R_nb⁺ = Exp(−ζ) · R_nb · Exp(φ_b)
//! ```
//!
//! **Flat earth** (paper `fused-iae-afkf` eq. 3–7): no Earth rate, no transport rate, no
//! Coriolis, constant gravity `g₀` and constant radii of a reference point:
//! `R_nb⁺ = R_nb Exp(φ_b)`, `v⁺ = v + R_nb Δv_b + g₀ dt`, `p⁺ = p + ½(v + v⁺) dt`.

use manifolds::So3;
use nalgebra::{Matrix3, Vector3};

use crate::earth::{gravity_ned, sin_cos_near, LocalEarth};
use crate::position::GeoPos;

/// Which mechanization (and matching error model) to use.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mechanization {
    /// WGS-84 NED with Earth rate, transport rate and normal gravity (default).
    Wgs84,
    /// Flat earth around a reference point: constant gravity and radii, no rotation terms.
    FlatEarth {
        /// Reference point for gravity and radii.
        reference: GeoPos,
    },
}

/// Bias-corrected increments of one interval and of the one before it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Increments {
    /// Previous interval's angular increment, rad (zero at start-up).
    pub dtheta_prev: Vector3<f64>,
    /// Previous interval's velocity increment, m/s.
    pub dvel_prev: Vector3<f64>,
    /// This interval's angular increment, rad.
    pub dtheta: Vector3<f64>,
    /// This interval's velocity increment, m/s.
    pub dvel: Vector3<f64>,
    /// Interval length, s.
    pub dt: f64,
}

/// Attitude, velocity, position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Nav {
    /// `R_nb`.
    pub att: So3,
    /// NED velocity, m/s.
    pub vel: Vector3<f64>,
    /// Position.
    pub pos: GeoPos,
}

/// Body-frame velocity increment with rotation and sculling corrections.
pub fn sculling(inc: &Increments) -> Vector3<f64> {
    inc.dvel
        + inc.dtheta.cross(&inc.dvel) * 0.5
        + (inc.dtheta_prev.cross(&inc.dvel) + inc.dvel_prev.cross(&inc.dtheta)) / 12.0
}

/// Body rotation vector with the two-sample coning correction.
pub fn coning(inc: &Increments) -> Vector3<f64> {
    inc.dtheta + inc.dtheta_prev.cross(&inc.dtheta) / 12.0
}

fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    manifolds::hat(v)
}

/// One WGS-84 NED mechanization step.
pub fn wgs84_step(nav: &Nav, inc: &Increments) -> Nav {
    wgs84_step_with(nav, inc, &nav.att.matrix(), &LocalEarth::at(&nav.pos))
}

/// The navigation frame's rotation `(ω_ie + ω_en) dt` and the gravity and Coriolis
/// velocity increment `(g − (2ω_ie + ω_en) × v) dt` at one point.
fn rates(e: &LocalEarth, v: &Vector3<f64>, dt: f64) -> (Vector3<f64>, Vector3<f64>) {
    let w_ie = e.earth_rate();
    let w_en = e.transport_rate(v);
    let g = Vector3::new(0.0, 0.0, e.gravity());
    ((w_ie + w_en) * dt, (g - (w_ie * 2.0 + w_en).cross(v)) * dt)
}

/// [`wgs84_step`] with `R_nb` and the Earth functions at the start given (the INS model
/// shares them with its Jacobians).
///
/// The predictor evaluates the Earth model at the start, predicts the velocity, and from
/// it the midpoint latitude and height (with the start's meridian radius: the predictor
/// only has to place the midpoint). The corrector evaluates the Earth model there, gives
/// the velocity, and integrates the position with the midpoint radii. The latitude
/// functions away from the start come from the start's through [`sin_cos_near`]. Each
/// step is on one chain of dependent divisions, square roots and trigonometry, so the
/// fewer of them the faster the step.
pub fn wgs84_step_with(
    nav: &Nav,
    inc: &Increments,
    r_nb: &Matrix3<f64>,
    start: &LocalEarth,
) -> Nav {
    let dt = inc.dt;
    let dv_b = sculling(inc);
    let phi_b = coning(inc);
    let f_n = r_nb * dv_b;
    let (p0, v0) = (&nav.pos, &nav.vel);
    // Predictor with the start-of-interval navigation quantities.
    let (zeta0, dv_gc0) = rates(start, v0, dt);
    let v_pred = v0 + f_n - skew(&zeta0) * f_n * 0.5 + dv_gc0;
    let v_mid = (v0 + v_pred) * 0.5;
    let h_mid = p0.h - 0.5 * v_mid.z * dt;
    let lat_mid = p0.lat + 0.5 * v_mid.x * dt / (start.rm + h_mid);
    // Corrector at the midpoint.
    let (sm, cm) = sin_cos_near(lat_mid, p0.lat, start.sin, start.cos);
    let mid = LocalEarth::new(sm, cm, h_mid);
    let (zeta, dv_gc) = rates(&mid, &v_mid, dt);
    let vel = v0 + f_n - skew(&zeta) * f_n * 0.5 + dv_gc;
    // Position with the average velocity and the midpoint radii.
    let v_avg = (v0 + vel) * 0.5;
    let h1 = p0.h - v_avg.z * dt;
    let h_avg = 0.5 * (p0.h + h1);
    let lat1 = p0.lat + v_avg.x * dt / (mid.rm + h_avg);
    let cos_mid = sin_cos_near(0.5 * (p0.lat + lat1), p0.lat, start.sin, start.cos).1;
    let lon1 = p0.lon + v_avg.y * dt / ((mid.rn + h_avg) * cos_mid);
    let att = nav.att.between_exp(&(-zeta), &phi_b);
    Nav { att, vel, pos: GeoPos { lat: lat1, lon: lon1, h: h1 } }
}

/// One flat-earth mechanization step around `reference`.
pub fn flat_earth_step(nav: &Nav, inc: &Increments, reference: &GeoPos) -> Nav {
    let dt = inc.dt;
    let dv_b = sculling(inc);
    let phi_b = coning(inc);
    let g = gravity_ned(reference.lat, reference.h);
    let vel = nav.vel + nav.att.matrix() * dv_b + g * dt;
    let v_avg = (nav.vel + vel) * 0.5;
    let m = reference.metric();
    let pos = GeoPos {
        lat: nav.pos.lat + v_avg.x * dt / m.x,
        lon: nav.pos.lon + v_avg.y * dt / m.y,
        h: nav.pos.h - v_avg.z * dt,
    };
    Nav { att: nav.att * So3::exp(&phi_b), vel, pos }
}

/// One step of the chosen mechanization.
pub fn step(mech: &Mechanization, nav: &Nav, inc: &Increments) -> Nav {
    match mech {
        Mechanization::Wgs84 => wgs84_step(nav, inc),
        Mechanization::FlatEarth { reference } => flat_earth_step(nav, inc, reference),
    }
}
