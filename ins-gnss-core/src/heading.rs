//! Heading (and pitch) from two antennas: a moving-base receiver measures the direction of
//! the baseline from its primary antenna to its secondary one, as a heading clockwise from
//! north and, where it gives the baseline's down component, an elevation.
//!
//! With the baseline `b_b` in the body frame (FRD, from the primary antenna to the
//! secondary; its length does not matter) and `b = R_nb b_b` (NED):
//! `ψ = atan2(b_E, b_N)`, `θ = atan2(−b_D, √(b_N² + b_E²))`. Under the right attitude
//! error `R_nb Exp(δθ)`, `∂b/∂δθ = −R_nb [b_b×]`;
//! `∂ψ/∂b = [−b_E, b_N, 0] / h²` and `∂θ/∂b = [b_D b_N / h, b_D b_E / h, −h] / |b|²`
//! (`h = √(b_N² + b_E²)`). The heading's residual is wrapped to (−π, π]. A baseline
//! along the forward axis (`[1, 0, 0]`) measures the vehicle's yaw; one across it (a
//! receiver mounted with the antennas left–right), the yaw + 90°.
//!
//! Sources (the `ins-gnss-io` crate): NMEA `HDT`/`THS` (`ins_gnss_io::nmea`); a heading
//! file (`ins_gnss_io::read_headings`): RTKLIB moving-base solutions in ENU,
//! u-blox `NAV-RELPOSNED`, columns; or any [`AntennaHeading`] a caller builds.

use estimator_core::{MeasurementJacobians, MeasurementModel, StreamId};
use manifolds::hat;
use nalgebra::{Const, SMatrix, Vector1, Vector2, Vector3};

use crate::state::InsState;

pub use ::gnss::heading::{wrap, AntennaHeading};

/// The stream of heading updates ([`BaselineHeading`], [`BaselineAttitude`]).
pub const GNSS_HEADING: StreamId = StreamId::named("gnss-heading");

/// A baseline whose horizontal part is below this share of its length has no heading.
const MIN_HORIZONTAL: f64 = 0.2;

/// How a run uses the headings of two antennas.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeadingConfig {
    /// The baseline from the primary antenna to the secondary, body frame (FRD), m.
    pub baseline: Vector3<f64>,
    /// The heading's 1σ, rad: replaces the source's when `force_std`, else used where the
    /// source gives none.
    pub std: f64,
    /// The elevation's 1σ, rad (as `std`).
    pub pitch_std: f64,
    /// Replace the sources' σ by `std` and `pitch_std`.
    pub force_std: bool,
    /// Use the elevation where the source gives it.
    pub use_pitch: bool,
}

impl Default for HeadingConfig {
    fn default() -> Self {
        Self {
            baseline: Vector3::x(),
            std: 0.5_f64.to_radians(),
            pitch_std: 1.0_f64.to_radians(),
            force_std: false,
            use_pitch: true,
        }
    }
}

impl HeadingConfig {
    /// The heading's σ for measurement `m`, rad.
    pub fn heading_std(&self, m: &AntennaHeading) -> f64 {
        match (self.force_std, m.heading_std) {
            (false, Some(s)) if s > 0.0 => s,
            _ => self.std,
        }
    }

    /// The elevation and its σ for measurement `m`, when used.
    pub fn pitch(&self, m: &AntennaHeading) -> Option<(f64, f64)> {
        let (p, s) = m.pitch.filter(|_| self.use_pitch)?;
        let s = match (self.force_std, s) {
            (false, Some(s)) if s > 0.0 => s,
            _ => self.pitch_std,
        };
        Some((p, s))
    }

    /// The vehicle's heading (the body's yaw, rad) that a measured baseline heading
    /// `psi` means for a level body: `psi` less the baseline's own azimuth in the body.
    pub fn body_yaw(&self, psi: f64) -> f64 {
        wrap(psi - self.baseline.y.atan2(self.baseline.x))
    }

