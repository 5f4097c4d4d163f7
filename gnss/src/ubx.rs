//! u-blox UBX logs: RXM-RAWX observations and RXM-SFRBX navigation subframes, read with
//! the `ublox` crate (MIT; 10 crates with its dependencies). GPS subframes 1–3 become
//! ephemerides, and subframe 4 page 18 the broadcast ionosphere, through [`super::lnav`];
//! Galileo I/NAV pages (word types 0–5) through [`super::inav`]; BeiDou D1 subframes 1–3
//! (the MEO and IGSO satellites) and D2 subframe 1 pages 1–10 (the GEO satellites)
//! through [`super::bds`].
//!
//! Chosen by measurement against the alternatives: the `ublox` crate decodes RAWX and
//! SFRBX packets (checksums checked) but not the GPS frames' ephemerides unless built with
//! `gnss-protos` 0.0.2 (MPL-2.0), whose frame encoder is a stub (`GpsQzssFrame::encode`
//! loops until it panics), so the simulator's logs could not be made with it; the LNAV
//! fields are a table here, checked against RTKLIB's `convbin` on the same log.

use super::lnav::{self, Subframe};
use super::obs::{ObsEpoch, SatObs, Signal};
use super::time::{GpsTime, Sat, System};
use super::{bds, inav};
use super::{Ephemerides, Ephemeris, RawError};
use std::collections::BTreeMap;
use std::path::Path;
use ublox::{proto23::PacketRef, Parser, UbxPacket};

/// What a UBX log holds.
#[derive(Clone, Debug, Default)]
pub struct UbxLog {
    /// RXM-RAWX epochs.
    pub epochs: Vec<ObsEpoch>,
    /// GPS, Galileo and BeiDou ephemerides from RXM-SFRBX.
    pub ephemerides: Ephemerides,
    /// The broadcast ionosphere (GPS subframe 4, page 18), when the log has it.
    pub klobuchar: Option<super::atmosphere::Klobuchar>,
    /// Packets with a bad checksum or length, left out.
    pub bad_packets: usize,
    /// Other packets (read past).
    pub other_packets: usize,
}

/// The u-blox GNSS id of a system.
fn system(gnss_id: u8) -> Option<System> {
    Some(match gnss_id {
        0 => System::Gps,
        1 => System::Sbas,
        2 => System::Galileo,
        3 => System::BeiDou,
        5 => System::Qzss,
        6 => System::Glonass,
        7 => System::Irnss,
        _ => return None,
    })
}

/// The slot of a u-blox signal id: GPS/QZSS L1C/A 0 → first, L2 CL/CM 3/4 (QZSS 4/5) →
/// second; Galileo E1 C/B 0/1 → first, E5a I/Q 3/4 → second; BeiDou B1I 0/1 → first.
fn slot(sys: System, sig_id: u8) -> Option<usize> {
    match (sys, sig_id) {
        (System::Gps | System::Qzss | System::Galileo | System::BeiDou, 0) => Some(0),
        (System::Galileo | System::BeiDou, 1) => Some(0),
        (System::Gps, 3 | 4) | (System::Qzss, 4 | 5) | (System::Galileo, 3 | 4) => Some(1),
        _ => None,
    }
}

/// Adds a record unless the same satellite's record of that issue and `toe` is there.
fn push_new(records: &mut Vec<Ephemeris>, e: Ephemeris) {
    if !records.iter().any(|r| r.sat == e.sat && r.iode == e.iode && r.toe == e.toe) {
        records.push(e);
    }
}

