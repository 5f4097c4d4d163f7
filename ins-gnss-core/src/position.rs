//! Geodetic position as a manifold whose tangent is a small NED displacement in metres.
//!
//! Error definition (as in KF-GINS and most INS texts, e.g. Groves 2013 §14.2): the true
//! position is the estimate displaced by `δp = [δN, δE, δD]` metres in the local NED
//! frame, first order in the curvilinear coordinates:
//!
//! ```text
//! φ ⊕ δp = φ + δN / (R_M + h)
//! λ ⊕ δp = λ + δE / ((R_N + h) cos φ)
//! h ⊕ δp = h − δD
//! ```
//!
//! with the radii at the point being perturbed; `⊖` inverts it exactly at the origin
//! point. This keeps the 15-state error in metres (well scaled) while the nominal state
//! keeps full geodetic precision.

use nalgebra::{Const, DMatrixView, Matrix3, Vector3};

use manifolds::{Manifold, OminusJacobians, OplusJacobians};

use crate::wgs84::{radii_from_sin, sin_cos_near};

/// A geodetic position: latitude and longitude in radians, ellipsoidal height in metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GeoPos {
    /// Latitude φ, rad.
    pub lat: f64,
    /// Longitude λ, rad.
    pub lon: f64,
    /// Height above the ellipsoid, m.
    pub h: f64,
}

impl GeoPos {
    /// From radians and metres.
    pub fn new(lat: f64, lon: f64, h: f64) -> Self {
        Self { lat, lon, h }
    }

    /// From degrees and metres.
    pub fn from_degrees(lat_deg: f64, lon_deg: f64, h: f64) -> Self {
        Self { lat: lat_deg.to_radians(), lon: lon_deg.to_radians(), h }
    }

    /// `(lat, lon, h)` in radians and metres.
    pub fn tuple(&self) -> (f64, f64, f64) {
        (self.lat, self.lon, self.h)
    }

    /// `diag(R_M + h, (R_N + h) cos φ, −1)`: metres per unit of (φ, λ, h) change.
    pub fn metric(&self) -> Vector3<f64> {
        let (s, c) = self.lat.sin_cos();
        metric_at(s, c, self.h)
    }
}

/// [`GeoPos::metric`] at the latitude with sine `s` and cosine `c`, height `h`.
pub(crate) fn metric_at(s: f64, c: f64, h: f64) -> Vector3<f64> {
    let (rm, rn) = radii_from_sin(s);
    metric_from_radii(rm, rn, c, h)
}

/// [`GeoPos::metric`] from the radii `R_M`, `R_N`, `cos φ` and the height.
pub(crate) fn metric_from_radii(rm: f64, rn: f64, c: f64, h: f64) -> Vector3<f64> {
    Vector3::new(rm + h, (rn + h) * c, -1.0)
}

/// `diag(m_to,N / m_from,N, m_to,E / m_from,E, 1)`: how a NED-metre displacement at
/// `from` scales when carried to `to` (the down axis is the same everywhere).
fn metric_ratio(from: &GeoPos, to: &GeoPos) -> Matrix3<f64> {
    ratio_of_metrics(&from.metric(), &to.metric())
}

/// [`metric_ratio`] from the two metrics.
fn ratio_of_metrics(from: &Vector3<f64>, to: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::from_diagonal(&Vector3::new(to.x / from.x, to.y / from.y, 1.0))
}

impl GeoPos {
    /// `self ⊕ d` with `m = self.metric()` already at hand.
    pub(crate) fn oplus_with_metric(&self, d: &Vector3<f64>, m: &Vector3<f64>) -> Self {
        Self { lat: self.lat + d.x / m.x, lon: self.lon + d.y / m.y, h: self.h + d.z / m.z }
    }

    /// `self ⊖ origin` with `m = origin.metric()` already at hand.
    pub(crate) fn ominus_with_metric(&self, origin: &Self, m: &Vector3<f64>) -> Vector3<f64> {
        Vector3::new(
            (self.lat - origin.lat) * m.x,
            (self.lon - origin.lon) * m.y,
            (self.h - origin.h) * m.z,
        )
    }