    /// Whether the baseline has a horizontal direction in the body frame.
    pub fn has_heading(&self) -> bool {
        has_horizontal_direction(&self.baseline)
    }
}

/// A heading file's headings handed to the epochs at their time: each epoch takes the
/// heading within 1 ms of it; headings passed over found no epoch.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HeadingQueue {
    list: Vec<AntennaHeading>,
    next: usize,
    unmatched: usize,
}

impl HeadingQueue {
    /// The headings, in time order.
    pub fn new(list: Vec<AntennaHeading>) -> Self {
        Self { list, next: 0, unmatched: 0 }
    }

    /// The heading at an epoch of time `t` (its time set to `t`), if one is within 1 ms;
    /// the epochs must come in time order.
    pub fn take(&mut self, t: f64) -> Option<AntennaHeading> {
        while self.next < self.list.len() && self.list[self.next].t < t - 1e-3 {
            self.next += 1;
            self.unmatched += 1;
        }
        let m = self.list.get(self.next).filter(|m| (m.t - t).abs() <= 1e-3)?;
        self.next += 1;
        Some(AntennaHeading { t, ..*m })
    }

    /// Headings that found no epoch so far, and those not reached yet.
    pub fn unmatched(&self) -> usize {
        self.unmatched + (self.list.len() - self.next)
    }
}

/// The baseline in NED and its Jacobian with respect to the attitude error.
fn baseline_ned(baseline: &Vector3<f64>, x: &InsState) -> (Vector3<f64>, SMatrix<f64, 3, 3>) {
    let r = x.att.matrix();
    (r * baseline, -r * hat(baseline))
}

/// Heading `ψ` and elevation `θ` of a NED baseline with their gradients.
fn angles(b: &Vector3<f64>) -> (f64, f64, Vector3<f64>, Vector3<f64>) {
    let h2 = b.x * b.x + b.y * b.y;
    let h = h2.sqrt().max(1e-12);
    let n2 = (h2 + b.z * b.z).max(1e-24);
    let psi = b.y.atan2(b.x);
    let theta = (-b.z).atan2(h);
    let d_psi = Vector3::new(-b.y, b.x, 0.0) / h2.max(1e-24);
    let d_theta = Vector3::new(b.z * b.x / h, b.z * b.y / h, -h) / n2;
    (psi, theta, d_psi, d_theta)
}

/// Whether a vector has a horizontal direction — its first two components (N, E; E, N;
/// or a body's x, y) at least a fifth of its length — so that its heading is defined.
pub fn has_horizontal_direction(b: &Vector3<f64>) -> bool {
    b.norm() > 0.0 && b.xy().norm() >= MIN_HORIZONTAL * b.norm()
}

/// Whether state `x` sees the baseline with a horizontal direction (the heading is
/// defined).
pub fn heading_defined(baseline: &Vector3<f64>, x: &InsState) -> bool {
    has_horizontal_direction(&(x.att.matrix() * baseline))
}

/// The baseline's heading, `z = ψ`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaselineHeading {
    /// The baseline, body frame (FRD), m.
    pub baseline: Vector3<f64>,
}

impl MeasurementModel for BaselineHeading {
    type State = InsState;
    type Measurement = Vector1<f64>;

    fn predict(&self, x: &InsState) -> Vector1<f64> {
        let (b, _) = baseline_ned(&self.baseline, x);
        Vector1::new(angles(&b).0)
    }

    fn jacobian(&self, x: &InsState) -> MeasurementJacobians<Const<1>, Const<15>> {
        let (b, db) = baseline_ned(&self.baseline, x);
        let (_, _, d_psi, _) = angles(&b);
        let mut h = SMatrix::<f64, 1, 15>::zeros();
        h.fixed_view_mut::<1, 3>(0, 0).copy_from(&(d_psi.transpose() * db));
        MeasurementJacobians { H: h }
    }

    fn residual(&self, z: &Vector1<f64>, z_hat: &Vector1<f64>) -> Vector1<f64> {
        Vector1::new(wrap(z.x - z_hat.x))
    }