/// Reads a UBX log (plain, or `.gz`/`.zst`/`.xz`).
pub fn read_ubx(path: &Path) -> Result<UbxLog, RawError> {
    let err = |m: String| RawError { path: path.to_path_buf(), line: 0, message: m };
    let mut bytes = Vec::new();
    std::io::Read::read_to_end(&mut super::open_input(path)?, &mut bytes)
        .map_err(|e| err(e.to_string()))?;
    let mut d = UbxDecoder::default();
    let mut parser = Parser::<Vec<u8>, ublox::proto23::Proto23>::default();
    let mut it = parser.consume_ubx(&bytes);
    while let Some(p) = it.next() {
        let p = match p {
            Ok(UbxPacket::Proto23(p)) => p,
            // (a protocol-23 parser yields no other)
            Ok(_) => {
                d.log.other_packets += 1;
                continue;
            }
            Err(_) => {
                d.log.bad_packets += 1;
                continue;
            }
        };
        match p {
            PacketRef::RxmRawx(r) => d.rawx(&r),
            PacketRef::RxmSfrbx(f) if f.gnss_id() == 2 => d.galileo(&f),
            PacketRef::RxmSfrbx(f) if f.gnss_id() == 3 => d.beidou(&f),
            PacketRef::RxmSfrbx(f) => d.gps(&f),
            _ => d.log.other_packets += 1,
        }
    }
    d.finish().map_err(err)
}

/// What [`read_ubx`] has decoded so far.
#[derive(Default)]
struct UbxDecoder {
    log: UbxLog,
    /// GPS subframes 1–3 per satellite, and the complete sets with the last RAWX time
    /// before them (which resolves their week)
    frames: BTreeMap<u8, [Option<Subframe>; 3]>,
    complete: Vec<(u8, [Subframe; 3], Option<GpsTime>)>,
    /// Galileo: the last word of each type 0–5 per satellite
    words: BTreeMap<u8, [Option<u128>; 6]>,
    /// BeiDou: the last D1 subframes 1–3 per MEO/IGSO satellite, D2 pages 1–10 per GEO
    d1: BTreeMap<u8, [Option<bds::Subframe>; 3]>,
    d2: BTreeMap<u8, [Option<bds::Subframe>; 10]>,
    records: Vec<Ephemeris>,
    /// The last lock times (a drop is a slip).
    lock: BTreeMap<(Sat, usize), u16>,
    last_time: Option<GpsTime>,
}

impl UbxDecoder {
    /// An RXM-RAWX epoch.
    fn rawx(&mut self, r: &ublox::rxm_rawx::RxmRawxRef<'_>) {
        let time = GpsTime::new(i32::from(r.week()), r.rcv_tow());
        let mut sats: Vec<SatObs> = Vec::new();
        for m in r.measurements() {
            let Some(sys) = system(m.gnss_id()) else { continue };
            let Some(k) = slot(sys, m.reserved2()) else { continue };
            if !sys.keplerian() || m.sv_id() == 0 {
                continue;
            }
            let sat = Sat { sys, prn: m.sv_id() };
            let trk = m.trk_stat().bits();
            let i = match sats.iter().position(|s| s.sat == sat) {
                Some(i) => i,
                None => {
                    sats.push(SatObs { sat, signals: [Signal::default(); 2] });
                    sats.len() - 1
                }
            };
            let s = &mut sats[i].signals[k];
            // (a value that is not finite is no measurement)
            s.code = Some(m.pr_mes()).filter(|v| trk & 1 != 0 && v.is_finite());
            // (a BeiDou GEO's B1I phase comes half a cycle short of the MEO satellites'
            // convention; RTKLIB's reader adds it back, so does this one)
            let half = if sat.beidou_geo() { 0.5 } else { 0.0 };
            s.phase = Some(m.cp_mes() + half).filter(|v| trk & 2 != 0 && v.is_finite());
            s.doppler = Some(f64::from(m.do_mes())).filter(|v| v.is_finite());
            s.cn0 = Some(f64::from(m.cno()));
            // a lock time of 0 (a new arc) or one that dropped: a slip, as RTKLIB reads
            // it; half cycle unresolved: bit 1, as RINEX
            let lt = m.lock_time();
            let slipped =
                self.lock.insert((sat, k), lt).is_some_and(|before| lt < before) || lt == 0;
            s.lli = u8::from(slipped) | if trk & 4 == 0 && trk & 2 != 0 { 2 } else { 0 };
        }
        self.last_time = Some(time);
        self.log.epochs.push(ObsEpoch { time, flag: 0, sats, line: 0 });
    }

