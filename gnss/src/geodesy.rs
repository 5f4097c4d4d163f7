//! The WGS-84 ellipsoid and the conversions on it: the defining shape (`a`, `f`), the
//! radii of curvature, geodetic ↔ ECEF ↔ local NED. What the satellite geometry needs
//! and the INS's Earth model (`ins-gnss-core`'s `wgs84` and `earth`) builds on.
//!
//! Constants: NIMA TR8350.2 (WGS-84), 3rd ed.

use nalgebra::{Matrix3, Vector3};

/// Semi-major axis `a`, m.
pub const A: f64 = 6_378_137.0;
/// Flattening `f`.
pub const F: f64 = 1.0 / 298.257_223_563;
/// First eccentricity squared `e² = f (2 − f)`.
pub const E2: f64 = F * (2.0 - F);
/// Semi-minor axis `b = a (1 − f)`, m.
pub const B: f64 = A * (1.0 - F);

/// Meridian radius of curvature `R_M(φ) = a (1 − e²) / (1 − e² sin²φ)^{3/2}`, m.
#[inline]
pub fn meridian_radius(lat: f64) -> f64 {
    radii_from_sin(lat.sin()).0
}

/// Prime-vertical radius of curvature `R_N(φ) = a / (1 − e² sin²φ)^{1/2}`, m.
#[inline]
pub fn prime_vertical_radius(lat: f64) -> f64 {
    radii_from_sin(lat.sin()).1
}

/// Both radii `(R_M, R_N)`.
#[inline]
pub fn radii(lat: f64) -> (f64, f64) {
    radii_from_sin(lat.sin())
}

/// Both radii `(R_M, R_N)` from `sin φ` (for callers that already have it: the error
/// model evaluates every latitude function of one epoch from one `sin_cos`).
#[inline]
pub fn radii_from_sin(s: f64) -> (f64, f64) {
    radii_from_isw(inverse_sqrt_w(s))
}

/// `1/√(1 − e² sin²φ)`.
#[inline]
pub fn inverse_sqrt_w(s: f64) -> f64 {
    1.0 / (1.0 - E2 * s * s).sqrt()
}

/// `(R_M, R_N) = (a (1 − e²) isw³, a isw)` from `isw = 1/√(1 − e² sin²φ)`.
#[inline]
pub fn radii_from_isw(isw: f64) -> (f64, f64) {
    (A * (1.0 - E2) * isw * isw * isw, A * isw)
}

/// Geodetic (lat, lon rad; h m) → ECEF, m.
#[inline]
pub fn geodetic_to_ecef(lat: f64, lon: f64, h: f64) -> Vector3<f64> {
    let rn = prime_vertical_radius(lat);
    let (sl, cl) = lat.sin_cos();
    let (so, co) = lon.sin_cos();
    Vector3::new((rn + h) * cl * co, (rn + h) * cl * so, (rn * (1.0 - E2) + h) * sl)
}

/// ECEF → geodetic `(lat, lon, h)` by Bowring's start and Newton iterations on latitude
/// (converges to < 1e-12 rad in 3–4 iterations anywhere outside the Earth's centre).
pub fn ecef_to_geodetic(r: &Vector3<f64>) -> (f64, f64, f64) {
    let lon = r.y.atan2(r.x);
    let p = (r.x * r.x + r.y * r.y).sqrt();
    if p < 1e-9 {
        let lat =
            if r.z >= 0.0 { core::f64::consts::FRAC_PI_2 } else { -core::f64::consts::FRAC_PI_2 };
        return (lat, lon, r.z.abs() - B);
    }
    // Bowring's initial value.
    let ep2 = (A * A - B * B) / (B * B);
    let theta = (r.z * A).atan2(p * B);
    let (st, ct) = theta.sin_cos();
    let mut lat = (r.z + ep2 * B * st.powi(3)).atan2(p - E2 * A * ct.powi(3));
    for _ in 0..5 {
        let rn = prime_vertical_radius(lat);
        let h = p / lat.cos() - rn;
        let next = r.z.atan2(p * (1.0 - E2 * rn / (rn + h)));
        let done = (next - lat).abs() < 1e-14;
        lat = next;
        if done {
            break;
        }
    }
    let rn = prime_vertical_radius(lat);
    let h =
        if lat.cos().abs() > 1e-6 { p / lat.cos() - rn } else { r.z / lat.sin() - rn * (1.0 - E2) };
    (lat, lon, h)
}

/// Rotation from ECEF to the local NED frame at (lat, lon): `v_n = C_ne v_e`.
#[inline]
pub fn ecef_to_ned_rotation(lat: f64, lon: f64) -> Matrix3<f64> {
    let (sl, cl) = lat.sin_cos();
    let (so, co) = lon.sin_cos();
    Matrix3::new(-sl * co, -sl * so, cl, -so, co, 0.0, -cl * co, -cl * so, -sl)
}

/// NED coordinates (m) of a geodetic point relative to a reference point (exact, through
/// ECEF).
pub fn geodetic_to_local_ned(reference: (f64, f64, f64), point: (f64, f64, f64)) -> Vector3<f64> {
    let r0 = geodetic_to_ecef(reference.0, reference.1, reference.2);
    let r = geodetic_to_ecef(point.0, point.1, point.2);
    ecef_to_ned_rotation(reference.0, reference.1) * (r - r0)
}

/// Geodetic point at NED offset `ned` (m) from a reference point (exact, through ECEF).
pub fn local_ned_to_geodetic(reference: (f64, f64, f64), ned: &Vector3<f64>) -> (f64, f64, f64) {
    let r0 = geodetic_to_ecef(reference.0, reference.1, reference.2);
    let r = r0 + ecef_to_ned_rotation(reference.0, reference.1).transpose() * ned;
    ecef_to_geodetic(&r)
}
