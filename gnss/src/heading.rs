//! A heading measured between two antennas (a moving-base receiver's), as the receivers'
//! logs give it; the INS's heading update (`ins-gnss-core`'s `heading`) takes it.

/// One moving-base measurement: the baseline's heading and, where given, its elevation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AntennaHeading {
    /// Time, s (the GNSS epoch's).
    pub t: f64,
    /// Heading of the baseline, clockwise from true north, rad.
    pub heading: f64,
    /// The heading's 1σ the source states, rad (`None`: the configuration's).
    pub heading_std: Option<f64>,
    /// Elevation of the baseline (up positive) and its 1σ where stated, rad.
    pub pitch: Option<(f64, Option<f64>)>,
    /// The baseline's measured length, m, where the source gives it.
    pub length: Option<f64>,
}

/// An angle wrapped to (−π, π].
pub fn wrap(a: f64) -> f64 {
    let w = a.rem_euclid(std::f64::consts::TAU);
    if w > std::f64::consts::PI {
        w - std::f64::consts::TAU
    } else {
        w
    }
}
