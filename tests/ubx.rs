//! u-blox logs: the simulated RXM-RAWX/RXM-SFRBX log of `data/ubx-sim/` read directly
//! gives the same observations and ephemerides as RTKLIB's `convbin` conversion of it to
//! RINEX (read by this crate's RINEX readers), and the observations the simulator wrote.

use gnss::ubx::{read_ubx, UbxLog};
use gnss::{read_nav, Ephemeris, GpsTime, ObsReader, System};
use ins_gnss_sim::raw::{simulate_raw, RawSim};
use ins_gnss_sim::{scenarios, Trajectory};
use std::path::{Path, PathBuf};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data").join(name)
}

/// Each record as convbin decoded it from the same log, every field to RINEX's 12 digits
/// (1e-11 relative). convbin resolves GPS's 10-bit week against today's date (2340 for the
/// 2005 logs' 1316: one rollover of 1024 weeks; the seconds of week agree), we against the
/// log's own RXM-RAWX weeks; Galileo's GST week is 12 bits and BeiDou's 13, both written
/// as GPS weeks: the same week.
fn assert_records_match(ours: &[Ephemeris], theirs: &[Ephemeris]) {
    assert_eq!(ours.len(), theirs.len());
    for (a, b) in ours.iter().zip(theirs) {
        assert_eq!(a.sat, b.sat);
        if a.sat.sys == System::Gps {
            assert_eq!((b.toe.week - a.toe.week).rem_euclid(1024), 0, "{}", a.sat);
        } else {
            assert_eq!(a.toe.week, b.toe.week, "{}", a.sat);
        }
        assert_eq!((a.toe.tow, a.toc.tow), (b.toe.tow, b.toc.tow));
        assert_eq!((a.iode, a.iodc, a.health), (b.iode, b.iodc, b.health));
        let close = |x: f64, y: f64| (x - y).abs() <= 1e-11 * x.abs().max(1e-20) + 1e-300;
        let pairs = [
            (a.af[0], b.af[0]),
            (a.af[1], b.af[1]),
            (a.af[2], b.af[2]),
            (a.sqrt_a, b.sqrt_a),
            (a.e, b.e),
            (a.i0, b.i0),
            (a.omega0, b.omega0),
            (a.omega, b.omega),
            (a.m0, b.m0),
            (a.delta_n, b.delta_n),
            (a.omega_dot, b.omega_dot),
            (a.idot, b.idot),
            (a.tgd[0], b.tgd[0]),
            (a.tgd[1], b.tgd[1]),
            (a.accuracy, b.accuracy),
        ];
        for (k, (x, y)) in pairs.iter().enumerate() {
            assert!(close(*x, *y), "{} field {k}: {x} vs {y}", a.sat);
        }
        for (x, y) in a.harmonics.iter().zip(&b.harmonics) {
            assert!(close(*x, *y), "{}: {x} vs {y}", a.sat);
        }
    }
}

