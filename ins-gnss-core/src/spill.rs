//! The INS states and inputs as exact rows of numbers, for the segment smoother's storage
//! ([`estimator_core::SegmentSmoother`]).

use estimator_core::Spill;
use manifolds::So3;
use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use crate::imu::ImuSample;
use crate::model::ImuInput;
use crate::position::GeoPos;
use crate::scale::InsState21;
use crate::state::InsState;

fn put3(out: &mut [f64], v: &Vector3<f64>) {
    out[..3].copy_from_slice(v.as_slice());
}

fn get3(v: &[f64]) -> Vector3<f64> {
    Vector3::new(v[0], v[1], v[2])
}

impl Spill for InsState {
    /// Quaternion (w, i, j, k), velocity, latitude, longitude, height, biases.
    const LEN: usize = 16;
    fn spill(&self, out: &mut [f64]) {
        let q = self.att.quaternion();
        out[..4].copy_from_slice(&[q.w, q.i, q.j, q.k]);
        put3(&mut out[4..], &self.vel);
        out[7..10].copy_from_slice(&[self.pos.lat, self.pos.lon, self.pos.h]);
        put3(&mut out[10..], &self.bg);
        put3(&mut out[13..], &self.ba);
    }
    fn unspill(v: &[f64]) -> Self {
        // (the stored quaternion is already unit: taken as it is, not renormalised)
        let q = UnitQuaternion::new_unchecked(Quaternion::new(v[0], v[1], v[2], v[3]));
        InsState {
            att: So3::from_unit_quaternion_unchecked(q),
            vel: get3(&v[4..]),
            pos: GeoPos { lat: v[7], lon: v[8], h: v[9] },
            bg: get3(&v[10..]),
            ba: get3(&v[13..]),
        }
    }
}

impl Spill for InsState21 {
    /// The 15-state row, gyro and accelerometer scale factors.
    const LEN: usize = InsState::LEN + 6;
    fn spill(&self, out: &mut [f64]) {
        self.nav.spill(&mut out[..InsState::LEN]);
        put3(&mut out[InsState::LEN..], &self.sg);
        put3(&mut out[InsState::LEN + 3..], &self.sa);
    }
    fn unspill(v: &[f64]) -> Self {
        let n = InsState::LEN;
        InsState21 { nav: InsState::unspill(&v[..n]), sg: get3(&v[n..]), sa: get3(&v[n + 3..]) }
    }
}

/// An IMU sample: time, interval, increments, odometer flag and reading.
const SAMPLE: usize = 10;

fn put_sample(out: &mut [f64], s: &ImuSample) {
    out[0] = s.t;
    out[1] = s.dt;
    put3(&mut out[2..], &s.dtheta);
    put3(&mut out[5..], &s.dvel);
    out[8] = f64::from(u8::from(s.odometer.is_some()));
    out[9] = s.odometer.unwrap_or(0.0);
}

fn get_sample(v: &[f64]) -> ImuSample {
    ImuSample {
        t: v[0],
        dt: v[1],
        dtheta: get3(&v[2..]),
        dvel: get3(&v[5..]),
        odometer: (v[8] != 0.0).then_some(v[9]),
    }
}

