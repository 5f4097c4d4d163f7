//! Atmospheric delays of a GNSS signal: the broadcast (Klobuchar) ionosphere and the
//! Saastamoinen troposphere.
//!
//! - Klobuchar: IS-GPS-200 §20.3.3.5.2.5, eight broadcast coefficients, L1 delay in
//!   metres (scale by `(f_L1/f)²` for another frequency).
//! - Saastamoinen (1972) zenith delays from a standard atmosphere (1013.25 hPa and 15 °C
//!   at sea level, −6.5 K/km, relative humidity 0.7 — the values RTKLIB's `tropmodel`
//!   uses), mapped to the elevation by 1/sin(el) (the formula's own mapping).

use super::ephemeris::C;
use core::f64::consts::PI;

/// The ionosphere's broadcast coefficients: α₀…α₃ (s, s/sc, s/sc², s/sc³) and β₀…β₃
/// (s, s/sc, …).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Klobuchar {
    /// Amplitude coefficients.
    pub alpha: [f64; 4],
    /// Period coefficients.
    pub beta: [f64; 4],
}

impl Default for Klobuchar {
    /// The coefficients RTKLIB falls back to when a file has none (broadcast on
    /// 2004-01-01).
    fn default() -> Self {
        Self {
            alpha: [0.1118e-07, -0.7451e-08, -0.5961e-07, 0.1192e-06],
            beta: [0.1167e+06, -0.2294e+06, -0.1311e+06, 0.1049e+07],
        }
    }
}

impl Klobuchar {
    /// Whether any coefficient is non-zero.
    pub fn is_set(&self) -> bool {
        self.alpha.iter().chain(&self.beta).any(|c| *c != 0.0)
    }

    /// The L1 slant delay (m) at a receiver `(lat, lon)` (rad), for a satellite at
    /// azimuth `az` and elevation `el` (rad), at GPS seconds of week `tow`.
    pub fn delay(&self, lat: f64, lon: f64, az: f64, el: f64, tow: f64) -> f64 {
        if el <= 0.0 {
            return 0.0;
        }
        // semicircles
        let e = el / PI;
        let psi = 0.0137 / (e + 0.11) - 0.022;
        let phi_i = (lat / PI + psi * az.cos()).clamp(-0.416, 0.416);
        let lambda_i = lon / PI + psi * az.sin() / (phi_i * PI).cos();
        let phi_m = phi_i + 0.064 * ((lambda_i - 1.617) * PI).cos();
        let t = (4.32e4 * lambda_i + tow).rem_euclid(86_400.0);
        let f = 1.0 + 16.0 * (0.53 - e).powi(3);
        let poly = |c: &[f64; 4]| c[0] + phi_m * (c[1] + phi_m * (c[2] + phi_m * c[3]));
        let amp = poly(&self.alpha).max(0.0);
        let per = poly(&self.beta).max(72_000.0);
        let x = 2.0 * PI * (t - 50_400.0) / per;
        let delay =
            if x.abs() < 1.57 { 5e-9 + amp * (1.0 - x * x / 2.0 + x.powi(4) / 24.0) } else { 5e-9 };
        C * f * delay
    }
}

/// Saastamoinen's slant delay (m) at latitude `lat` (rad), ellipsoidal height `h` (m) and
/// elevation `el` (rad); 0 below the horizon or outside −100 m … 10 km.
pub fn saastamoinen(lat: f64, h: f64, el: f64) -> f64 {
    let (zh, zw) = saastamoinen_zenith(lat, h);
    if el <= 0.0 || !(-100.0..=1e4).contains(&h) {
        return 0.0;
    }
    (zh + zw) / el.sin()
}

/// Saastamoinen's zenith delays (hydrostatic, wet), m, in the standard atmosphere.
pub fn saastamoinen_zenith(lat: f64, h: f64) -> (f64, f64) {
    let h = h.max(0.0);
    let pressure = 1013.25 * (1.0 - 2.2557e-5 * h).powf(5.2568);
    let temp = 15.0 - 6.5e-3 * h + 273.16;
    let humidity = 0.7;
    let e = 6.108 * humidity * ((17.15 * temp - 4684.0) / (temp - 38.45)).exp();
    let zh = 0.002_276_8 * pressure / (1.0 - 0.002_66 * (2.0 * lat).cos() - 0.000_28 * h / 1e3);
    let zw = 0.002_277 * (1255.0 / temp + 0.05) * e;
    (zh, zw)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn klobuchar_night_floor_and_day_peak() {
        let k = Klobuchar {
            alpha: [1.118e-08, 1.49e-08, -5.96e-08, -5.96e-08],
            beta: [8.806e+04, 1.638e+04, -1.966e+05, -1.311e+05],
        };
        let (lat, lon) = (35.16f64.to_radians(), 139.61f64.to_radians());
        let zenith = 90f64.to_radians();
        // local 14:00 (the model's peak): 14 h − lon/15 h UT
        let tow_peak = (14.0 - 139.61 / 15.0) * 3600.0;
        let day = k.delay(lat, lon, 0.0, zenith, tow_peak);
        // local 02:00: the 5 ns night floor times the obliquity (1 at the zenith)
        let night = k.delay(lat, lon, 0.0, zenith, tow_peak + 12.0 * 3600.0);
        assert!((night - C * 5e-9 * (1.0 + 16.0 * 0.03f64.powi(3))).abs() < 1e-9, "{night}");
        assert!(day > 2.0 * night && day < 30.0, "{day}");
        // lower satellites cross more ionosphere
        let low = k.delay(lat, lon, 0.0, 15f64.to_radians(), tow_peak);
        assert!(low > 2.0 * day, "{low} {day}");
    }

    #[test]
    fn saastamoinen_zenith_delay_is_2_4_m_at_sea_level() {
        let (zh, zw) = saastamoinen_zenith(45f64.to_radians(), 0.0);
        // hydrostatic 2.3 m at sea level (0.0022768 × 1013.25), wet ~0.1–0.2 m at 70 % and 15 °C
        assert!((zh - 2.3071).abs() < 2e-3, "{zh}");
        assert!(zw > 0.1 && zw < 0.25, "{zw}");
        let at_30 = saastamoinen(45f64.to_radians(), 0.0, 30f64.to_radians());
        assert!((at_30 - 2.0 * (zh + zw)).abs() < 1e-9);
        assert!(saastamoinen(0.0, 2000.0, 1.0) < saastamoinen(0.0, 0.0, 1.0));
        assert_eq!(saastamoinen(0.0, 0.0, -0.1), 0.0);
    }
}