#[test]
fn a_ubx_log_reads_as_its_convbin_rinex() {
    let log = read_ubx(&data("ubx-sim/sim.ubx.zst")).unwrap();
    assert_eq!(log.bad_packets, 0);
    let rinex: Vec<_> =
        ObsReader::open(&data("ubx-sim/sim.obs.zst")).unwrap().map(Result::unwrap).collect();
    assert_eq!(log.epochs.len(), 201);
    assert_eq!(rinex.len(), log.epochs.len());
    let (mut values, mut slips) = (0, 0);
    for (u, r) in log.epochs.iter().zip(&rinex) {
        // convbin writes the time to 1e-7 s
        assert!(u.time.diff(&r.time).abs() < 1e-7, "{} vs {}", u.time, r.time);
        assert_eq!(u.sats.len(), r.sats.len(), "{}", u.time);
        for (a, b) in u.sats.iter().zip(&r.sats) {
            assert_eq!(a.sat, b.sat);
            for (x, y) in a.signals.iter().zip(&b.signals) {
                for (p, q, tol) in [
                    (x.code, y.code, 1e-3),
                    (x.phase, y.phase, 1e-3),
                    (x.doppler, y.doppler, 1e-3),
                    (x.cn0, y.cn0, 1e-3),
                ] {
                    let (p, q) = (p.unwrap(), q.unwrap());
                    // RINEX keeps 3 decimals
                    assert!((p - q).abs() <= tol, "{} {}: {p} vs {q}", u.time, a.sat);
                    values += 1;
                }
                assert_eq!(x.lli & 1, y.lli & 1, "{} {}: slip flags", u.time, a.sat);
                slips += usize::from(x.lli & 1);
            }
        }
    }
    assert_eq!(values, 16_080);
    assert!(slips > 0);

    // the ephemerides: every field as convbin decoded it (`assert_records_match`)
    let nav = read_nav(&data("ubx-sim/sim.nav.zst")).unwrap();
    // the ionosphere of subframe 4 page 18 as convbin wrote it (`GPSA`, `GPSB`)
    let (k, kc) = (log.klobuchar.unwrap(), nav.klobuchar.unwrap());
    for (x, y) in k.alpha.iter().chain(&k.beta).zip(kc.alpha.iter().chain(&kc.beta)) {
        // (RINEX writes 4 digits)
        assert!((x - y).abs() <= 1e-3 * y.abs(), "{x} vs {y}");
    }
    let ours = log.ephemerides.records();
    assert_eq!(ours.len(), nav.ephemerides.records().len());
    assert_eq!(ours.len(), 10);
    assert_records_match(ours, nav.ephemerides.records());
}

/// The log's observations are the simulator's, bit for bit (codes and phases are f64 in
/// RXM-RAWX; the Doppler f32, C/N0 whole dB-Hz), and its ephemerides the navigation file's
/// records at the LNAV message's resolution.
#[test]
fn a_ubx_log_holds_what_the_simulator_wrote() {
    let nav = read_nav(&data("rinex-rtklib/07590920.05n.zst")).unwrap();
    let (start, segs) = scenarios::drive_600s();
    let traj = Trajectory::new(start, &segs[..10]).unwrap();
    let sim = RawSim {
        slip_probability: 0.002,
        ..RawSim::spp_budget(GpsTime::from_calendar(2005, 4, 2, 3, 0, 0.0))
    };
    let (epochs, _) = simulate_raw(&traj, &nav.ephemerides, &nav.klobuchar.unwrap(), &sim, 2005);
    let log = read_ubx(&data("ubx-sim/sim.ubx.zst")).unwrap();
    assert_eq!(log.epochs.len(), epochs.len());
    for (u, s) in log.epochs.iter().zip(&epochs) {
        assert_eq!(u.time, s.time);
        for (a, b) in u.sats.iter().zip(&s.sats) {
            assert_eq!(a.sat, b.sat);
            for (x, y) in a.signals.iter().zip(&b.signals) {
                assert_eq!(x.code, y.code);
                assert_eq!(x.phase, y.phase);
                assert!((x.doppler.unwrap() - y.doppler.unwrap()).abs() < 1e-3);
                assert!((x.cn0.unwrap() - y.cn0.unwrap()).abs() <= 0.5);
                // the simulator flags the slips; the log also each arc's first epoch (lock 0)
                if y.lli & 1 != 0 {
                    assert_eq!(x.lli & 1, 1);
                }
            }
        }
    }
    assert_eq!(log.ephemerides.records().len(), 10);
    // the ionosphere at the message's resolution (α₀ 2⁻³⁰ s … β₃ 2¹⁶ s)
    let (k, kn) = (log.klobuchar.unwrap(), nav.klobuchar.unwrap());
    assert!((k.alpha[0] - kn.alpha[0]).abs() <= 2f64.powi(-31));
    assert!((k.beta[3] - kn.beta[3]).abs() <= 2f64.powi(15));
    for e in log.ephemerides.records() {
        let r = nav
            .ephemerides
            .records()
            .iter()
            .find(|r| r.sat == e.sat && r.iode == e.iode && r.toe == e.toe)
            .unwrap();
        assert_eq!((e.toc, e.iodc, e.health), (r.toc, r.iodc, r.health));
        // within half a unit of the message's last bit (the record came from such a message)
        assert!((e.sqrt_a - r.sqrt_a).abs() <= 2f64.powi(-20));
        assert!((e.e - r.e).abs() <= 2f64.powi(-34));
        assert!((e.af[0] - r.af[0]).abs() <= 2f64.powi(-32));
        assert!((e.m0 - r.m0).abs() <= 2f64.powi(-32) * core::f64::consts::PI);
        // the same satellite position to a millimetre an hour from toe
        let t = e.toe.add(3600.0);
        assert!((e.state(&t).pos - r.state(&t).pos).norm() < 1e-3);
    }
}

