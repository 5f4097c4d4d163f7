//! Writes the simulated u-blox logs of `data/ubx-sim/` (see its `make.sh`), seed 2005:
//!
//! - `OUT.ubx`: the 600 s drive's first 300 s, 1 Hz RXM-RAWX (GPS L1 C/A and L2 CL, with a
//!   cycle slip now and then) and the RXM-SFRBX subframes of the shipped navigation file's
//!   records;
//! - with `--galileo`, the drive's first 60 s with GPS and Galileo: GPS as above, and a
//!   Galileo constellation made from the GPS records (each satellite's orbit moved to
//!   Galileo's: √A 5440.6 m^½, 56° inclination, the node and the mean anomaly turned, SISA
//!   3.12 m, two group delays; the records whose toe and toc are whole minutes, as I/NAV
//!   sends them), observed on E1 (a u-blox F9 tracks E1 and E5b; RTKLIB's
//!   reader takes no E5a from RXM-RAWX), its records as I/NAV pages. The orbits are not
//!   real Galileo ones: the log tests the I/NAV path, not the constellation.
//!
//! `cargo run --release --example sim_ubx -- OUT.ubx [--galileo]`

use ins_gnss_core::raw::{read_nav, Ephemerides, Ephemeris, GpsTime, Sat, System};
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

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).ok_or("usage: sim_ubx OUT.ubx [--galileo]")?;
    let galileo = std::env::args().nth(2).as_deref() == Some("--galileo");
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
    } else {
        nav.ephemerides
    };
    let (mut epochs, _) = simulate_raw(&traj, &eph, &kb, &sim, 2005);
    for o in epochs.iter_mut().flat_map(|e| e.sats.iter_mut()) {
        if o.sat.sys == System::Galileo {
            o.signals[1] = Default::default();
        }
    }
    let bytes = write_ubx(&epochs, &eph, Some(&kb), 13);
    std::fs::write(&out, &bytes)?;
    println!("{out}: {} epochs, {} bytes", epochs.len(), bytes.len());
    Ok(())
}
