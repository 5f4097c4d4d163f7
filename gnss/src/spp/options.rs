//! The single point's options: the atmosphere's models, the weighting, the masks and RAIM.

use super::*;

/// The ionosphere model of a solution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ionosphere {
    /// No correction (5 m of error budget).
    Off,
    /// The broadcast Klobuchar model, scaled to each signal's frequency.
    Klobuchar,
    /// The iono-free combination of the two frequencies' codes (satellites with one are
    /// dropped).
    IonoFree,
}

/// The troposphere model of a solution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Troposphere {
    /// No correction (3 m of error budget).
    Off,
    /// Saastamoinen with the standard atmosphere, mapped by 1/sin(el) (RTKLIB's single
    /// point).
    Saastamoinen,
    /// Saastamoinen's zenith delays mapped by Niell's hydrostatic and wet functions
    /// (lower than 1/sin(el) by 0.5 m at 10° and 3 m at 5°).
    Niell,
}

impl Troposphere {
    /// The model a name selects: `off`, `saastamoinen` or `niell` (as the configuration,
    /// the scenarios and `ins-gnss spp --tropo` write it).
    pub fn from_name(name: &str) -> Option<Self> {
        Some(match name {
            "off" => Self::Off,
            "saastamoinen" => Self::Saastamoinen,
            "niell" => Self::Niell,
            _ => return None,
        })
    }

    /// The slant delay (m) this model gives at `(lat, h)` for a satellite at elevation `el`
    /// at `time` (the season of Niell's mapping); `Off`: 0.
    pub fn delay(self, lat: f64, h: f64, el: f64, time: GpsTime) -> f64 {
        match self {
            Self::Off => 0.0,
            Self::Saastamoinen => saastamoinen(lat, h, el),
            Self::Niell => saastamoinen_niell(lat, h, el, time.day_of_year()),
        }
    }
}

/// Options of the single-point solution.
#[derive(Clone, Debug, PartialEq)]
pub struct SppOptions {
    /// Elevation mask, rad.
    pub elevation_mask: f64,
    /// Ionosphere.
    pub ionosphere: Ionosphere,
    /// Troposphere.
    pub troposphere: Troposphere,
    /// The systems used.
    pub systems: Vec<System>,
    /// Elevation weighting `σ² = a² + b²/sin²(el)`: `(a, b)`, m.
    pub elevation_weight: (f64, f64),
    /// C/N0 weighting `c·10^(−C/N0/10)` (m²·Hz), added when the observation has C/N0;
    /// `None` for elevation only. The σ-ε model of Hartinger and Brunner (1999); 1.6e4 m²Hz
    /// suits a C/A code.
    pub cn0_weight: Option<f64>,
    /// Satellites below this C/N0 (dB-Hz) are not used (0: no mask).
    pub cn0_mask: f64,
    /// Significance of the residuals' χ² check (RTKLIB: 0.001).
    pub alpha: f64,
    /// Largest GDOP accepted.
    pub max_gdop: f64,
    /// Satellites RAIM may exclude one by one while the check fails (0: no exclusion).
    pub max_exclusions: usize,
    /// How much lower (in χ²) the best exclusion must leave the residuals than the
    /// runner-up for RAIM to name a satellite; below it the epoch is refused (a wrong
    /// exclusion would leave the fault in a trusted fix).
    pub raim_margin: f64,
    /// σ of a Doppler's range rate, m/s.
    pub doppler_std: f64,
}

impl Default for SppOptions {
    fn default() -> Self {
        Self {
            elevation_mask: 15f64.to_radians(),
            ionosphere: Ionosphere::Klobuchar,
            troposphere: Troposphere::Saastamoinen,
            systems: vec![System::Gps, System::Galileo, System::BeiDou, System::Qzss],
            elevation_weight: (0.3, 0.3),
            cn0_weight: None,
            cn0_mask: 0.0,
            alpha: 1e-3,
            max_gdop: 30.0,
            max_exclusions: 2,
            raim_margin: 2.0,
            doppler_std: 0.1,
        }
    }
}

impl SppOptions {
    /// The options `rnx2rtkp -p 0` uses when given no configuration (RTKLIB 2.4.3):
    /// 15° mask, no ionosphere and no troposphere correction, no exclusion.
    pub fn rtklib_default() -> Self {
        Self {
            ionosphere: Ionosphere::Off,
            troposphere: Troposphere::Off,
            max_exclusions: 0,
            ..Self::default()
        }
    }
}
