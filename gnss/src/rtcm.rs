//! RTCM 3 from a file (a base station's stream as `str2str` or a caster client saves it):
//! the observations of its Multiple Signal Messages — MSM4 and MSM7 of GPS (1074, 1077),
//! Galileo (1094, 1097), QZSS (1114, 1117) and BeiDou (1124, 1127) — as epochs, and the
//! station's antenna reference point (1005, 1006). The frames and fields are decoded by
//! the `rtcm-rs` crate; this module assembles them: each satellite's rough range and each
//! signal's fine pseudorange and phase into full observations, the messages of one instant
//! into one epoch, the lock-time indicators into slip flags, and the time of week into a
//! GPS time near a given one (MSM carries no week).
//!
//! Other messages (ephemerides, GLONASS, MSM1–3, 5, 6, legacy 1001–1004) are counted, not
//! read: the navigation data come from a navigation file or the rover's own log.

use crate::obs::{frequency, slot_of, ObsEpoch, SatObs, Signal};
use crate::time::{GpsTime, Sat, System};
use crate::RawError;
use nalgebra::Vector3;
use rtcm_rs::prelude::*;
use std::collections::{BTreeMap, HashMap};
use std::path::Path;

/// Metres light travels in a millisecond.
const LIGHT_MS: f64 = 299_792.458;

/// BeiDou time is GPS time less this (s).
const BDT_GPST: f64 = 14.0;

/// What a file of RTCM 3 frames gave.
#[derive(Clone, Debug, Default)]
pub struct RtcmLog {
    /// The observations, one epoch per instant, in time order.
    pub epochs: Vec<ObsEpoch>,
    /// The station's antenna reference point (ECEF, m) of its last 1005 or 1006 message.
    pub position: Option<Vector3<f64>>,
    /// Frames decoded (any message).
    pub frames: usize,
    /// Frames of messages not read, by message number.
    pub other: BTreeMap<u16, usize>,
}

/// One MSM's content, whatever its type: system, time of week (ms, the system's own time),
/// each satellite's rough range (ms) and rate (m/s), each cell's signal.
struct Msm {
    sys: System,
    tow_ms: u32,
    sats: Vec<(u8, Option<f64>, Option<f64>)>,
    cells: Vec<Cell>,
}

/// One satellite and signal of an MSM: fine pseudorange and phase range (ms, beside the
/// satellite's rough range), the lock-time indicator (its kind: MSM7's extended one), C/N0
/// (dB-Hz) and the fine phase-range rate (m/s).
struct Cell {
    sat: u8,
    band: u8,
    attr: char,
    code: Option<f64>,
    phase: Option<f64>,
    lock: (bool, u16),
    cn0: Option<f64>,
    rate: Option<f64>,
}

/// An MSM of either type as an [`Msm`]: its time field, its cells' code, phase and
/// lock-time fields (MSM7's extended: `$ext`), and how to read a satellite's rough rate,
/// a cell's C/N0 and a cell's fine rate (MSM4 has no rates).
macro_rules! msm {
    ($m:expr, $sys:expr, $time:ident, ($code:ident, $phase:ident, $lock:ident, $ext:expr),
     |$s:ident| $sat_rate:expr, |$c:ident| ($cn0:expr, $rate:expr)) => {
        Msm {
            sys: $sys,
            tow_ms: $m.$time,
            sats: $m
                .data_segment
                .satellite_data
                .iter()
                .map(|s| {
                    let rough = s.gnss_satellite_rough_range_integer_ms;
                    let rough =
                        rough.map(|i| f64::from(i) + s.gnss_satellite_rough_range_mod1ms_ms);
                    let $s = s;
                    (s.satellite_id, rough, $sat_rate)
                })
                .collect(),
            cells: $m
                .data_segment
                .signal_data
                .iter()
                .map(|c| {
                    let $c = c;
                    Cell {
                        sat: c.satellite_id,
                        band: c.signal_id.band(),
                        attr: c.signal_id.attribute(),
                        code: c.$code,
                        phase: c.$phase,
                        lock: ($ext, u16::from(c.$lock)),
                        cn0: $cn0,
                        rate: $rate,
                    }
                })
                .collect(),
        }
    };
}

