//! The numbers of one row of `nav.txt`, `std.txt` and `imu_errors.txt`.

use super::*;

/// A smoothed row: time, navigation state, and the σ of the error states (as many as the
/// state has).
pub(crate) fn smoothed_row<S: RunState>(
    r: &SmoothedRow<S>,
    floors: &Floors,
) -> (f64, InsState, Option<[f64; 21]>)
where
    DefaultAllocator: DimAlloc<S::Dim>,
{
    let sigma = r.var.as_ref().map(|var| {
        let mut sigma = [0.0; 21];
        for (s, v) in sigma.iter_mut().zip(var.iter()) {
            *s = v.max(0.0).sqrt();
        }
        if let Some(f) = floors.at(r.time) {
            raise_position_sigma(&mut sigma, &f);
        }
        sigma
    });
    (r.time, r.x.nav().clone(), sigma)
}

/// The position variances (N, E, D; m²) below which a tight run's reported σ does not go
/// ([`Navigator::satellite_floor`]), from the time each raw epoch set them on.
#[derive(Clone, Debug, Default)]
pub(crate) struct Floors(Vec<(f64, [f64; 3])>);

impl Floors {
    /// The floor from `t` on (kept only when it changed).
    pub(crate) fn push(&mut self, t: f64, f: [f64; 3]) {
        if self.0.last().is_none_or(|(_, last)| *last != f) {
            self.0.push((t, f));
        }
    }

    /// The floor in force at `t`.
    pub(crate) fn at(&self, t: f64) -> Option<[f64; 3]> {
        let i = self.0.partition_point(|(tf, _)| *tf <= t + 1e-9);
        i.checked_sub(1).map(|i| self.0[i].1)
    }
}

/// The position σ (the error state's position block) raised to the floor's.
pub(crate) fn raise_position_sigma(sigma: &mut [f64], floor: &[f64; 3]) {
    for (s, f) in sigma[InsState::POS.range()].iter_mut().zip(floor) {
        *s = s.max(f.max(0.0).sqrt());
    }
}

/// The navigation record of a state.
pub fn nav_record(t: f64, x: &ins_gnss_core::InsState) -> NavRecord {
    let (r, p, y) = x.euler();
    NavRecord { week: 0.0, t, pos: x.pos, vel: x.vel, att: Vector3::new(r, p, y) }
}

/// One row of `std.txt` (its values and decimals) and its length: `t`, then the 1σ of
/// the error states `s` in the file's units (position, velocity, attitude in degrees,
/// biases in deg/h and mGal, scale factors in ppm).
pub(crate) fn sigma_row(t: f64, s: &[f64]) -> ([(f64, usize); 22], usize) {
    let d = 180.0 / core::f64::consts::PI;
    let mut row: [(f64, usize); 22] = [(0.0, 0); 22];
    row[0] = (t, 6);
    let order = [6, 7, 8, 3, 4, 5, 0, 1, 2, 9, 10, 11, 12, 13, 14];
    for (k, &i) in order.iter().enumerate() {
        row[1 + k] = match i {
            0..=2 => (s[i] * d, 8),
            9..=11 => (s[i] / DEG_PER_H, 6),
            12..=14 => (s[i] / MGAL, 6),
            _ => (s[i], 6),
        };
    }
    // 21 states: the scale factors' σ, ppm (KF-GINS's columns)
    let n = s.len().min(21);
    for i in 15..n {
        row[1 + i] = (s[i] * 1e6, 3);
    }
    (row, 1 + n)
}

/// One row of `imu_errors.txt` (its values and decimals) and its length: `t`, gyro bias
/// (deg/h), accelerometer bias (mGal), and with 21 states the scale factors (ppm).
pub(crate) fn imu_error_row(
    t: f64,
    x: &InsState,
    scale: Option<(Vector3<f64>, Vector3<f64>)>,
) -> ([(f64, usize); 13], usize) {
    let mut row = [(0.0, 3); 13];
    row[0] = (t, 6);
    for i in 0..3 {
        row[1 + i] = (x.bg[i] / DEG_PER_H, 6);
        row[4 + i] = (x.ba[i] / MGAL, 6);
    }
    let Some((sg, sa)) = scale else { return (row, 7) };
    for (i, v) in sg.iter().chain(sa.iter()).enumerate() {
        row[7 + i] = (v * 1e6, 3);
    }
    (row, 13)
}