/// A log with Galileo (`data/ubx-sim/gal.ubx.zst`, see `examples/sim_ubx.rs`): its I/NAV
/// pages give the records RTKLIB's `convbin` decodes from the same log, field by field, the
/// GPS ones too, and its E1 observations convbin's; the records sit within half a unit of
/// the message's last bit of the records the simulator wrote.
#[test]
fn a_galileo_log_reads_as_its_convbin_rinex() {
    let log = read_ubx(&data("ubx-sim/gal.ubx.zst")).unwrap();
    assert_eq!(log.bad_packets, 0);
    let nav = read_nav(&data("ubx-sim/gal.nav.zst")).unwrap();
    let ours = log.ephemerides.records();
    let theirs = nav.ephemerides.records();
    let gal = |r: &[Ephemeris]| r.iter().filter(|e| e.sat.sys == System::Galileo).count();
    assert_eq!(gal(ours), 3);
    assert_eq!(gal(theirs), 3);
    assert_records_match(ours, theirs);
    // the Galileo records against the simulator's (made from the GPS file's, as the example
    // makes them): within the I/NAV message's resolution. The node, the inclination and the
    // mean anomaly, moved off the GPS file's grid, are rounded to 2⁻³¹ semicircles (7.3e-10
    // rad: 2.2 cm at Galileo's 29,600 km), so the orbits agree to a few centimetres
    let gps = read_nav(&data("rinex-rtklib/07590920.05n.zst")).unwrap();
    for e in ours.iter().filter(|e| e.sat.sys == System::Galileo) {
        let g = gps
            .ephemerides
            .records()
            .iter()
            .find(|r| r.sat.prn == e.sat.prn && r.iode == e.iode && r.toe == e.toe)
            .expect("the GPS record the Galileo one was made from");
        assert!((e.sqrt_a - 5440.588).abs() <= 2f64.powi(-20));
        assert!((e.af[0] - g.af[0]).abs() <= 2f64.powi(-35));
        assert!((e.tgd[1] - 1.1 * g.tgd[0]).abs() <= 2f64.powi(-33));
        assert_eq!(e.accuracy, 3.12);
        let sim = Ephemeris {
            sat: e.sat,
            sqrt_a: 5440.588,
            i0: 56f64.to_radians(),
            omega0: g.omega0 + 1.0,
            m0: g.m0 + 0.5,
            ..g.clone()
        };
        let t = e.toe.add(1800.0);
        let d = (e.state(&t).pos - sim.state(&t).pos).norm();
        assert!(d < 0.05, "{}: {d} m", e.sat);
    }
    // the observations, Galileo's E1 included, as convbin wrote them
    assert_eq!(log.epochs.len(), 71);
    let galileo_values = assert_observations_match(&log, "ubx-sim/gal.obs.zst", System::Galileo);
    assert!(galileo_values > 500, "{galileo_values}");
}

