//! The IMU inputs as exact rows of numbers, for the segment smoother's storage
//! ([`estimator_core::SegmentSmoother`]). The states need no code here: they are stored as
//! their coefficients ([`manifolds::Coeffs`], which `composite_state!` derives from the
//! fields' and [`GeoPos`](crate::GeoPos) implements).

use estimator_core::Spill;
use nalgebra::Vector3;

use crate::imu::ImuSample;
use crate::model::ImuInput;

fn put3(out: &mut [f64], v: &Vector3<f64>) {
    out[..3].copy_from_slice(v.as_slice());
}

fn get3(v: &[f64]) -> Vector3<f64> {
    Vector3::new(v[0], v[1], v[2])
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
    /// An input whose previous sample is the step before's current one: that sample only,
    /// and of it only what the step before's does not give (the time when it is that
    /// sample's time plus the interval, the interval when it is the same, the odometer
    /// when there is none): 6 to 9 numbers, so that the smoother's records of a run hold
    /// each IMU sample once and the increments of a steady-rate log alone.
    const AFTER_LEN: usize = 9;
    fn spill_after(&self, before: &Self, out: &mut [f64]) -> Option<u8> {
        let prev = self.prev.as_ref()?;
        // bit for bit (a NaN-free sample equal by value is the same bits but ±0)
        let (mut x, mut y) = ([0.0; SAMPLE], [0.0; SAMPLE]);
        put_sample(&mut x, prev);
        put_sample(&mut y, &before.cur);
        if !x.iter().zip(&y).all(|(p, q)| p.to_bits() == q.to_bits()) {
            return None;
        }
        let (s, last) = (&self.cur, &before.cur);
        let same_dt = s.dt.to_bits() == last.dt.to_bits();
        let next_t = (last.t + s.dt).to_bits() == s.t.to_bits();
        let mut form = 0;
        let mut at = 0;
        let mut put = |v: &[f64]| {
            out[at..at + v.len()].copy_from_slice(v);
            at += v.len();
        };
        if same_dt {
            form |= SAME_DT;
        } else {
            put(&[s.dt]);
        }
        if next_t {
            form |= NEXT_T;
        } else {
            put(&[s.t]);
        }
        put(s.dtheta.as_slice());
        put(s.dvel.as_slice());
        match s.odometer {
            None => form |= NO_ODOMETER,
            Some(v) => put(&[v]),
        }
        Some(form)
    }
    fn after_len(form: u8) -> usize {
        let absent = |bit: u8| usize::from(form & bit == 0);
        6 + absent(SAME_DT) + absent(NEXT_T) + absent(NO_ODOMETER)
    }
    fn unspill_after(v: &[f64], form: u8, before: &Self) -> Self {
        let last = &before.cur;
        let mut at = 0;
        let mut take = |n: usize| {
            at += n;
            &v[at - n..at]
        };
        let dt = if form & SAME_DT != 0 { last.dt } else { take(1)[0] };
        let t = if form & NEXT_T != 0 { last.t + dt } else { take(1)[0] };
        let dtheta = get3(take(3));
        let dvel = get3(take(3));
        let odometer = (form & NO_ODOMETER == 0).then(|| take(1)[0]);
        ImuInput { prev: Some(*last), cur: ImuSample { t, dt, dtheta, dvel, odometer } }
    }
    /// The step ends at the sample's time, after its interval.
    fn stamp(&self) -> Option<(f64, f64)> {
        Some((self.cur.t, self.cur.dt))
    }
}

