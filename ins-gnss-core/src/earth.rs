//! WGS-84 Earth model: ellipsoid, normal gravity, radii of curvature, Earth and transport
//! rates, and geodetic ↔ ECEF ↔ local NED conversions.
//!
//! Constants: NIMA TR8350.2 (WGS-84), 3rd ed. Normal gravity: Somigliana's closed form
//! with the second-order height correction (TR8350.2 eq. 4-1 and 4-3).

use nalgebra::Vector3;

use crate::position::GeoPos;

pub use crate::wgs84::*;
use crate::wgs84::{inverse_sqrt_w, radii_from_isw};

/// `dR_N/dφ = R_N e² sin φ cos φ / (1 − e² sin²φ)`, m/rad.
pub fn prime_vertical_radius_derivative(lat: f64) -> f64 {
    let (s, c) = lat.sin_cos();
    LocalEarth::new(s, c, 0.0).rn_prime()
}

/// Normal gravity magnitude at geodetic latitude `lat` (rad) and height `h` (m), m/s².
pub fn normal_gravity(lat: f64, h: f64) -> f64 {
    normal_gravity_from_sin(lat.sin(), h)
}

/// [`normal_gravity`] from `sin φ`.
pub fn normal_gravity_from_sin(s: f64, h: f64) -> f64 {
    gravity_with(s * s, inverse_sqrt_w(s), h)
}

/// `k = b γ_p / (a γ_e) − 1` of Somigliana's formula.
const SOMIGLIANA_K: f64 = B * GAMMA_P / (A * GAMMA_E) - 1.0;
/// `m = ω² a² b / GM`.
const NORMAL_M: f64 = OMEGA_IE * OMEGA_IE * A * A * B / GM;

/// Somigliana's normal gravity on the ellipsoid, `γ₀ = γ_e (1 + k sin²φ) / √(1 − e² sin²φ)`,
/// from `sin²φ` and `isw = 1/√(1 − e² sin²φ)`.
fn somigliana(s2: f64, isw: f64) -> f64 {
    GAMMA_E * (1.0 + SOMIGLIANA_K * s2) * isw
}

/// `2/a (1 + f + m − 2f sin²φ)`, the linear coefficient of the height factor.
fn height_coefficient(s2: f64) -> f64 {
    2.0 / A * (1.0 + F + NORMAL_M - 2.0 * F * s2)
}

/// Normal gravity: [`somigliana`] times the height factor
/// `1 − (2/a)(1 + f + m − 2f sin²φ) h + (3/a²) h²`.
fn gravity_with(s2: f64, isw: f64, h: f64) -> f64 {
    somigliana(s2, isw) * (1.0 - height_coefficient(s2) * h + 3.0 / (A * A) * h * h)
}

/// Partial derivatives of [`normal_gravity`]: `(∂g/∂φ [m/s²/rad], ∂g/∂h [1/s²])`.
pub fn normal_gravity_gradient(lat: f64, h: f64) -> (f64, f64) {
    let (s, c) = lat.sin_cos();
    LocalEarth::new(s, c, h).gravity_gradient()
}

/// The latitude and height functions of one point that the mechanization and the error
/// model use, from one sine and cosine with one square root and four divisions (each
/// function on its own would take about fifteen divisions and three roots; they sit on
/// the mechanization's chain of dependent operations).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalEarth {
    /// `sin φ`.
    pub sin: f64,
    /// `cos φ`.
    pub cos: f64,
    /// `tan φ`.
    pub tan: f64,
    /// `1/cos φ`.
    pub sec: f64,
    /// `1/√(1 − e² sin²φ)`.
    pub isw: f64,
    /// Height, m.
    pub h: f64,
    /// Meridian radius `R_M`, m.
    pub rm: f64,
    /// Prime-vertical radius `R_N`, m.
    pub rn: f64,
    /// `1/(R_M + h)`, 1/m.
    pub inv_rmh: f64,
    /// `1/(R_N + h)`, 1/m.
    pub inv_rnh: f64,
}

impl LocalEarth {
    /// The functions at a geodetic position (one `sin_cos`).
    pub fn at(p: &GeoPos) -> Self {
        let (s, c) = p.lat.sin_cos();
        Self::new(s, c, p.h)
    }