macro_rules! msm4 {
    ($m:expr, $sys:expr, $time:ident) => {
        msm!(
            $m,
            $sys,
            $time,
            (
                gnss_signal_fine_pseudorange_ms,
                gnss_signal_fine_phaserange_ms,
                gnss_phaserange_lock_time_ind,
                false
            ),
            |_s| None,
            |c| (c.gnss_signal_cnr_dbhz.map(f64::from), None)
        )
    };
}

macro_rules! msm7 {
    ($m:expr, $sys:expr, $time:ident) => {
        msm!(
            $m,
            $sys,
            $time,
            (
                gnss_signal_fine_pseudorange_ext_ms,
                gnss_signal_fine_phaserange_ext_ms,
                gnss_phaserange_lock_time_ext_ind,
                true
            ),
            |s| s.gnss_satellite_rough_phaserange_rates_m_s.map(f64::from),
            |c| (c.gnss_signal_cnr_ext_dbhz, c.gnss_signal_fine_phaserange_rate_m_s)
        )
    };
}

/// A 1005 or 1006 message's antenna reference point (ECEF, m).
macro_rules! arp {
    ($m:expr) => {
        Vector3::new(
            $m.antenna_ref_point_ecef_x_m,
            $m.antenna_ref_point_ecef_y_m,
            $m.antenna_ref_point_ecef_z_m,
        )
    };
}

/// Reads a file of RTCM 3 frames (plain, or `.gz`/`.zst`/`.xz`); each MSM's time of week
/// is taken in the week that puts it nearest `near`. A file without a frame, or without
/// an MSM this module reads, is refused, naming the messages it has.
pub fn read_rtcm(path: &Path, near: GpsTime) -> Result<RtcmLog, RawError> {
    let err = |line: usize, m: String| RawError { path: path.to_path_buf(), line, message: m };
    let mut bytes = Vec::new();
    std::io::Read::read_to_end(&mut crate::open_input(path)?, &mut bytes)
        .map_err(|e| err(0, e.to_string()))?;
    let mut log = RtcmLog::default();
    let mut epochs: BTreeMap<i64, (usize, HashMap<Sat, SatObs>)> = BTreeMap::new();
    let mut locks: HashMap<(Sat, usize), (bool, u16)> = HashMap::new();
    let mut at = 0;
    while at < bytes.len() {
        let (used, frame) = next_msg_frame(&bytes[at..]);
        let offset = at;
        at += used.max(1);
        let Some(frame) = frame else { continue };
        log.frames += 1;
        let msm = match frame.get_message() {
            // (the antenna reference point of either station message)
            Message::Msg1005(m) => {
                log.position = Some(arp!(m));
                continue;
            }
            Message::Msg1006(m) => {
                log.position = Some(arp!(m));
                continue;
            }
            Message::Msg1074(m) => msm4!(m, System::Gps, gps_epoch_time_ms),
            Message::Msg1077(m) => msm7!(m, System::Gps, gps_epoch_time_ms),
            Message::Msg1094(m) => msm4!(m, System::Galileo, gal_epoch_time_ms),
            Message::Msg1097(m) => msm7!(m, System::Galileo, gal_epoch_time_ms),
            Message::Msg1114(m) => msm4!(m, System::Qzss, qzss_epoch_time_ms),
            Message::Msg1117(m) => msm7!(m, System::Qzss, qzss_epoch_time_ms),
            Message::Msg1124(m) => msm4!(m, System::BeiDou, bds_epoch_time_ms),
            Message::Msg1127(m) => msm7!(m, System::BeiDou, bds_epoch_time_ms),
            _ => {
                *log.other.entry(frame.message_number().unwrap_or(0)).or_insert(0) += 1;
                continue;
            }
        };
        let time = gps_time(&msm, near);
        let key = (time.week as i64) * 604_800_000 + (time.tow * 1000.0).round() as i64;
        let (_, sats) = epochs.entry(key).or_insert_with(|| (offset, HashMap::new()));
        add(&msm, sats, &mut locks);
    }
    if epochs.is_empty() {
        let what: Vec<String> = log.other.iter().map(|(k, n)| format!("{k} ×{n}")).collect();
        return Err(err(
            0,
            match log.frames {
                0 => "no RTCM 3 frame (is it RTCM 3?)".into(),
                _ => format!(
                    "no MSM4 or MSM7 observation of GPS, Galileo, QZSS or BeiDou among its \
                     RTCM 3 messages ({})",
                    what.join(", ")
                ),
            },
        ));
    }
    log.epochs = epochs
        .into_iter()
        .map(|(key, (line, sats))| {
            let (week, ms) = (key.div_euclid(604_800_000), key.rem_euclid(604_800_000));
            let mut sats: Vec<SatObs> = sats.into_values().collect();
            sats.sort_by_key(|s| (s.sat.sys as u8, s.sat.prn));
            ObsEpoch { time: GpsTime::new(week as i32, ms as f64 / 1000.0), flag: 0, sats, line }
        })
        .collect();
    Ok(log)
}