    /// A Galileo I/NAV page: a record once type 5 (health, week) closes a set of types
    /// 0–5 under one IODnav.
    fn galileo(&mut self, f: &ublox::rxm_sfrbx::RxmSfrbxRef<'_>) {
        // eight words of page (u-blox receivers send a ninth, reserved)
        let page: Vec<u32> = f.dwrd().collect();
        let Some(Ok(page)) = page.get(..8).map(<[u32; 8]>::try_from) else { return };
        let Some(w) = inav::decode_page(&page) else { return };
        let t = usize::from(inav::word_type(w));
        if t > 5 {
            return;
        }
        let set = self.words.entry(f.sv_id()).or_default();
        set[t] = Some(w);
        if t == 5
            && let [Some(a), Some(b), Some(c), Some(d), Some(e), Some(g)] = *set
            && let Some(r) = inav::decode(&[a, b, c, d, e, g])
        {
            push_new(&mut self.records, r);
        }
    }

    /// A BeiDou subframe: D2 pages of a GEO (a record when page 10 closes the other nine),
    /// else D1 (a record when subframe 3 closes 1 and 2 of the same frame).
    fn beidou(&mut self, f: &ublox::rxm_sfrbx::RxmSfrbxRef<'_>) {
        let prn = f.sv_id();
        let words: Vec<u32> = f.dwrd().map(|w| w & 0x3fff_ffff).collect();
        let Ok(sf) = <bds::Subframe>::try_from(words.as_slice()) else { return };
        if (Sat { sys: System::BeiDou, prn }).beidou_geo() {
            let (Some(1), page @ 1..=10) = (bds::subframe_id(&sf), bds::d2_page(&sf)) else {
                return;
            };
            let set = self.d2.entry(prn).or_default();
            set[usize::from(page) - 1] = Some(sf);
            if page == 10
                && set.iter().all(Option::is_some)
                && let Some(r) = bds::decode_d2(prn, &set.map(Option::unwrap_or_default))
            {
                push_new(&mut self.records, r);
            }
            return;
        }
        let Some(id @ 1..=3) = bds::subframe_id(&sf) else { return };
        let set = self.d1.entry(prn).or_default();
        set[usize::from(id) - 1] = Some(sf);
        if let (3, [Some(a), Some(b), Some(c)]) = (id, *set)
            && let Some(r) = bds::decode(prn, &[a, b, c])
        {
            push_new(&mut self.records, r);
        }
    }

    /// A GPS subframe: L1 C/A's LNAV only (byte 2 is the signal on F9 receivers, 0 on M8,
    /// and L2C's and L5's CNAV messages start with LNAV's preamble); the Klobuchar
    /// coefficients, or subframes 1–3 kept until a RAWX time resolves their week.
    fn gps(&mut self, f: &ublox::rxm_sfrbx::RxmSfrbxRef<'_>) {
        if f.gnss_id() != 0 || f.reserved1() != 0 {
            return;
        }
        let words: Vec<u32> = f.dwrd().collect();
        let Ok(sf) = <[u32; 10]>::try_from(words.as_slice()) else { return };
        if let Some(k) = lnav::decode_ionosphere(&sf) {
            self.log.klobuchar = Some(k);
            return;
        }
        let Some(id @ 1..=3) = lnav::subframe_id(&sf) else { return };
        let set = self.frames.entry(f.sv_id()).or_default();
        set[usize::from(id) - 1] = Some(sf);
        if let [Some(a), Some(b), Some(c)] = *set {
            // decoded once a RAWX time resolves the week (subframes often come first)
            self.complete.push((f.sv_id(), [a, b, c], self.last_time));
        }
    }