/// A log's epochs against convbin's RINEX of it: the same times (to RINEX's 1e-7 s), the
/// same satellites, and each code, phase and Doppler present in both or neither and equal to
/// RINEX's 3 decimals. Returns how many values of `sys` were compared.
fn assert_observations_match(log: &UbxLog, rinex: &str, sys: System) -> usize {
    let rinex: Vec<_> = ObsReader::open(&data(rinex)).unwrap().map(Result::unwrap).collect();
    assert_eq!(rinex.len(), log.epochs.len());
    let mut values = 0;
    for (u, r) in log.epochs.iter().zip(&rinex) {
        assert!(u.time.diff(&r.time).abs() < 1e-6, "{} vs {}", u.time, r.time);
        assert_eq!(u.sats.len(), r.sats.len(), "{}", u.time);
        for (a, b) in u.sats.iter().zip(&r.sats) {
            assert_eq!(a.sat, b.sat);
            for (x, y) in a.signals.iter().zip(&b.signals) {
                for (p, q) in [(x.code, y.code), (x.phase, y.phase), (x.doppler, y.doppler)] {
                    assert_eq!(p.is_some(), q.is_some(), "{} {}", u.time, a.sat);
                    if let (Some(p), Some(q)) = (p, q) {
                        assert!((p - q).abs() <= 1e-3, "{} {}: {p} vs {q}", u.time, a.sat);
                        values += usize::from(a.sat.sys == sys);
                    }
                }
            }
        }
    }
    values
}

/// A log with BeiDou (`data/ubx-sim/bds.ubx.zst`, see `examples/sim_ubx.rs`): its D1
/// subframes (MEO) and D2 pages (GEO) give the records RTKLIB's `convbin` decodes from the
/// same log, field by field, the GPS ones too, and its B1I observations convbin's; the MEO
/// records sit within half a unit of the message's last bit of the records the simulator
/// wrote, the GEO ones where the simulator parked them.
#[test]
fn a_beidou_log_reads_as_its_convbin_rinex() {
    let log = read_ubx(&data("ubx-sim/bds.ubx.zst")).unwrap();
    assert_eq!(log.bad_packets, 0);
    let nav = read_nav(&data("ubx-sim/bds.nav.zst")).unwrap();
    let ours = log.ephemerides.records();
    let theirs = nav.ephemerides.records();
    let bds = |r: &[Ephemeris]| r.iter().filter(|e| e.sat.sys == System::BeiDou).count();
    // the 3 MEO satellites' D1 records and the 3 GEO satellites' D2 ones (C01's record
    // changes inside the log: 4)
    assert_eq!(bds(ours), 7);
    assert_eq!(bds(theirs), 7);
    assert_records_match(ours, theirs);
    // against the simulator's records (made from the GPS file's, 1024 weeks later, as the
    // example makes them): the orbits agree to the message's resolution (2⁻³¹ semicircles
    // of the turned node and mean anomaly: 2 cm at BeiDou's 27,900 km)
    let gps = read_nav(&data("rinex-rtklib/07590920.05n.zst")).unwrap();
    for e in ours.iter().filter(|e| e.sat.beidou_geo()) {
        // parked over BeiDou's GEO slots: within 0.1° of the slot's longitude and 0.5° of
        // the equator, and a few kilometres from where it was half an hour earlier (its
        // eccentricity, 0.0003, swings it by ±13 km a day; a MEO moves 7,000 km)
        let slot = [140.0, 80.0, 110.5][usize::from(e.sat.prn) - 1];
        let (p0, p1) = (e.state(&e.toe).pos, e.state(&e.toe.add(1800.0)).pos);
        let (lat, lon, _) = ins_gnss_core::earth::ecef_to_geodetic(&p0);
        assert!((lon.to_degrees() - slot).abs() < 0.1, "{}: {}", e.sat, lon.to_degrees());
        assert!(lat.to_degrees().abs() < 0.5, "{}: {}", e.sat, lat.to_degrees());
        assert!((p1 - p0).norm() < 10_000.0, "{}: {} m", e.sat, (p1 - p0).norm());
    }
    for e in ours.iter().filter(|e| e.sat.sys == System::BeiDou && !e.sat.beidou_geo()) {
        let g = gps
            .ephemerides
            .records()
            .iter()
            .find(|r| r.sat.prn + 3 == e.sat.prn && r.toe_sow == e.toe_sow)
            .expect("the GPS record the BeiDou one was made from");
        // toe: the GPS record's seconds of week read as BDT (14 s later in GPS time)
        assert_eq!(e.toe, GpsTime::new(g.toe.week + 1024, g.toe_sow + 14.0));
        assert_eq!(e.toc, e.toe);
        assert_eq!((e.iode, e.accuracy), (g.iode % 32, 2.0));
        assert!((e.sqrt_a - 5282.625).abs() <= 2f64.powi(-20));
        assert!((e.af[0] - g.af[0]).abs() <= 2f64.powi(-34));
        assert!((e.tgd[0] - g.tgd[0]).abs() <= 0.5e-10);
        assert!((e.tgd[1] + 0.5 * g.tgd[0]).abs() <= 0.5e-10);
        let sim = Ephemeris {
            sat: e.sat,
            toe: e.toe,
            toc: e.toc,
            sqrt_a: 5282.625,
            i0: 55f64.to_radians(),
            omega0: g.omega0 + 2.0,
            m0: g.m0 + 1.0,
            ..g.clone()
        };
        let t = e.toe.add(1800.0);
        let d = (e.state(&t).pos - sim.state(&t).pos).norm();
        assert!(d < 0.05, "{}: {d} m", e.sat);
    }
    // the observations, BeiDou's B1I included, as convbin wrote them
    assert_eq!(log.epochs.len(), 201);
    let beidou_values = assert_observations_match(&log, "ubx-sim/bds.obs.zst", System::BeiDou);
    assert!(beidou_values > 500, "{beidou_values}");
}