    /// [`GeoPos::metric`](crate::GeoPos::metric) here: `(R_M + h, (R_N + h) cos φ, −1)`.
    pub fn metric(&self) -> Vector3<f64> {
        crate::position::metric_from_radii(self.rm, self.rn, self.cos, self.h)
    }

    /// The functions at latitude `φ` (given by `sin φ`, `cos φ`) and height `h`.
    pub fn new(sin: f64, cos: f64, h: f64) -> Self {
        let isw = inverse_sqrt_w(sin);
        let (rm, rn) = radii_from_isw(isw);
        let sec = 1.0 / cos;
        Self {
            sin,
            cos,
            tan: sin * sec,
            sec,
            isw,
            h,
            rm,
            rn,
            inv_rmh: 1.0 / (rm + h),
            inv_rnh: 1.0 / (rn + h),
        }
    }

    /// Earth rate in NED, rad/s.
    pub fn earth_rate(&self) -> Vector3<f64> {
        earth_rate_ned_sc(self.sin, self.cos)
    }

    /// Transport rate in NED for velocity `v_n`, rad/s.
    pub fn transport_rate(&self, v_n: &Vector3<f64>) -> Vector3<f64> {
        Vector3::new(v_n.y * self.inv_rnh, -v_n.x * self.inv_rmh, -v_n.y * self.tan * self.inv_rnh)
    }

    /// Normal gravity, m/s².
    pub fn gravity(&self) -> f64 {
        gravity_with(self.sin * self.sin, self.isw, self.h)
    }

    /// `(∂g/∂φ [m/s²/rad], ∂g/∂h [1/s²])` of normal gravity.
    pub fn gravity_gradient(&self) -> (f64, f64) {
        let (s, c, h, isw) = (self.sin, self.cos, self.h, self.isw);
        let s2 = s * s;
        let g0 = somigliana(s2, isw);
        // dγ₀/dφ = γ_e [2k s c / √w + (1 + k s²) e² s c / w^{3/2}], w = 1 − e² s²
        let k = SOMIGLIANA_K;
        let dg0 = GAMMA_E * s * c * isw * (2.0 * k + (1.0 + k * s2) * E2 * isw * isw);
        let hf = 1.0 - height_coefficient(s2) * h + 3.0 / (A * A) * h * h;
        // d(hf)/dφ = (2/a)(4 f s c) h
        let dhf_dlat = 2.0 / A * (4.0 * F * s * c) * h;
        let dhf_dh = -height_coefficient(s2) + 6.0 * h / (A * A);
        (dg0 * hf + g0 * dhf_dlat, g0 * dhf_dh)
    }

    /// `dR_N/dφ = R_N e² sin φ cos φ / (1 − e² sin²φ)`, m/rad.
    pub fn rn_prime(&self) -> f64 {
        self.rn * E2 * self.sin * self.cos * self.isw * self.isw
    }
}

/// Gravity vector in NED (down positive), m/s².
pub fn gravity_ned(lat: f64, h: f64) -> Vector3<f64> {
    Vector3::new(0.0, 0.0, normal_gravity(lat, h))
}

/// Earth rate in NED, `ω_ie^n = ω [cos φ, 0, −sin φ]`, rad/s.
pub fn earth_rate_ned(lat: f64) -> Vector3<f64> {
    let (s, c) = lat.sin_cos();
    earth_rate_ned_sc(s, c)
}

/// [`earth_rate_ned`] from `sin φ`, `cos φ`.
pub fn earth_rate_ned_sc(s: f64, c: f64) -> Vector3<f64> {
    Vector3::new(OMEGA_IE * c, 0.0, -OMEGA_IE * s)
}

/// Transport rate `ω_en^n = [v_E/(R_N+h), −v_N/(R_M+h), −v_E tan φ/(R_N+h)]`, rad/s.
pub fn transport_rate(lat: f64, h: f64, v_n: &Vector3<f64>) -> Vector3<f64> {
    LocalEarth::at(&GeoPos { lat, lon: 0.0, h }).transport_rate(v_n)
}

pub use gnss::geodesy::{
    ecef_to_geodetic, ecef_to_ned_rotation, geodetic_to_ecef, geodetic_to_local_ned,
    local_ned_to_geodetic,
};
