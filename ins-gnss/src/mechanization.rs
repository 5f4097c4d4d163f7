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

use crate::earth::{
    earth_rate_ned_sc, gravity_ned, normal_gravity_from_sin, radii, radii_from_sin,
    transport_rate_with,
};
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

/// Geodetic position after moving with average NED velocity `v_avg` for `dt`, with radii
/// at the midpoint height and latitude.
fn integrate_position(p: &GeoPos, rm0: f64, v_avg: &Vector3<f64>, dt: f64) -> GeoPos {
    let h1 = p.h - v_avg.z * dt;
    let h_mid = 0.5 * (p.h + h1);
    let lat_guess = p.lat + v_avg.x * dt / (rm0 + h_mid);
    let lat_mid = 0.5 * (p.lat + lat_guess);
    let (rm, rn) = radii(lat_mid);
    let lat1 = p.lat + v_avg.x * dt / (rm + h_mid);
    let lat_mid = 0.5 * (p.lat + lat1);
    let lon1 = p.lon + v_avg.y * dt / ((rn + h_mid) * lat_mid.cos());
    GeoPos { lat: lat1, lon: lon1, h: h1 }
}

/// One WGS-84 NED mechanization step.
pub fn wgs84_step(nav: &Nav, inc: &Increments) -> Nav {
    let dt = inc.dt;
    let dv_b = sculling(inc);
    let phi_b = coning(inc);
    let r_nb = nav.att.matrix();
    let f_n = r_nb * dv_b;

    // Predictor with the start-of-interval navigation quantities. Each position's
    // latitude functions come from one `sin_cos`.
    let accel = |p: &GeoPos, v: &Vector3<f64>, s: f64, c: f64| {
        let (rm, rn) = radii_from_sin(s);
        let w_ie = earth_rate_ned_sc(s, c);
        let w_en = transport_rate_with(rm + p.h, rn + p.h, s / c, v);
        let zeta = (w_ie + w_en) * dt;
        let g = Vector3::new(0.0, 0.0, normal_gravity_from_sin(s, p.h));
        let dv_gc = (g - (w_ie * 2.0 + w_en).cross(v)) * dt;
        (zeta, dv_gc)
    };
    let (s0, c0) = nav.pos.lat.sin_cos();
    let rm0 = radii_from_sin(s0).0;
    let (zeta0, dv_gc0) = accel(&nav.pos, &nav.vel, s0, c0);
    let v_pred = nav.vel + f_n - skew(&zeta0) * f_n * 0.5 + dv_gc0;
    let p_pred = integrate_position(&nav.pos, rm0, &((nav.vel + v_pred) * 0.5), dt);
    // Corrector at the midpoint.
    let p_mid = GeoPos {
        lat: 0.5 * (nav.pos.lat + p_pred.lat),
        lon: 0.5 * (nav.pos.lon + p_pred.lon),
        h: 0.5 * (nav.pos.h + p_pred.h),
    };
    let v_mid = (nav.vel + v_pred) * 0.5;
    let (sm, cm) = p_mid.lat.sin_cos();
    let (zeta, dv_gc) = accel(&p_mid, &v_mid, sm, cm);
    let vel = nav.vel + f_n - skew(&zeta) * f_n * 0.5 + dv_gc;
    let pos = integrate_position(&nav.pos, rm0, &((nav.vel + vel) * 0.5), dt);
    let att = So3::exp(&(-zeta)) * nav.att * So3::exp(&phi_b);
    Nav { att, vel, pos }
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
