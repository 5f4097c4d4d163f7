//! Writes the simulated u-blox logs of `data/ubx-sim/` (see its `make.sh`), seed 2005 unless
//! given:
//!
//! - `OUT.ubx`: the 600 s drive's first 200 s, 1 Hz RXM-RAWX (GPS L1 C/A and L2 CL, with a
//!   cycle slip now and then) and the RXM-SFRBX subframes of the shipped navigation file's
//!   records;
//! - with `--galileo`, the drive's first 60 s with GPS and Galileo: GPS as above, and a
//!   Galileo constellation made from the GPS records (each satellite's orbit moved to
//!   Galileo's: √A 5440.6 m^½, 56° inclination, the node and the mean anomaly turned, SISA
//!   3.12 m, two group delays; the records whose toe and toc are whole minutes, as I/NAV
//!   sends them), observed on E1 (a u-blox F9 tracks E1 and E5b; RTKLIB's
//!   reader takes no E5a from RXM-RAWX), its records as I/NAV pages. The orbits are not
//!   real Galileo ones: the log tests the I/NAV path, not the constellation;
//! - with `--beidou`, the drive's first 200 s with GPS and BeiDou: GPS as above, and a
//!   BeiDou MEO constellation made likewise (C06–C35 from G03–G32: √A 5282.6 m^½, 55°
//!   inclination, the node and the mean anomaly turned, URA 2 m, two group delays; toe and
//!   toc the GPS record's toe read as BDT, so a multiple of 8 s as D1 sends it), observed on
//!   B1I, its records as D1 subframes; and three GEO satellites C01–C03 made from G01–G03's
//!   records (√A 6493.4 m^½, 5° inclination in the GEO message's frame, which its −5° turn
//!   makes equatorial, the node placed so; parked at 140°, 80° and 110.5° E, BeiDou's own GEO slots), their
//!   records as D2 pages. The log is dated 1024 weeks after the navigation
//!   file (2024-11-16): BeiDou time starts in 2006, and GPS's 10-bit week, the only GPS
//!   field that sees the date, reads the same.
//!
//! `cargo run --release --example sim_ubx -- OUT.ubx [--galileo | --beidou [--no-geo]] [--seed N]`
//! (`--seed`: the receiver's errors, default 2005, the shipped logs' seed; `--no-geo`: the
//! BeiDou log without its GEO satellites' observations, the others' errors unchanged).

use gnss::time::BDT_MINUS_GPST;
use gnss::{read_nav, Ephemerides, Ephemeris, GpsTime, Sat, System};
use ins_gnss_sim::raw::{simulate_raw, write_ubx, RawSim};
use ins_gnss_sim::{scenarios, Trajectory};
use std::path::Path;

/// A Galileo record made from a GPS one (see the module's documentation).
fn galileo_from(g: &Ephemeris) -> Ephemeris {
    Ephemeris {
        sat: Sat { sys: System::Galileo, prn: g.sat.prn },
        sqrt_a: 5440.588,
        i0: 56f64.to_radians(),
        omega0: g.omega0 + 1.0,
        m0: g.m0 + 0.5,
        accuracy: 3.12,
        tgd: [g.tgd[0], 1.1 * g.tgd[0]],
        health: 0,
        ..g.clone()
    }
}

/// A BeiDou record made from a GPS one (see the module's documentation).
fn beidou_from(g: &Ephemeris) -> Ephemeris {
    let toe = g.toe.add(-BDT_MINUS_GPST);
    Ephemeris {
        sat: Sat { sys: System::BeiDou, prn: g.sat.prn + 3 },
        toe,
        toc: toe,
        sqrt_a: 5282.625,
        i0: 55f64.to_radians(),
        omega0: g.omega0 + 2.0,
        m0: g.m0 + 1.0,
        iode: g.iode % 32,
        iodc: g.iode % 32,
        accuracy: 2.0,
        tgd: [g.tgd[0], -0.5 * g.tgd[0]],
        health: 0,
        ..g.clone()
    }
}

