//! Atmospheric delays of a GNSS signal: the broadcast (Klobuchar) ionosphere and the
//! Saastamoinen troposphere.
//!
//! - Klobuchar: IS-GPS-200 §20.3.3.5.2.5, eight broadcast coefficients, L1 delay in
//!   metres (scale by `(f_L1/f)²` for another frequency).
//! - Saastamoinen (1972) zenith delays from a standard atmosphere (1013.25 hPa and 15 °C
//!   at sea level, −6.5 K/km, relative humidity 0.7 — the values RTKLIB's `tropmodel`
//!   uses), mapped to the elevation by 1/sin(el) (the formula's own mapping, and
//!   RTKLIB's in its single point) or by Niell's (1996) mapping functions, hydrostatic
//!   and wet apart ([`niell`]): 1/sin(el) treats the atmosphere as flat, and overstates
//!   the hydrostatic delay by about 0.5 m at 10° of elevation and 3 m at 5°.

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
    if !modelled(h, el) {
        return 0.0;
    }
    let (zh, zw) = saastamoinen_zenith(lat, h);
    (zh + zw) / el.sin()
}

/// Whether the troposphere models give a delay: a satellite above the horizon seen from
/// −100 m … 10 km.
fn modelled(h: f64, el: f64) -> bool {
    el > 0.0 && (-100.0..=1e4).contains(&h)
}

/// Saastamoinen's zenith delays mapped by Niell's functions: `z_h·m_h + z_w·m_w` (m), at
/// day of year `doy` (for the hydrostatic mapping's season); 0 where [`saastamoinen`] is.
pub fn saastamoinen_niell(lat: f64, h: f64, el: f64, doy: f64) -> f64 {
    if !modelled(h, el) {
        return 0.0;
    }
    let (zh, zw) = saastamoinen_zenith(lat, h);
    let (mh, mw) = niell(lat, h, el, doy);
    zh * mh + zw * mw
}

/// Marini's continued fraction in the form Niell normalised to 1 at the zenith:
/// `(1 + a/(1 + b/(1 + c))) / (sin e + a/(sin e + b/(sin e + c)))`.
fn marini(el: f64, (a, b, c): (f64, f64, f64)) -> f64 {
    let s = el.sin();
    (1.0 + a / (1.0 + b / (1.0 + c))) / (s + a / (s + b / (s + c)))
}

/// Niell's (1996) latitudes of the coefficient tables, degrees; a coefficient is
/// interpolated linearly in |latitude| between them and held beyond them.
const NIELL_LATITUDES: [f64; 5] = [15.0, 30.0, 45.0, 60.0, 75.0];
/// Hydrostatic `a, b, c`: annual averages, then amplitudes of the seasonal term (Niell
/// 1996, table 3).
const NIELL_HYDRO_AVG: [[f64; 5]; 3] = [
    [1.276_993_4e-3, 1.268_323_0e-3, 1.246_539_7e-3, 1.219_604_9e-3, 1.204_599_6e-3],
    [2.915_369_5e-3, 2.915_229_9e-3, 2.928_844_5e-3, 2.902_256_5e-3, 2.902_491_2e-3],
    [62.610_505e-3, 62.837_393e-3, 63.721_774e-3, 63.824_265e-3, 64.258_455e-3],
];
const NIELL_HYDRO_AMP: [[f64; 5]; 3] = [
    [0.0, 1.270_962_6e-5, 2.652_366_2e-5, 3.400_045_2e-5, 4.120_219_1e-5],
    [0.0, 2.141_497_9e-5, 3.016_077_9e-5, 7.256_272_2e-5, 11.723_375e-5],
    [0.0, 9.012_840_0e-5, 4.349_703_7e-5, 84.795_348e-5, 170.372_06e-5],
];
/// The hydrostatic mapping's height correction `a, b, c` (per km of height).
const NIELL_HEIGHT: (f64, f64, f64) = (2.53e-5, 5.49e-3, 1.14e-3);
/// Wet `a, b, c` (no seasonal term).
const NIELL_WET: [[f64; 5]; 3] = [
    [5.802_189_7e-4, 5.679_484_7e-4, 5.811_801_9e-4, 5.972_754_2e-4, 6.164_169_3e-4],
    [1.427_526_8e-3, 1.513_862_5e-3, 1.457_275_2e-3, 1.500_742_8e-3, 1.759_908_2e-3],
    [4.347_296_1e-2, 4.672_951_0e-2, 4.390_893_1e-2, 4.462_698_2e-2, 5.473_603_8e-2],
];

/// A table's row at |latitude| `lat_deg`: linear between the tabulated latitudes.
fn niell_row(row: &[f64; 5], lat_deg: f64) -> f64 {
    let x = lat_deg.abs();
    let l = &NIELL_LATITUDES;
    if x <= l[0] {
        return row[0];
    }
    if x >= l[4] {
        return row[4];
    }
    let i = ((x - l[0]) / 15.0).floor() as usize;
    let t = (x - l[i]) / (l[i + 1] - l[i]);
    row[i] + t * (row[i + 1] - row[i])
}