impl Spill for ImuInput {
    /// A presence flag and the previous sample, then the current one.
    const LEN: usize = 1 + 2 * SAMPLE;
    fn spill(&self, out: &mut [f64]) {
        out[0] = f64::from(u8::from(self.prev.is_some()));
        match &self.prev {
            Some(p) => put_sample(&mut out[1..], p),
            None => out[1..=SAMPLE].fill(0.0),
        }
        put_sample(&mut out[1 + SAMPLE..], &self.cur);
    }
    fn unspill(v: &[f64]) -> Self {
        ImuInput {
            prev: (v[0] != 0.0).then(|| get_sample(&v[1..])),
            cur: get_sample(&v[1 + SAMPLE..]),
        }
    }
    /// An input whose previous sample is the step before's current one: that sample only
    /// (the smoother's records of a run hold each IMU sample once).
    const AFTER_LEN: usize = SAMPLE;
    fn spill_after(&self, before: &Self, out: &mut [f64]) -> bool {
        // bit for bit (a NaN-free sample equal by value is the same bits but ±0)
        let same = |a: &ImuSample, b: &ImuSample| {
            let (mut x, mut y) = ([0.0; SAMPLE], [0.0; SAMPLE]);
            put_sample(&mut x, a);
            put_sample(&mut y, b);
            x.iter().zip(&y).all(|(p, q)| p.to_bits() == q.to_bits())
        };
        match &self.prev {
            Some(p) if same(p, &before.cur) => {
                put_sample(out, &self.cur);
                true
            }
            _ => false,
        }
    }
    fn unspill_after(v: &[f64], before: &Self) -> Self {
        ImuInput { prev: Some(before.cur), cur: get_sample(v) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn round_trip<T: Spill + PartialEq + core::fmt::Debug>(x: &T) {
        let mut v = vec![f64::NAN; T::LEN];
        x.spill(&mut v);
        assert!(v.iter().all(|v| !v.is_nan()), "every slot written");
        assert_eq!(&T::unspill(&v), x);
    }

    #[test]
    fn states_and_inputs_come_back_exactly() {
        let nav = InsState {
            att: So3::from_euler(0.1, -0.2, 2.9),
            vel: Vector3::new(1.0, -2.0, 0.1),
            pos: GeoPos { lat: 0.5, lon: 2.1, h: 30.5 },
            bg: Vector3::new(1e-5, -2e-5, 3e-6),
            ba: Vector3::new(1e-3, 2e-3, -4e-3),
        };
        round_trip(&nav);
        round_trip(&InsState21 {
            nav,
            sg: Vector3::new(1e-4, 2e-4, -3e-4),
            sa: Vector3::new(-1e-4, 5e-4, 0.0),
        });
        let s = ImuSample::from_increments(
            10.01,
            0.01,
            Vector3::new(1e-3, 2e-3, 3e-3),
            Vector3::new(0.1, 0.0, -0.098),
        );
        round_trip(&ImuInput { prev: None, cur: s });
        let with_odo = ImuSample { odometer: Some(0.0), ..s };
        round_trip(&ImuInput { prev: Some(s), cur: with_odo });
    }

    /// An input that repeats the step before's sample is stored as its new sample alone
    /// and comes back exactly; one that does not (another previous sample, none, an
    /// odometer flag or a signed zero that differs) is not shortened.
    #[test]
    fn inputs_after_the_step_before_are_stored_once() {
        let s = ImuSample::from_increments(
            10.01,
            0.01,
            Vector3::new(1e-3, 2e-3, 3e-3),
            Vector3::new(0.1, 0.0, -0.098),
        );
        let next = ImuSample { t: 10.02, dtheta: Vector3::new(2e-3, 0.0, -1e-3), ..s };
        let before = ImuInput { prev: None, cur: s };
        let after = ImuInput { prev: Some(s), cur: next };
        let mut v = vec![f64::NAN; ImuInput::AFTER_LEN];
        assert!(after.spill_after(&before, &mut v));
        assert!(v.iter().all(|v| !v.is_nan()), "every slot written");
        assert_eq!(ImuInput::unspill_after(&v, &before), after);
        const { assert!(ImuInput::AFTER_LEN < ImuInput::LEN) };
        let others = [
            ImuInput { prev: None, cur: next },
            ImuInput { prev: Some(next), cur: next },
            ImuInput { prev: Some(ImuSample { odometer: Some(0.0), ..s }), cur: next },
            ImuInput {
                prev: Some(ImuSample { dvel: Vector3::new(0.1, -0.0, -0.098), ..s }),
                cur: next,
            },
        ];
        for other in others {
            assert!(!other.spill_after(&before, &mut v), "{other:?}");
        }
    }
}