/// Forms of an IMU input stored after the one before ([`Spill::spill_after`]): the interval
/// is the one before's, the time is the one before's plus the interval, no odometer.
const SAME_DT: u8 = 1;
const NEXT_T: u8 = 2;
const NO_ODOMETER: u8 = 4;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::position::GeoPos;
    use crate::scale::InsState21;
    use crate::state::InsState;
    use crate::tight::{InsStateTc, InsStateTc21};
    use manifolds::So3;

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
        let nav21 = InsState21 {
            nav: nav.clone(),
            sg: Vector3::new(1e-4, 2e-4, -3e-4),
            sa: Vector3::new(-1e-4, 5e-4, 0.0),
        };
        round_trip(&nav21);
        // (the rows are the fields' coefficients in order: the quaternion w, i, j, k first)
        let mut row = [0.0; 16];
        nav.spill(&mut row);
        let q = nav.att.quaternion();
        assert_eq!(row[..4], [q.w, q.i, q.j, q.k]);
        assert_eq!(row[7..10], [0.5, 2.1, 30.5]);
        let isb = Vector3::new(3.0, -4.0, 0.5);
        round_trip(&InsStateTc { nav, clock: manifolds::R2::new(12.5, -0.25), isb });
        round_trip(&InsStateTc21 { nav: nav21, clock: manifolds::R2::new(-1.0, 0.0), isb });
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

    /// An input that repeats the step before's sample is stored as its new sample alone,
    /// less what the step before gives, and comes back exactly in every form; one that
    /// does not (another previous sample, none, an odometer flag or a signed zero that
    /// differs) is not shortened.
    #[test]
    fn inputs_after_the_step_before_are_stored_once() {
        let s = ImuSample::from_increments(
            10.01,
            0.01,
            Vector3::new(1e-3, 2e-3, 3e-3),
            Vector3::new(0.1, 0.0, -0.098),
        );
        let before = ImuInput { prev: None, cur: s };
        let steady = ImuSample { t: 10.01 + 0.01, dtheta: Vector3::new(2e-3, 0.0, -1e-3), ..s };
        // (form, numbers): the steady sample gives only its increments
        let cases = [
            (steady, SAME_DT | NEXT_T | NO_ODOMETER, 6),
            (ImuSample { odometer: Some(0.0), ..steady }, SAME_DT | NEXT_T, 7),
            (ImuSample { t: 10.03, ..steady }, SAME_DT | NO_ODOMETER, 7),
            (ImuSample { dt: 0.02, t: 10.01 + 0.02, ..steady }, NEXT_T | NO_ODOMETER, 7),
            (ImuSample { dt: 0.02, t: 10.04, odometer: Some(-1.5), ..steady }, 0, 9),
        ];
        for (next, form, len) in cases {
            let after = ImuInput { prev: Some(s), cur: next };
            let mut v = vec![f64::NAN; ImuInput::AFTER_LEN];
            assert_eq!(after.spill_after(&before, &mut v), Some(form), "{next:?}");
            assert_eq!(ImuInput::after_len(form), len);
            assert!(v[..len].iter().all(|v| !v.is_nan()), "every slot written");
            assert!(v[len..].iter().all(|v| v.is_nan()), "nothing past the form's length");
            let back = ImuInput::unspill_after(&v[..len], form, &before);
            assert_eq!(back, after);
            assert_eq!(back.cur.t.to_bits(), next.t.to_bits());
            assert_eq!(back.stamp(), Some((next.t, next.dt)));
        }
        const { assert!(ImuInput::AFTER_LEN < ImuInput::LEN) };
        // the longest form is the most there is room for
        assert_eq!((0..8).map(ImuInput::after_len).max(), Some(ImuInput::AFTER_LEN));
        let next = steady;
        let others = [
            ImuInput { prev: None, cur: next },
            ImuInput { prev: Some(next), cur: next },
            ImuInput { prev: Some(ImuSample { odometer: Some(0.0), ..s }), cur: next },
            ImuInput {
                prev: Some(ImuSample { dvel: Vector3::new(0.1, -0.0, -0.098), ..s }),
                cur: next,
            },
        ];
        let mut v = vec![f64::NAN; ImuInput::AFTER_LEN];
        for other in others {
            assert_eq!(other.spill_after(&before, &mut v), None, "{other:?}");
        }
    }
}
