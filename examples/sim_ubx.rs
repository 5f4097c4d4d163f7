//! Writes the simulated u-blox log of `data/ubx-sim/` (see its `make.sh`): the 600 s drive's
//! first 300 s, 1 Hz RXM-RAWX (GPS L1 C/A and L2 CL, with a cycle slip now and then) and
//! the RXM-SFRBX subframes of the shipped navigation file's records, seed 2005.
//!
//! `cargo run --release --example sim_ubx -- OUT.ubx`

use ins_gnss_core::raw::{read_nav, GpsTime};
use ins_gnss_sim::raw::{simulate_raw, write_ubx, RawSim};
use ins_gnss_sim::{scenarios, Trajectory};
use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).ok_or("usage: sim_ubx OUT.ubx")?;
    let nav = read_nav(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("data/rinex-rtklib/07590920.05n.zst"),
    )?;
    let (start, segs) = scenarios::drive_600s();
    let traj = Trajectory::new(start, &segs[..10])?;
    let sim = RawSim {
        slip_probability: 0.002,
        ..RawSim::spp_budget(GpsTime::from_calendar(2005, 4, 2, 3, 0, 0.0))
    };
    let kb = nav.klobuchar.ok_or("no ionosphere")?;
    let (epochs, _) = simulate_raw(&traj, &nav.ephemerides, &kb, &sim, 2005);
    let bytes = write_ubx(&epochs, &nav.ephemerides, Some(&kb), 13);
    std::fs::write(&out, &bytes)?;
    println!("{out}: {} epochs, {} bytes", epochs.len(), bytes.len());
    Ok(())
}
