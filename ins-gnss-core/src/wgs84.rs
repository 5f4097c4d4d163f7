//! The WGS-84 ellipsoid: defining constants, radii of curvature and the trigonometry of a
//! latitude near a cached one. Everything here is a function of the latitude alone; the
//! Earth model built on it ([`crate::earth`]) and the geodetic position
//! ([`GeoPos`](crate::GeoPos)) both use it.
//!
//! Constants: NIMA TR8350.2 (WGS-84), 3rd ed.

/// Semi-major axis `a`, m.
pub const A: f64 = 6_378_137.0;
/// Flattening `f`.
pub const F: f64 = 1.0 / 298.257_223_563;
/// First eccentricity squared `e² = f (2 − f)`.
pub const E2: f64 = F * (2.0 - F);
/// Semi-minor axis `b = a (1 − f)`, m.
pub const B: f64 = A * (1.0 - F);
/// Earth rotation rate `ω_ie`, rad/s.
pub const OMEGA_IE: f64 = 7.292_115e-5;
/// Earth's gravitational constant `GM`, m³/s².
pub const GM: f64 = 3.986_004_418e14;
/// Normal gravity at the equator, m/s².
pub const GAMMA_E: f64 = 9.780_325_335_9;
/// Normal gravity at the poles, m/s².
pub const GAMMA_P: f64 = 9.832_184_937_8;

/// Meridian radius of curvature `R_M(φ) = a (1 − e²) / (1 − e² sin²φ)^{3/2}`, m.
pub fn meridian_radius(lat: f64) -> f64 {
    radii_from_sin(lat.sin()).0
}

/// Prime-vertical radius of curvature `R_N(φ) = a / (1 − e² sin²φ)^{1/2}`, m.
pub fn prime_vertical_radius(lat: f64) -> f64 {
    radii_from_sin(lat.sin()).1
}

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

/// Both radii `(R_M, R_N)`.
pub fn radii(lat: f64) -> (f64, f64) {
    radii_from_sin(lat.sin())
}

/// Both radii `(R_M, R_N)` from `sin φ` (for callers that already have it: the error
/// model evaluates every latitude function of one epoch from one `sin_cos`).
pub fn radii_from_sin(s: f64) -> (f64, f64) {
    radii_from_isw(inverse_sqrt_w(s))
}

/// `1/√(1 − e² sin²φ)`.
pub(crate) fn inverse_sqrt_w(s: f64) -> f64 {
    1.0 / (1.0 - E2 * s * s).sqrt()
}

/// `(R_M, R_N) = (a (1 − e²) isw³, a isw)` from `isw = 1/√(1 − e² sin²φ)`.
pub(crate) fn radii_from_isw(isw: f64) -> (f64, f64) {
    (A * (1.0 - E2) * isw * isw * isw, A * isw)
}