/// A BeiDou GEO record made from a GPS one, parked over `longitude` (degrees east): the
/// GEO message's orbit, inclined 5° in a frame the model turns by −5° about its x axis,
/// with its ascending node on that axis's negative side at toe, is equatorial (on the
/// positive side the two add up to 10°), and its argument of latitude at toe is the
/// longitude less 180°.
fn beidou_geo_from(g: &Ephemeris, prn: u8, longitude: f64) -> Ephemeris {
    /// BeiDou's Earth rotation rate (CGCS2000), rad/s.
    const OMEGA_E: f64 = 7.292_115e-5;
    let wrap = |a: f64| {
        (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI
    };
    Ephemeris {
        sqrt_a: 6493.4,
        e: 0.0003,
        i0: 5f64.to_radians(),
        omega0: wrap(OMEGA_E * g.toe_sow + std::f64::consts::PI),
        omega: 0.0,
        m0: wrap(longitude.to_radians() - std::f64::consts::PI),
        delta_n: 0.0,
        omega_dot: 0.0,
        idot: 0.0,
        harmonics: [0.0; 6],
        ..Ephemeris { sat: Sat { sys: System::BeiDou, prn }, ..beidou_from(g) }
    }
}

/// The BeiDou log's date shift: 1024 weeks.
const WEEKS_AHEAD: i32 = 1024;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let usage = "usage: sim_ubx OUT.ubx [--galileo | --beidou [--no-geo]] [--seed N]";
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = args.first().ok_or(usage)?.clone();
    let (mut galileo, mut beidou, mut seed, mut no_geo) = (false, false, 2005u64, false);
    let mut rest = args[1..].iter();
    while let Some(a) = rest.next() {
        match a.as_str() {
            "--galileo" => galileo = true,
            "--beidou" => beidou = true,
            "--no-geo" => no_geo = true,
            "--seed" => seed = rest.next().and_then(|v| v.parse().ok()).ok_or(usage)?,
            _ => return Err(usage.into()),
        }
    }
    if galileo && beidou || no_geo && !beidou {
        return Err(usage.into());
    }
    let nav = read_nav(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("data/rinex-rtklib/07590920.05n.zst"),
    )?;
    let (start, segs) = scenarios::drive_600s();
    let traj = Trajectory::new(start, if galileo { &segs[..3] } else { &segs[..10] })?;
    let sim = RawSim {
        slip_probability: 0.002,
        ..RawSim::spp_budget(GpsTime::from_calendar(2005, 4, 2, 3, 0, 0.0))
    };
    let kb = nav.klobuchar.ok_or("no ionosphere")?;
    let eph = if galileo {
        let mut records = nav.ephemerides.records().to_vec();
        // (I/NAV gives toe and toc in minutes: the records whose times are whole minutes)
        let whole = |e: &&Ephemeris| e.toe_sow % 60.0 == 0.0 && e.toc.tow % 60.0 == 0.0;
        records.extend(nav.ephemerides.records().iter().filter(whole).map(galileo_from));
        Ephemerides::new(records)
    } else if beidou {
        let mut records = nav.ephemerides.records().to_vec();
        // (both messages send toc = toe, in units of 8 s)
        let times = |e: &Ephemeris| e.toc == e.toe && e.toe_sow % 8.0 == 0.0;
        let d1 = |e: &&Ephemeris| e.sat.prn >= 3 && times(e);
        records.extend(nav.ephemerides.records().iter().filter(d1).map(beidou_from));
        let geo = |e: &&Ephemeris| e.sat.prn <= 3 && times(e);
        records.extend(nav.ephemerides.records().iter().filter(geo).map(|g| {
            let longitude = [140.0, 80.0, 110.5][usize::from(g.sat.prn) - 1];
            beidou_geo_from(g, g.sat.prn, longitude)
        }));
        Ephemerides::new(records)
    } else {
        nav.ephemerides
    };
    let (mut epochs, _) = simulate_raw(&traj, &eph, &kb, &sim, seed);
    if no_geo {
        // the GEO satellites' observations left out after the simulation: every other
        // satellite's errors are those of the log with them
        for e in &mut epochs {
            e.sats.retain(|o| !o.sat.beidou_geo());
        }
    }
    for o in epochs.iter_mut().flat_map(|e| e.sats.iter_mut()) {
        if matches!(o.sat.sys, System::Galileo | System::BeiDou) {
            o.signals[1] = Default::default();
        }
    }
    let eph = if beidou {
        // the same sky 1024 weeks later (see the module's documentation)
        for e in &mut epochs {
            e.time.week += WEEKS_AHEAD;
        }
        let mut records = eph.records().to_vec();
        for r in &mut records {
            r.toe.week += WEEKS_AHEAD;
            r.toc.week += WEEKS_AHEAD;
        }
        Ephemerides::new(records)
    } else {
        eph
    };
    let bytes = write_ubx(&epochs, &eph, Some(&kb), 13);
    std::fs::write(&out, &bytes)?;
    println!("{out}: {} epochs, {} bytes", epochs.len(), bytes.len());
    Ok(())
}