    /// [`GeoPos::metric`] at a point near `near`, whose latitude's sine and cosine are
    /// `(s, c)`: this latitude's functions come from those through [`sin_cos_near`].
    pub(crate) fn metric_near(&self, near: &GeoPos, (s, c): (f64, f64)) -> Vector3<f64> {
        let (s, c) = sin_cos_near(self.lat, near.lat, s, c);
        metric_at(s, c, self.h)
    }

    /// `self ⊕ d` and the reset block `∂(self ⊕ d)/∂d`, from the metric here and at
    /// `self ⊕ d` with one `sin_cos`: the second latitude's functions come from the first's
    /// through [`sin_cos_near`].
    fn oplus_and_reset_block(&self, d: &Vector3<f64>) -> (Self, Matrix3<f64>) {
        let (s, c) = self.lat.sin_cos();
        let m = metric_at(s, c, self.h);
        let y = self.oplus_with_metric(d, &m);
        let g = ratio_of_metrics(&m, &y.metric_near(self, (s, c)));
        (y, g)
    }
}

impl manifolds::Coeffs for GeoPos {
    /// Latitude, longitude (rad), height (m).
    const LEN: usize = 3;
    fn coeffs(&self, out: &mut [f64]) {
        out.copy_from_slice(&[self.lat, self.lon, self.h]);
    }
    fn from_coeffs(c: &[f64]) -> Self {
        GeoPos { lat: c[0], lon: c[1], h: c[2] }
    }
}

impl Manifold for GeoPos {
    type Dim = Const<3>;

    fn origin() -> Self {
        Self { lat: 0.0, lon: 0.0, h: 0.0 }
    }

    fn oplus(&self, d: &Vector3<f64>) -> Self {
        self.oplus_with_metric(d, &self.metric())
    }

    fn ominus(&self, origin: &Self) -> Vector3<f64> {
        self.ominus_with_metric(origin, &origin.metric())
    }

    fn is_finite(&self) -> bool {
        self.lat.is_finite() && self.lon.is_finite() && self.h.is_finite()
    }

    /// `J_y_δ = diag(m_y,N / m_x,N, m_y,E / m_x,E, 1)` with `m` the metric at each point.
    /// `J_y_x` involves the derivative of the radii with latitude (below 1e-6 relative for
    /// displacements under a kilometre) and is taken by central differences of 1 mm.
    fn oplus_jacobians(&self, d: &Vector3<f64>) -> OplusJacobians<Self> {
        let (y, J_y_delta) = self.oplus_and_reset_block(d);
        let J_y_x = manifolds::numdiff::jacobian(self, |xp| xp.oplus(d).ominus(&y), 1e-3);
        OplusJacobians { J_y_x, J_y_delta }
    }

    /// `diag(m_y,N / m_x,N, m_y,E / m_x,E, 1)` (also the one reset block).
    fn oplus_jacobian_delta(&self, d: &Vector3<f64>) -> Matrix3<f64> {
        self.oplus_and_reset_block(d).1
    }

    /// `reset_blocks` and `oplus` from one metric and one `sin_cos`.
    fn oplus_reset(
        &self,
        d: &Vector3<f64>,
        visit: &mut dyn FnMut(usize, DMatrixView<'_, f64>),
    ) -> Self {
        let (y, g) = self.oplus_and_reset_block(d);
        visit(0, DMatrixView::from_slice(g.as_slice(), 3, 3));
        y
    }

    /// `J_d_y = diag(m_x / m_y)` exactly; `J_d_x` by central differences of 1 mm.
    fn ominus_jacobians(&self, origin: &Self) -> OminusJacobians<Self> {
        let J_d_y = metric_ratio(self, origin);
        let J_d_x = manifolds::numdiff::jacobian(origin, |xp| self.ominus(xp), 1e-3);
        OminusJacobians { J_d_y, J_d_x }
    }
}