/// The messages of `other` (message number → frames) as a note: "RTCM 3 messages not
/// read: 1087 ×120 (GLONASS MSM7), 1019 ×4 (ephemeris)"; `None` when there are none.
pub fn unread_text(other: &BTreeMap<u16, usize>) -> Option<String> {
    if other.is_empty() {
        return None;
    }
    let kind = |n: u16| -> String {
        let msm = ["GPS", "GLONASS", "Galileo", "SBAS", "QZSS", "BeiDou", "NavIC"];
        match n {
            1071..=1137 => match msm.get(usize::from((n - 1071) / 10)) {
                Some(sys) => format!("{sys} MSM{}", (n - 1) % 10),
                None => "MSM".into(),
            },
            1001..=1004 => "GPS legacy observations".into(),
            1009..=1012 => "GLONASS legacy observations".into(),
            1019 | 1020 | 1041..=1046 => "ephemeris".into(),
            1007 | 1008 | 1033 => "antenna descriptor".into(),
            1230 => "GLONASS biases".into(),
            _ => "other".into(),
        }
    };
    let parts: Vec<String> =
        other.iter().map(|(n, c)| format!("{n} ×{c} ({})", kind(*n))).collect();
    Some(format!("RTCM 3 messages not read: {}", parts.join(", ")))
}

/// An MSM's instant as GPS time, in the week that puts it nearest `near`.
fn gps_time(msm: &Msm, near: GpsTime) -> GpsTime {
    let mut tow = f64::from(msm.tow_ms) / 1000.0;
    if msm.sys == System::BeiDou {
        tow += BDT_GPST;
    }
    let d = (tow - near.tow + 302_400.0).rem_euclid(604_800.0) - 302_400.0;
    let t = near.add(d);
    // (whole milliseconds again: `add` works in floating seconds)
    GpsTime::new(t.week, (t.tow * 1000.0).round() / 1000.0)
}

/// An MSM's cells into the epoch's satellites: each slot from its best-ranked signal (the
/// ranks of RINEX's reader), a slip flagged where the lock-time indicator went down or
/// stayed at its least (RTKLIB's reading).
fn add(msm: &Msm, sats: &mut HashMap<Sat, SatObs>, locks: &mut HashMap<(Sat, usize), (bool, u16)>) {
    let mut rank: HashMap<(Sat, usize), u8> = HashMap::new();
    for c in &msm.cells {
        let Some(&(_, Some(rough), rough_rate)) = msm.sats.iter().find(|s| s.0 == c.sat) else {
            continue;
        };
        let prn = if msm.sys == System::Qzss { c.sat + 192 } else { c.sat };
        let sat = Sat { sys: msm.sys, prn };
        let Some((slot, r)) = slot_of(msm.sys, b'0' + c.band, c.attr as u8) else { continue };
        if rank.get(&(sat, slot)).is_some_and(|&best| best <= r) {
            continue;
        }
        rank.insert((sat, slot), r);
        let wavelength = LIGHT_MS * 1000.0 / frequency(msm.sys, slot);
        let entry = sats.entry(sat).or_insert_with(|| SatObs { sat, signals: Default::default() });
        let lli = match locks.insert((sat, slot), c.lock) {
            // (lock lost since: a lock time shorter than before, or at its least again)
            Some((kind, before))
                if kind == c.lock.0 && (c.lock.1 < before || c.lock.1 + before == 0) =>
            {
                1
            }
            _ => 0,
        };
        entry.signals[slot] = Signal {
            code: c.code.map(|f| (rough + f) * LIGHT_MS),
            phase: c.phase.map(|f| (rough + f) * LIGHT_MS / wavelength),
            doppler: rough_rate.zip(c.rate).map(|(r, f)| -(r + f) / wavelength),
            cn0: c.cn0,
            lli,
        };
    }
}
