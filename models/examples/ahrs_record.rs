//! Record the first 60 s of the simulated loitering flight (seed 1) as the sensor sequence
//! the firmware example runs: 16-bit counts as a MEMS part gives them (gyro LSB 2e-5 rad/s,
//! accelerometer 1e-3 m/s², magnetometer 5e-5).
//!
//! ```sh
//! cargo run -p models --example ahrs_record -- firmware/data/flight.bin
//! ```

use models::ahrs::sim::{LoiteringFlight, SensorErrors};

fn main() {
    let path = std::env::args().nth(1).unwrap_or_else(|| "firmware/data/flight.bin".into());
    let flight = LoiteringFlight::default();
    let errors = SensorErrors::default();
    let samples = flight.simulate(&errors, 1);
    let n = (60.0 * flight.rate) as usize;
    let recorded = &samples[..n];
    let bytes = flight.recording(&errors, recorded, [2e-5, 1e-3, 5e-5]);
    // written beside the target, then renamed over it: a failed write leaves an earlier
    // recording as it was
    let tmp = format!("{path}.partial");
    if let Err(e) = std::fs::write(&tmp, &bytes).and_then(|()| std::fs::rename(&tmp, &path)) {
        let _ = std::fs::remove_file(&tmp);
        eprintln!("ahrs_record: cannot write {path}: {e}");
        std::process::exit(1);
    }
    println!("{path}: {} samples at {} Hz, {} bytes", recorded.len(), flight.rate, bytes.len());
}