/// A measurement that is not finite in a log (a corrupt receiver record) is read as
/// missing, not as a number: the epoch's other satellites still give a single point.
#[test]
fn a_non_finite_measurement_is_read_as_missing() {
    let nav = read_nav(&data("rinex-rtklib/07590920.05n.zst")).unwrap();
    let (start, segs) = scenarios::drive_600s();
    let traj = Trajectory::new(start, &segs[..1]).unwrap();
    let sim = RawSim::spp_budget(GpsTime::from_calendar(2005, 4, 2, 3, 0, 0.0));
    let kb = nav.klobuchar.unwrap();
    let (mut epochs, _) = simulate_raw(&traj, &nav.ephemerides, &kb, &sim, 1);
    epochs[3].sats[0].signals[0].code = Some(f64::NAN);
    epochs[3].sats[1].signals[0].phase = Some(f64::INFINITY);
    let dir = std::env::temp_dir().join(format!("ubx-nan-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join("nan.ubx");
    std::fs::write(&p, ins_gnss_sim::raw::write_ubx(&epochs, &nav.ephemerides, Some(&kb), 13))
        .unwrap();
    let log = read_ubx(&p).unwrap();
    let e = &log.epochs[3];
    assert_eq!(e.sats[0].signals[0].code, None);
    assert_eq!(e.sats[1].signals[0].phase, None);
    assert!(e.sats[1].signals[0].code.is_some());
    let opt = gnss::SppOptions::default();
    assert!(gnss::single_point(e, &log.ephemerides, log.klobuchar.as_ref(), &opt, None).is_ok());
    let _ = std::fs::remove_dir_all(&dir);
}

/// The packets of a UBX log: `(start, length)` of each whole frame (sync, class, id,
/// length, payload, checksum).
fn frames(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut at = 0;
    while at + 8 <= bytes.len() {
        assert_eq!(&bytes[at..at + 2], &[0xb5, 0x62]);
        let len = usize::from(u16::from_le_bytes([bytes[at + 4], bytes[at + 5]]));
        out.push((at, len + 8));
        at += len + 8;
    }
    out
}

/// An F9 receiver's GPS L2C CNAV messages (RXM-SFRBX with signal 3, whose preamble is
/// LNAV's) beside the L1 C/A subframes: every L1 subframe of the log sent again as signal 3
/// with its data words garbled and its subframe ID kept. The records stay the clean log's.
#[test]
fn cnav_messages_do_not_reach_the_lnav_decoder() {
    let bytes = log_bytes("ubx-sim/sim.ubx.zst");
    let mut out = Vec::with_capacity(2 * bytes.len());
    for (at, len) in frames(&bytes) {
        let packet = &bytes[at..at + len];
        out.extend_from_slice(packet);
        if packet[2..4] == [0x02, 0x13] && packet[6] == 0 {
            let mut cnav = packet.to_vec();
            cnav[8] = 3;
            // words 3–10 garbled (word 2 keeps the subframe ID)
            for (k, w) in (2..10).enumerate() {
                let at = 14 + 4 * w;
                let v = u32::from_le_bytes(cnav[at..at + 4].try_into().unwrap());
                cnav[at..at + 4].copy_from_slice(&(v ^ (0x2aaa_aa40 >> k)).to_le_bytes());
            }
            set_checksum(&mut cnav);
            out.extend_from_slice(&cnav);
        }
    }
    let with_cnav = read_bytes(&out, "cnav");
    let clean = read_ubx(&data("ubx-sim/sim.ubx.zst")).unwrap();
    assert_eq!(with_cnav.bad_packets, 0);
    assert_eq!(with_cnav.ephemerides.records(), clean.ephemerides.records());
}

/// A shipped log's bytes, decompressed.
fn log_bytes(name: &str) -> Vec<u8> {
    let mut bytes = Vec::new();
    let mut input = ins_gnss_io::formats::open(&data(name)).unwrap();
    std::io::Read::read_to_end(&mut input, &mut bytes).unwrap();
    bytes
}

/// The Fletcher checksum of a whole packet (sync to checksum) set from its class to its
/// payload's end.
fn set_checksum(packet: &mut [u8]) {
    let len = packet.len();
    let (mut a, mut b) = (0u8, 0u8);
    for byte in &packet[2..len - 2] {
        a = a.wrapping_add(*byte);
        b = b.wrapping_add(a);
    }
    packet[len - 2] = a;
    packet[len - 1] = b;
}

/// `bytes` read as a UBX log from a scratch file (removed after).
fn read_bytes(bytes: &[u8], name: &str) -> UbxLog {
    let path = std::env::temp_dir().join(format!("{name}-{}.ubx", std::process::id()));
    std::fs::write(&path, bytes).unwrap();
    let log = read_ubx(&path);
    let _ = std::fs::remove_file(&path);
    log.unwrap()
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(64))]

    /// Navigation words of any bits, in packets whose checksums are right (what a receiver
    /// with a decoding fault would send): the three logs still read, never a panic, and
    /// their observations are untouched.
    #[test]
    fn garbled_navigation_words_never_panic(
        log in 0usize..3,
        picks in proptest::collection::vec((0usize..4000, 0usize..40, proptest::prelude::any::<u32>()), 1..40),
    ) {
        let name = ["ubx-sim/sim.ubx.zst", "ubx-sim/gal.ubx.zst", "ubx-sim/bds.ubx.zst"][log];
        let mut bytes = log_bytes(name);
        let sfrbx: Vec<(usize, usize)> = frames(&bytes)
            .into_iter()
            .filter(|&(at, _)| bytes[at + 2] == 0x02 && bytes[at + 3] == 0x13)
            .collect();
        for (k, word, value) in picks {
            let (at, len) = sfrbx[k % sfrbx.len()];
            let words = (len - 16) / 4;
            // (the first word kept: the preamble and subframe ID stay, so the garbled
            // fields reach the decoders)
            let w = at + 14 + 4 * (1 + word % (words - 1));
            bytes[w..w + 4].copy_from_slice(&value.to_le_bytes());
            set_checksum(&mut bytes[at..at + len]);
        }
        let garbled = read_bytes(&bytes, &format!("garbled-{log}"));
        let clean = read_ubx(&data(name)).unwrap();
        proptest::prop_assert_eq!(garbled.bad_packets, 0);
        proptest::prop_assert_eq!(garbled.epochs.len(), clean.epochs.len());
        for e in garbled.ephemerides.records() {
            // whatever a garbled record says, its state is finite or refused, never a panic
            let _ = e.state(&e.toe);
        }
    }
}