    /// The log: the GPS records decoded with their week, the epochs numbered.
    fn finish(mut self) -> Result<UbxLog, String> {
        let mut log = self.log;
        let first_time = log.epochs.first().map(|e| e.time);
        for (prn, sf, near) in self.complete {
            let Some(near) = near.or(first_time) else { continue };
            if let Some(e) = lnav::decode(prn, &sf, &near) {
                push_new(&mut self.records, e);
            }
        }
        if log.epochs.is_empty() && self.records.is_empty() {
            return Err(format!(
                "no RXM-RAWX or RXM-SFRBX packet ({} bad, {} other)",
                log.bad_packets, log.other_packets
            ));
        }
        for (k, e) in log.epochs.iter_mut().enumerate() {
            e.line = k + 1;
        }
        log.ephemerides = Ephemerides::new(self.records);
        Ok(log)
    }
}

/// The moving-base headings of a UBX log: NAV-RELPOSNED version 1 (F9P and later, read
/// with the `ublox` crate's protocol-27 parser): the heading of the baseline from the
/// moving base to this receiver (`relPosHeading`, its `accHeading` as σ), the elevation
/// from the N, E, D components, at the epoch's GPS time of week. Epochs without a valid
/// relative position and heading, or with float ambiguities when `fixed_only`, are left
/// out and counted. Returns the headings and that count.
pub fn read_relposned(
    path: &Path,
    fixed_only: bool,
) -> Result<(Vec<crate::heading::AntennaHeading>, usize), RawError> {
    use ublox::proto27::{PacketRef as P27, Proto27};
    let err = |m: String| RawError { path: path.to_path_buf(), line: 0, message: m };
    let mut bytes = Vec::new();
    std::io::Read::read_to_end(&mut super::open_input(path)?, &mut bytes)
        .map_err(|e| err(e.to_string()))?;
    let mut parser = Parser::<_, Proto27>::default();
    let mut it = parser.consume_ubx(&bytes);
    let (mut out, mut left) = (Vec::new(), 0usize);
    let mut last: Option<f64> = None;
    while let Some(p) = it.next() {
        let Ok(UbxPacket::Proto27(P27::NavRelPosNed(m))) = p else { continue };
        // flags: gnssFixOK 0, relPosValid 2, carrSoln 3–4, relPosHeadingValid 8
        let flags = m.flags_raw();
        let carrier = (flags >> 3) & 0x3;
        let valid = flags & 0x1 != 0 && flags & 0x4 != 0 && flags & 0x100 != 0;
        if !valid || carrier == 0 || carrier == 3 || (fixed_only && carrier != 2) {
            left += 1;
            continue;
        }
        let t = f64::from(m.itow()) * 1e-3;
        if last.is_some_and(|l| t <= l) {
            left += 1;
            continue;
        }
        last = Some(t);
        let cm = |c: f64, hp: f64| (c + hp * 0.1) * 0.01;
        let n = cm(m.rel_pos_n_cm(), m.rel_pos_hp_n_mm());
        let e = cm(m.rel_pos_e_cm(), m.rel_pos_hp_e_mm());
        let d = cm(m.rel_pos_d_cm(), m.rel_pos_hp_d_mm());
        let h = n.hypot(e);
        let acc = m.acc_heading_degrees().to_radians();
        let acc_d = m.acc_d_mm() * 1e-3;
        let l = (h * h + d * d).sqrt();
        out.push(crate::heading::AntennaHeading {
            t,
            heading: crate::heading::wrap(m.rel_pos_heading_degrees().to_radians()),
            heading_std: (acc > 0.0).then_some(acc),
            pitch: (l > 0.0).then(|| ((-d).atan2(h), (acc_d > 0.0).then(|| acc_d / l))),
            length: (l > 0.0).then_some(l),
        });
    }
    Ok((out, left))
}
