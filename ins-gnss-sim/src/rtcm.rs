//! A receiver's observations written as RTCM 3, as a base station streams them: GPS MSM7
//! (1077) per epoch and the station's position (1005) before the first. Encoded by the
//! `rtcm-rs` crate; this module splits each observation into MSM's rough range (per
//! satellite) and fine ranges (per signal), keeps each phase within MSM's range of its code
//! by a whole number of cycles fixed per arc (as receivers and RTKLIB's `str2str` do: the
//! phase's integer is arbitrary), and counts each signal's lock time from the start of its
//! arc (a flagged slip starts a new one).

use gnss::obs::frequency;
use gnss::{ObsEpoch, Sat, System};
use nalgebra::Vector3;
use rtcm_rs::msg::{Msg1005T, Msg1077Data, Msg1077Sig, Msg1077T, Msm57Sat};
use rtcm_rs::prelude::*;
use std::collections::HashMap;

/// Metres light travels in a millisecond.
const LIGHT_MS: f64 = 299_792.458;

/// MSM7's extended lock-time indicator (DF407) of a lock time in ms (monotonic; RTCM
/// 10403's table: exact below 64 ms, then in steps doubling with each octave).
fn lock_indicator(ms: f64) -> u16 {
    let t = ms.max(0.0) as u64;
    if t < 64 {
        return t as u16;
    }
    let n = (63 - t.leading_zeros() as u64).saturating_sub(5).min(21);
    ((t >> n) + 32 * n).min(704) as u16
}

/// The GPS satellites of `epochs` (L1 C/A and L2 P(Y), code, phase, Doppler, C/N0) as RTCM 3
/// frames from station `station` at ECEF `position` (m). Epochs are stamped to the
/// millisecond (MSM's resolution): a receiver's stamps are whole milliseconds of its own
/// clock.
pub fn write_rtcm(epochs: &[ObsEpoch], position: &Vector3<f64>, station: u16) -> Vec<u8> {
    let mut out = Vec::new();
    let mut builder = MessageBuilder::new();
    let station_msg = Msg1005T {
        reference_station_id: station,
        gps_flag: 1,
        antenna_ref_point_ecef_x_m: position.x,
        antenna_ref_point_ecef_y_m: position.y,
        antenna_ref_point_ecef_z_m: position.z,
        ..Default::default()
    };
    if let Ok(frame) = builder.build_message(&Message::Msg1005(station_msg)) {
        out.extend_from_slice(frame);
    }
    // each signal's arc: its start (s) and whole cycles taken off its phase
    let mut arcs: HashMap<(Sat, usize), (f64, f64)> = HashMap::new();
    for e in epochs {
        let t = f64::from(e.time.week) * 604_800.0 + e.time.tow;
        let mut data = Msg1077Data::default();
        for s in e.sats.iter().filter(|s| s.sat.sys == System::Gps).take(64) {
            let Some(rough) = s.signals[0].code.or(s.signals[1].code).map(|c| c / LIGHT_MS) else {
                continue;
            };
            let whole = rough.floor();
            let rough = whole + ((rough - whole) * 1024.0).round() / 1024.0;
            let doppler =
                s.signals[0].doppler.map(|d| -d * LIGHT_MS * 1000.0 / frequency(System::Gps, 0));
            let rough_rate = doppler.map(|r| r.round());
            data.satellite_data.push(Msm57Sat {
                satellite_id: s.sat.prn,
                gnss_satellite_rough_range_integer_ms: Some(rough.floor() as u8),
                reserved_8_4: 0,
                gnss_satellite_rough_range_mod1ms_ms: rough - rough.floor(),
                gnss_satellite_rough_phaserange_rates_m_s: rough_rate.map(|r| r as i16),
            });
            for (slot, (band, attr)) in [(1, 'C'), (2, 'W')].into_iter().enumerate() {
                let g = &s.signals[slot];
                let Some(code) = g.code else { continue };
                let wavelength = LIGHT_MS * 1000.0 / frequency(System::Gps, slot);
                let key = (s.sat, slot);
                let phase = g.phase.map(|p| {
                    let fresh = g.lli & 1 != 0
                        || arcs
                            .get(&key)
                            .is_none_or(|a| ((p - a.1) * wavelength - code).abs() > 1000.0);
                    if fresh {
                        arcs.insert(key, (t, (p - code / wavelength).round()));
                    }
                    (p - arcs[&key].1) * wavelength / LIGHT_MS - rough
                });
                let lock = arcs.get(&key).map_or(0.0, |a| (t - a.0) * 1000.0);
                data.signal_data.push(Msg1077Sig {
                    satellite_id: s.sat.prn,
                    signal_id: rtcm_rs::msg::GpsSigId::new(band, attr),
                    gnss_signal_fine_pseudorange_ext_ms: Some(code / LIGHT_MS - rough),
                    gnss_signal_fine_phaserange_ext_ms: phase,
                    gnss_phaserange_lock_time_ext_ind: lock_indicator(lock),
                    half_cycle_ambiguity_ind: 0,
                    gnss_signal_cnr_ext_dbhz: g.cn0,
                    gnss_signal_fine_phaserange_rate_m_s: g
                        .doppler
                        .zip(rough_rate)
                        .map(|(d, r)| -d * wavelength - r),
                });
            }
        }
        let msg = Msg1077T {
            reference_station_id: station,
            gps_epoch_time_ms: (e.time.tow * 1000.0).round() as u32,
            data_segment: data,
            ..Default::default()
        };
        if let Ok(frame) = builder.build_message(&Message::Msg1077(msg)) {
            out.extend_from_slice(frame);
        }
    }
    out
}

/// An RTCM 3 frame of message `number` whose `len`-byte payload is zeros after the
/// number, with its CRC-24Q (RTCM 10403's parity; rtcm-rs encodes only the messages
/// compiled in): a message of any number, for a file that holds messages a reader does
/// not read.
pub fn blank_frame(number: u16, len: usize) -> Vec<u8> {
    let len = len.clamp(2, 1023);
    let mut payload = vec![0u8; len];
    payload[0] = (number >> 4) as u8;
    payload[1] = ((number & 0xF) << 4) as u8;
    let mut f = vec![0xD3, (len >> 8) as u8 & 0x03, len as u8];
    f.extend(payload);
    // (CRC-24Q is the CRC-24 that `crc-any` names after LTE's CRC24A, as rtcm-rs uses it)
    let mut crc = crc_any::CRC::crc24lte_a();
    crc.digest(&f);
    let crc = crc.get_crc();
    f.extend([(crc >> 16) as u8, (crc >> 8) as u8, crc as u8]);
    f
}

#[cfg(test)]
mod tests {
    use super::lock_indicator;

    #[test]
    fn the_lock_indicator_follows_rtcm_s_table() {
        // DF407: 0–63 ms exact; 64–127 → (t + 64) / 2; 128–255 → (t + 256) / 4; …
        assert_eq!(lock_indicator(0.0), 0);
        assert_eq!(lock_indicator(63.0), 63);
        assert_eq!(lock_indicator(64.0), 64);
        assert_eq!(lock_indicator(127.0), 95);
        assert_eq!(lock_indicator(128.0), 96);
        assert_eq!(lock_indicator(300.0), (300 + 768) / 8);
        let mut last = 0;
        for ms in (0..100_000_000).step_by(997) {
            let i = lock_indicator(ms as f64);
            assert!(i >= last && i <= 704);
            last = i;
        }
    }
}
