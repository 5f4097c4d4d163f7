//! The settings of an RTK solution in the units users give them (`ins-gnss rtk`'s options,
//! Python's `rtk`, `[gnss.rtk]`) and their checks: [`RtkSettings`], [`base_position`].

use gnss::rtk::{RtkMode, RtkOptions};
use nalgebra::Vector3;

/// The base's ECEF position from three numbers X, Y, Z (m; `--base-position X,Y,Z`,
/// Python's `base_position`): three finite numbers whose distance from the Earth's centre
/// is a place on Earth (6,300–6,450 km), or why not (the caller names its option).
pub fn base_position(v: &[f64]) -> Result<Vector3<f64>, String> {
    let r = match v {
        [x, y, z] => Vector3::new(*x, *y, *z),
        _ => return Err(format!("3 numbers (ECEF X,Y,Z in m) expected, {} given", v.len())),
    };
    if !(r.iter().all(|c| c.is_finite()) && (6.3e6..=6.45e6).contains(&r.norm())) {
        return Err(format!(
            "{:.3},{:.3},{:.3} is {:.0} km from the Earth's centre: not an ECEF position on \
             Earth (m)",
            r.x,
            r.y,
            r.z,
            r.norm() / 1e3
        ));
    }
    Ok(r)
}

/// The settings of `ins-gnss rtk` and of the Python package's `rtk`, in the command's
/// units, with its defaults ([`Default`]); [`RtkSettings::options`] checks them.
#[derive(Clone, Debug, PartialEq)]
pub struct RtkSettings {
    /// The rover stands still (`--static`): its position is one state over the run.
    pub static_rover: bool,
    /// Frequencies: 1 (L1/E1) or 2 (with L2/E5b).
    pub frequencies: usize,
    /// Elevation mask, degrees.
    pub mask: f64,
    /// The ratio test's threshold (≥ 1).
    pub ratio: f64,
    /// The oldest base epoch a rover epoch is paired with, s.
    pub max_age: f64,
    /// The integer bootstrapping success rate a fix needs (`None`: the frequencies'
    /// default).
    pub min_success_rate: Option<f64>,
    /// Partial fixing (the subset of ambiguities that passes).
    pub partial: bool,
    /// The code's persisting single-differenced bias σ, m (0: white code).
    pub code_bias_sigma: f64,
    /// Its correlation time, s (`inf`: constant).
    pub code_bias_tau: f64,
    /// Fix-and-hold after this many consecutive fixed epochs (0: never).
    pub hold: usize,
}

impl Default for RtkSettings {
    fn default() -> Self {
        Self {
            static_rover: false,
            frequencies: 2,
            mask: 15.0,
            ratio: 3.0,
            max_age: 1.0,
            min_success_rate: None,
            partial: false,
            code_bias_sigma: 0.3,
            code_bias_tau: 60.0,
            hold: 5,
        }
    }
}

impl RtkSettings {
    /// The solver's options, or the setting that cannot be used: (its name, why).
    pub fn options(&self) -> Result<RtkOptions, (&'static str, String)> {
        let bad =
            |name: &'static str, value: f64, want: &str| Err((name, format!("{value}: {want}")));
        if !(1..=2).contains(&self.frequencies) {
            return bad("frequencies", self.frequencies as f64, "1 or 2");
        }
        if !(0.0..90.0).contains(&self.mask) {
            return bad("mask", self.mask, "degrees of elevation, 0 to below 90");
        }
        if !(self.ratio.is_finite() && self.ratio >= 1.0) {
            return bad("ratio", self.ratio, "the ratio test's threshold, 1 or more");
        }
        if !(self.max_age.is_finite() && self.max_age > 0.0) {
            return bad("max_age", self.max_age, "seconds, positive");
        }
        if let Some(p) = self.min_success_rate
            && !(0.0..=1.0).contains(&p)
        {
            return bad("min_success_rate", p, "a probability, 0 to 1");
        }
        if !(self.code_bias_sigma.is_finite() && self.code_bias_sigma >= 0.0) {
            return bad("code_bias_sigma", self.code_bias_sigma, "metres, not negative");
        }
        // (infinite: a constant bias)
        if self.code_bias_tau.is_nan() || self.code_bias_tau <= 0.0 {
            return bad("code_bias_tau", self.code_bias_tau, "seconds, positive (or inf)");
        }
        let mode = if self.static_rover { RtkMode::Static } else { RtkMode::Kinematic };
        let defaults = RtkOptions::for_frequencies(mode, self.frequencies);
        Ok(RtkOptions {
            elevation_mask: self.mask.to_radians(),
            ratio: self.ratio,
            max_age: self.max_age,
            min_success_rate: self.min_success_rate.unwrap_or(defaults.min_success_rate),
            partial: self.partial,
            code_bias_sigma: self.code_bias_sigma,
            code_bias_tau: self.code_bias_tau,
            hold: (self.hold > 0).then_some(self.hold),
            ..defaults
        })
    }
}

#[cfg(test)]
mod tests {
    use super::RtkSettings;

    /// A constant code bias is `code_bias_tau = inf` (`--code-bias-tau inf`, as the help
    /// says); zero, negative and NaN are refused with the key.
    #[test]
    fn an_infinite_correlation_time_is_a_constant_bias() {
        let with = |tau: f64| RtkSettings { code_bias_tau: tau, ..Default::default() }.options();
        assert_eq!(with(f64::INFINITY).map(|o| o.code_bias_tau).ok(), Some(f64::INFINITY));
        assert_eq!(with(300.0).map(|o| o.code_bias_tau).ok(), Some(300.0));
        for bad in [0.0, -1.0, f64::NAN] {
            assert_eq!(with(bad).err().map(|e| e.0), Some("code_bias_tau"), "{bad}");
        }
    }
}