    fn stream(&self) -> StreamId {
        GNSS_HEADING
    }
}

/// The baseline's heading and elevation, `z = [ψ, θ]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BaselineAttitude {
    /// The baseline, body frame (FRD), m.
    pub baseline: Vector3<f64>,
}

impl MeasurementModel for BaselineAttitude {
    type State = InsState;
    type Measurement = Vector2<f64>;

    fn predict(&self, x: &InsState) -> Vector2<f64> {
        let (b, _) = baseline_ned(&self.baseline, x);
        let (psi, theta, _, _) = angles(&b);
        Vector2::new(psi, theta)
    }

    fn jacobian(&self, x: &InsState) -> MeasurementJacobians<Const<2>, Const<15>> {
        let (b, db) = baseline_ned(&self.baseline, x);
        let (_, _, d_psi, d_theta) = angles(&b);
        let mut h = SMatrix::<f64, 2, 15>::zeros();
        h.fixed_view_mut::<1, 3>(0, 0).copy_from(&(d_psi.transpose() * db));
        h.fixed_view_mut::<1, 3>(1, 0).copy_from(&(d_theta.transpose() * db));
        MeasurementJacobians { H: h }
    }

    fn residual(&self, z: &Vector2<f64>, z_hat: &Vector2<f64>) -> Vector2<f64> {
        Vector2::new(wrap(z.x - z_hat.x), z.y - z_hat.y)
    }

    fn stream(&self) -> StreamId {
        GNSS_HEADING
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::GeoPos;
    use manifolds::So3;

    fn state(roll: f64, pitch: f64, yaw: f64) -> InsState {
        InsState {
            att: So3::from_euler(roll, pitch, yaw),
            vel: Vector3::new(3.0, -1.0, 0.2),
            pos: GeoPos::from_degrees(30.5, 114.4, 20.0),
            bg: Vector3::zeros(),
            ba: Vector3::zeros(),
        }
    }

    #[test]
    fn forward_baseline_measures_the_yaw() {
        for yaw in [-179.0_f64, -90.0, 0.0, 37.0, 179.5] {
            let x = state(0.03, -0.02, yaw.to_radians());
            let z = BaselineHeading { baseline: Vector3::x() }.predict(&x);
            // with roll and pitch the forward axis' azimuth is still the yaw
            assert!(wrap(z.x - yaw.to_radians()).abs() < 1e-12, "{yaw}: {}", z.x.to_degrees());
        }
        // across the vehicle (right antenna secondary): the yaw + 90°
        let x = state(0.0, 0.0, 0.3);
        let z = BaselineHeading { baseline: Vector3::y() * 1.2 }.predict(&x);
        assert!((z.x - 0.3 - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        let cfg = HeadingConfig { baseline: Vector3::y(), ..Default::default() };
        assert!((cfg.body_yaw(z.x) - 0.3).abs() < 1e-12);
    }

    #[test]
    fn elevation_of_a_pitched_baseline() {
        let x = state(0.0, 0.1, 1.0);
        let z = BaselineAttitude { baseline: Vector3::x() }.predict(&x);
        assert!((z.y - 0.1).abs() < 1e-12);
    }

    #[test]
    fn residual_wraps_across_north() {
        let m = BaselineHeading { baseline: Vector3::x() };
        let r = m.residual(&Vector1::new(-3.1), &Vector1::new(3.1));
        assert!((r.x - (std::f64::consts::TAU - 6.2)).abs() < 1e-12);
        assert!((wrap(std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-15);
        assert!((wrap(-std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-15);
    }

    #[test]
    fn vertical_baseline_has_no_heading() {
        let cfg = HeadingConfig { baseline: Vector3::z(), ..Default::default() };
        assert!(!cfg.has_heading());
        assert!(!heading_defined(&Vector3::z(), &state(0.0, 0.0, 1.0)));
        assert!(heading_defined(&Vector3::x(), &state(0.0, 0.5, 1.0)));
    }
}
