//! Raw observations: per epoch, per satellite, on two frequencies.

use super::time::{GpsTime, Sat, System};

/// One signal's observations (any may be missing).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Signal {
    /// Pseudorange, m.
    pub code: Option<f64>,
    /// Carrier phase, cycles.
    pub phase: Option<f64>,
    /// Doppler, Hz (positive when the satellite approaches).
    pub doppler: Option<f64>,
    /// Carrier-to-noise density, dB-Hz.
    pub cn0: Option<f64>,
    /// Loss-of-lock indicator of the phase (bit 0: a slip may have occurred).
    pub lli: u8,
}

/// A satellite's observations in one epoch: the first (L1/E1/B1I) and second (L2/E5a/B3I)
/// frequency.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SatObs {
    /// The satellite.
    pub sat: Sat,
    /// First and second frequency.
    pub signals: [Signal; 2],
}

/// One epoch of a receiver's observations.
#[derive(Clone, Debug, PartialEq)]
pub struct ObsEpoch {
    /// Receiver time stamp (GPS time).
    pub time: GpsTime,
    /// RINEX epoch flag (0 OK, 1 power failure before this epoch).
    pub flag: u8,
    /// Satellites in the order of the file.
    pub sats: Vec<SatObs>,
    /// The file line (or UBX byte offset) the epoch starts at, for messages.
    pub line: usize,
}

/// Carrier frequency (Hz) of a system's first (`slot = 0`) or second (`slot = 1`) frequency
/// as this crate assigns them: GPS/QZSS L1, L2; Galileo E1, E5a; BeiDou B1I, B3I.
pub fn frequency(sys: System, slot: usize) -> f64 {
    match (sys, slot) {
        (System::Gps | System::Qzss | System::Galileo | System::Sbas, 0) => 1_575.42e6,
        (System::Gps | System::Qzss, _) => 1_227.60e6,
        (System::Galileo | System::Sbas, _) => 1_176.45e6,
        (System::BeiDou, 0) => 1_561.098e6,
        (System::BeiDou, _) => 1_268.52e6,
        (System::Glonass, 0) => 1_602.0e6,
        (System::Glonass, _) => 1_246.0e6,
        (System::Irnss, 0) => 1_176.45e6,
        (System::Irnss, _) => 2_492.028e6,
    }
}

/// Which slot a RINEX 3 band (the observation code's digit) fills for a system, and the
/// preference among attributes (lower is preferred).
pub fn slot_of(sys: System, band: u8, attr: u8) -> Option<(usize, u8)> {
    let rank = |order: &[u8]| order.iter().position(|a| *a == attr).map(|p| p as u8);
    match (sys, band) {
        (System::Gps | System::Qzss | System::Sbas, b'1') => Some((0, rank(b"CWPSLXYM")?)),
        (System::Gps | System::Qzss, b'2') => Some((1, rank(b"WPCDSLXYM")?)),
        (System::Galileo, b'1') => Some((0, rank(b"CXBAZ")?)),
        (System::Galileo, b'5') => Some((1, rank(b"QXI")?)),
        // RINEX 3.02 wrote BeiDou's B1I as band 1, later versions as band 2
        (System::BeiDou, b'2' | b'1') => Some((0, rank(b"IQX")?)),
        (System::BeiDou, b'6') => Some((1, rank(b"IQX")?)),
        (System::Glonass, b'1') => Some((0, rank(b"CP")?)),
        (System::Glonass, b'2') => Some((1, rank(b"PC")?)),
        _ => None,
    }
}
