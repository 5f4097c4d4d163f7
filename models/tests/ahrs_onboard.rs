//! The AHRS as firmware runs it (`models::ahrs::onboard`): the recording format round trip
//! and its refusals, and the sample-by-sample driver against the experiment's loop.

use manifolds::Manifold;
use models::ahrs::experiment::{run_traced, Variant};
use models::ahrs::onboard::{cs_maekf_model, RecordingError};
use models::ahrs::sim::{LoiteringFlight, SensorErrors};
use models::ahrs::{Ahrs, AhrsMeasurement, Recording};
use nalgebra::Vector3;

fn flight_samples(n: usize) -> (LoiteringFlight, SensorErrors, Vec<models::ahrs::sim::Sample>) {
    let flight = LoiteringFlight::default();
    let errors = SensorErrors::default();
    let samples = flight.simulate(&errors, 7).into_iter().take(n).collect();
    (flight, errors, samples)
}

#[test]
fn recording_round_trip_within_half_a_count() {
    let (flight, errors, mut samples) = flight_samples(500);
    let lsb = [2e-5, 1e-3, 5e-5];
    samples[3].accel.x = 1e3; // beyond ±32767 counts: saturates
    let raw: Vec<[Vector3<f64>; 3]> = samples.iter().map(|s| [s.gyro, s.accel, s.mag]).collect();
    let bytes = flight.recording(&errors, &samples, lsb);
    let att0 = flight.attitude(0.0);
    let rec = Recording::parse(&bytes).unwrap();
    assert_eq!(rec.len(), raw.len());
    assert_eq!(
        (rec.rate, rec.gyro_noise, rec.g_n, rec.m_n, rec.lsb),
        (flight.rate, errors.gyro_noise, flight.g_n, flight.m_n, lsb)
    );
    assert_eq!(rec.att0.quaternion().coords, att0.quaternion().coords);
    for (k, want) in raw.iter().enumerate() {
        let got = rec.sample::<f64>(k).unwrap();
        for s in 0..3 {
            for i in 0..3 {
                let w = want[s][i].clamp(-32767.0 * lsb[s], 32767.0 * lsb[s]);
                assert!(
                    (got[s][i] - w).abs() <= 0.5 * lsb[s] * (1.0 + 1e-9),
                    "sample {k} sensor {s} axis {i}"
                );
            }
        }
    }
    assert_eq!(rec.sample::<f64>(3).unwrap()[1].x, 32767.0 * 1e-3);
    assert!(rec.sample::<f64>(raw.len()).is_none());
}

#[test]
fn recording_refuses_foreign_and_truncated_bytes() {
    let (flight, errors, samples) = flight_samples(10);
    let bytes = flight.recording(&errors, &samples, [1e-4; 3]);
    assert_eq!(Recording::parse(b"not a recording").unwrap_err(), RecordingError::NotARecording);
    assert_eq!(Recording::parse(&bytes[..20]).unwrap_err(), RecordingError::Truncated);
    assert_eq!(Recording::parse(&bytes[..bytes.len() - 1]).unwrap_err(), RecordingError::Truncated);
    // a corrupt sample count (u32::MAX) is refused, not trusted
    let mut huge = bytes.clone();
    huge[8 + 8 * 15..8 + 8 * 15 + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    assert_eq!(Recording::parse(&huge).unwrap_err(), RecordingError::Truncated);
    assert_eq!(Recording::parse(&bytes).unwrap().len(), 10);
}

/// The firmware's and the replay's set-up (`Ahrs::new` with `cs_maekf_model`) is the
/// experiment's CS-MAEKF with the paper's settings (`Variant::CsMaekf`, `Start::Paper`,
/// which runs through `Ahrs::from_filter`): the same attitude errors at every sample, bit
/// for bit.
#[test]
fn driver_matches_the_experiment_loop_exactly() {
    let (flight, errors, samples) = flight_samples(2000);
    let model = cs_maekf_model(errors.gyro_noise, flight.rate);
    let mut expected = Vec::new();
    run_traced(&Variant::CsMaekf.model(&errors, flight.rate), &flight, &samples, |_, e| {
        expected.push(e)
    })
    .unwrap();
    let meas = AhrsMeasurement { g_n: flight.g_n, m_n: flight.m_n };
    let mut ahrs = Ahrs::new(model, meas, flight.attitude(0.0), flight.rate).unwrap();
    for (s, want) in samples.iter().zip(&expected) {
        ahrs.step(&s.gyro, &s.accel, &s.mag).unwrap();
        let (a, b) = (ahrs.state().att.euler(), s.att.euler());
        let w = manifolds::wrap_angle;
        let got = [w(a.0 - b.0).to_degrees(), w(a.1 - b.1).to_degrees(), w(a.2 - b.2).to_degrees()];
        assert_eq!(&got, want, "t = {}", s.t);
    }
    assert_eq!(expected.len(), 2000);
}

/// The firmware's compiled-in recording, run on the host: readable, 60 s at 100 Hz, and the
/// filter ends within 3° of the simulated truth (seed 1, the recording's seed).
#[test]
fn firmware_recording_runs_on_the_host() {
    let bytes =
        std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/../firmware/data/flight.bin")).unwrap();
    let rec = Recording::parse(&bytes).unwrap();
    assert_eq!((rec.len(), rec.rate), (6000, 100.0));
    let truth = LoiteringFlight::default().simulate(&SensorErrors::default(), 1);
    let meas = AhrsMeasurement { g_n: rec.g_n, m_n: rec.m_n };
    let mut ahrs =
        Ahrs::new(cs_maekf_model(rec.gyro_noise, rec.rate), meas, rec.att0, rec.rate).unwrap();
    for k in 0..rec.len() {
        let [g, a, m] = rec.sample(k).unwrap();
        ahrs.step(&g, &a, &m).unwrap();
    }
    let err = ahrs.state().att.ominus(&truth[5999].att).norm();
    assert!(err.to_degrees() < 3.0, "final attitude error {:.3}°", err.to_degrees());
    let p = ahrs.filter().covariance();
    assert!(p.clone().cholesky().is_some() && (p.transpose() - p.as_ref()).abs().max() == 0.0);
}
