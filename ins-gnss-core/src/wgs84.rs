//! The WGS-84 ellipsoid: defining constants, radii of curvature and the trigonometry of a
//! latitude near a cached one. Everything here is a function of the latitude alone; the
//! Earth model built on it ([`crate::earth`]) and the geodetic position
//! ([`GeoPos`](crate::GeoPos)) both use it.
//!
//! Constants: NIMA TR8350.2 (WGS-84), 3rd ed. The ellipsoid's shape and radii are the GNSS
//! crate's ([`gnss::geodesy`]), re-exported here.

pub(crate) use gnss::geodesy::{inverse_sqrt_w, radii_from_isw};
pub use gnss::geodesy::{
    meridian_radius, prime_vertical_radius, radii, radii_from_sin, A, B, E2, F,
};

/// Earth rotation rate `ω_ie`, rad/s.
pub const OMEGA_IE: f64 = 7.292_115e-5;
/// Earth's gravitational constant `GM`, m³/s².
pub const GM: f64 = 3.986_004_418e14;
/// Normal gravity at the equator, m/s².
pub const GAMMA_E: f64 = 9.780_325_335_9;
/// Normal gravity at the poles, m/s².
pub const GAMMA_P: f64 = 9.832_184_937_8;

/// `(sin φ, cos φ)` from those of a nearby latitude `φ₀`: `sin(φ₀ + δ)` and
/// `cos(φ₀ + δ)` by angle addition, with `sin δ` and `cos δ` from their series. For
/// `|δ| ≤ 1e-3` rad (6 km of latitude) the first omitted terms, `δ⁵/120` and `δ⁶/720`,
/// are below 1e-17, so the result is as accurate as the library's `sin_cos`; farther
/// away this calls `sin_cos`. The mechanization evaluates four latitudes per epoch within
/// a few metres of each other; this replaces three of their four library calls, which
/// sat on the step's longest chain of dependent operations.
#[inline]
pub fn sin_cos_near(lat: f64, lat0: f64, s0: f64, c0: f64) -> (f64, f64) {
    let d = lat - lat0;
    if d.abs() > 1e-3 || !d.is_finite() {
        return lat.sin_cos();
    }
    let d2 = d * d;
    let sd = d * (1.0 - d2 * (1.0 / 6.0));
    let cd = 1.0 - d2 * (0.5 - d2 * (1.0 / 24.0));
    (s0 * cd + c0 * sd, c0 * cd - s0 * sd)
}
