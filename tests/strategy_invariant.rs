//! The adaptive layer's promise on the INS (15 states, loose GNSS position and velocity at
//! 10 Hz): every strategy of the program, with and without the gross-error gate, keeps P
//! symmetric positive definite after every epoch and never has an epoch refused, over
//! random mismatches of the declared GNSS σ (either way), a stretch of noisier fixes and
//! gross errors. (The attitude and constant-velocity shapes: `adaptive/tests/invariant.rs`.)

use estimator::adaptive::{AnyStrategy, GrossErrorGate, STRATEGY_NAMES};
use estimator::estimator_core::NoObserver;
use estimator::ins_gnss::{InsModel, Navigator};
use ins_gnss_sim::{scenarios, SimDataset};
use nalgebra::Vector3;
use proptest::prelude::*;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;

use crate::simulated_drive;

/// Finite, symmetric and positive definite (its Cholesky factor exists); with `eigen`,
/// its smallest eigenvalue positive too (an independent path to the same property, at
/// the epochs with fixes: the eigenvalues at every epoch were 60 % of this test's time).
fn spd(p: &nalgebra::SMatrix<f64, 15, 15>, eigen: bool) -> bool {
    let scale = p.abs().max().max(f64::MIN_POSITIVE);
    p.iter().all(|v| v.is_finite())
        && (p - p.transpose()).abs().max() <= 1e-9 * scale
        && p.cholesky().is_some()
        && (!eigen || p.symmetric_eigenvalues().min() > 0.0)
}

/// The fixes as a receiver with a wrong σ would give them: declared σ × `declared`, the
/// positions noisier by `noisy` in the middle third, `gross` of them 50 m off.
fn corrupt(data: &mut SimDataset, seed: u64, declared: f64, noisy: f64, gross: f64) {
    let mut rng = StdRng::seed_from_u64(seed);
    let n = data.gnss.len();
    let earth = 6.378e6;
    for (k, g) in data.gnss.iter_mut().enumerate() {
        let mut extra = Vector3::<f64>::zeros();
        if (n / 3..2 * n / 3).contains(&k) {
            extra += Vector3::from_fn(|i, _| {
                rng.sample::<f64, _>(StandardNormal) * g.pos_std[i] * (noisy - 1.0).max(0.0)
            });
        }
        if rng.random::<f64>() < gross {
            extra += Vector3::new(50.0, -50.0, 20.0);
        }
        g.pos.lat += extra[0] / earth;
        g.pos.lon += extra[1] / (earth * g.pos.lat.cos());
        g.pos.h -= extra[2];
        g.pos_std *= declared;
        if let Some((_, s)) = &mut g.vel {
            *s *= declared;
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 4, .. ProptestConfig::default() })]

    #[test]
    fn the_ins_keeps_p_positive_definite_under_every_strategy(
        seed in 0u64..1000,
        declared in 0.2f64..5.0,
        noisy in 1.0f64..10.0,
        gross in 0.0f64..0.1,
    ) {
        let mut data = simulated_drive::drive(4, 100.0, seed);
        corrupt(&mut data, seed, declared, noisy, gross);
        let (init, cfg) = simulated_drive::start_at_truth(&data);
        for name in STRATEGY_NAMES {
            for gated in [false, true] {
                let s: AnyStrategy = name.parse().unwrap();
                let s = if gated { GrossErrorGate::new(s, 1e-6, 10) } else { GrossErrorGate::disabled(s) };
                let model = InsModel::wgs84(scenarios::mems_imu().noise);
                let mut nav = Navigator::new(&init, model, s, cfg).unwrap();
                let mut out = Vec::new();
                for (k, (imu, fixes)) in data.replay().enumerate() {
                    out.clear();
                    let r = nav.process_into(imu, fixes, &mut NoObserver, &mut out);
                    prop_assert!(r.is_ok(), "{} gated={}: epoch {}: {:?}", name, gated, k, r.err());
                    prop_assert!(spd(nav.covariance(), !fixes.is_empty()), "{} gated={}: P not PD at epoch {}", name, gated, k);
                }
            }
        }
    }
}