/// Niell's (1996) mapping functions `(m_h, m_w)` at latitude `lat` (rad), height `h` (m,
/// above the ellipsoid; Niell's is above sea level, within tens of metres the same here),
/// elevation `el` (rad) and day of year `doy` (1.0 = 1 January 0 h). Both are 1 at the
/// zenith. The hydrostatic coefficients vary with the season, peaking on day 28 in the
/// north and half a year later in the south; the wet ones do not.
pub fn niell(lat: f64, h: f64, el: f64, doy: f64) -> (f64, f64) {
    let lat_deg = lat.to_degrees();
    let phase = if lat < 0.0 { doy - 28.0 + 365.25 / 2.0 } else { doy - 28.0 };
    let season = (2.0 * core::f64::consts::PI * phase / 365.25).cos();
    let coef = |k: usize| {
        niell_row(&NIELL_HYDRO_AVG[k], lat_deg) - niell_row(&NIELL_HYDRO_AMP[k], lat_deg) * season
    };
    let hydro = marini(el, (coef(0), coef(1), coef(2)));
    let height = (1.0 / el.sin() - marini(el, NIELL_HEIGHT)) * h / 1e3;
    let wet = |k: usize| niell_row(&NIELL_WET[k], lat_deg);
    (hydro + height, marini(el, (wet(0), wet(1), wet(2))))
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

    #[test]
    fn niell_is_one_at_the_zenith_and_below_the_flat_mapping_near_the_horizon() {
        let zenith = core::f64::consts::FRAC_PI_2;
        for lat in [-80.0f64, -45.0, 0.0, 22.5, 45.0, 52.0, 80.0] {
            for doy in [1.0, 28.0, 120.0, 300.0] {
                let (mh, mw) = niell(lat.to_radians(), 500.0, zenith, doy);
                assert!((mh - 1.0).abs() < 1e-12 && (mw - 1.0).abs() < 1e-12, "{mh} {mw}");
            }
        }
        let (lat, doy) = (45f64.to_radians(), 150.0);
        // high satellites: within 0.5 % of 1/sin(el) (the atmosphere's curvature is felt
        // only low down)
        for el_deg in [30.0f64, 45.0, 60.0] {
            let el = el_deg.to_radians();
            let (mh, mw) = niell(lat, 0.0, el, doy);
            let flat = 1.0 / el.sin();
            assert!((mh / flat - 1.0).abs() < 5e-3 && (mw / flat - 1.0).abs() < 5e-3);
        }
        // low ones: below 1/sin(el), the hydrostatic function more so than the wet
        // (the wet layer is lower, so flatter); at 5° the hydrostatic value is about 10.2
        // (1/sin 5° = 11.47)
        let el = 5f64.to_radians();
        let (mh, mw) = niell(lat, 0.0, el, doy);
        assert!(mh > 9.9 && mh < 10.4, "{mh}");
        assert!(mh < mw && mw < 1.0 / el.sin(), "{mh} {mw}");
        // the mapping grows with height (less atmosphere above to bend through)
        assert!(niell(lat, 2000.0, el, doy).0 > mh);
        // and the slant delay: below the 1/sin mapping's by about 3 m at 5°
        let d = saastamoinen(lat, 0.0, el) - saastamoinen_niell(lat, 0.0, el, doy);
        assert!(d > 2.5 && d < 3.5, "{d}");
        assert_eq!(saastamoinen_niell(lat, 0.0, -0.1, doy), 0.0);
    }

    #[test]
    fn niell_seasons_mirror_between_hemispheres_and_vanish_at_15_degrees() {
        let el = 7f64.to_radians();
        let north = niell(50f64.to_radians(), 0.0, el, 28.0);
        let south = niell(-50f64.to_radians(), 0.0, el, 28.0 + 365.25 / 2.0);
        assert!((north.0 - south.0).abs() < 1e-12 && (north.1 - south.1).abs() < 1e-12);
        // the seasons differ at 50°, not at the equator's table row
        let summer = niell(50f64.to_radians(), 0.0, el, 28.0 + 365.25 / 2.0).0;
        assert!((summer - north.0).abs() > 1e-3, "{summer} {}", north.0);
        let (a, b) = (niell(0.1, 0.0, el, 28.0).0, niell(0.1, 0.0, el, 200.0).0);
        assert!((a - b).abs() < 1e-15);
        // the tables are interpolated in latitude: 37.5° lies between 30° and 45°
        let (m30, m45) =
            (niell(30f64.to_radians(), 0.0, el, 100.0), niell(45f64.to_radians(), 0.0, el, 100.0));
        let m = niell(37.5f64.to_radians(), 0.0, el, 100.0);
        assert!(m.0 > m30.0.min(m45.0) && m.0 < m30.0.max(m45.0));
    }
}
