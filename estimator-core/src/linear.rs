//! Linear-Gaussian models on `R^N`: `x_{k+1} = F x_k + w`, `z = H x + v`.
//! On a Euclidean state the error-state filter is exactly the linear Kalman filter.

use nalgebra::{SMatrix, SVector};

use crate::stream::StreamId;
use crate::traits::{MeasurementJacobians, MeasurementModel, ProcessJacobians, ProcessModel};

/// `x_{k+1} = F x_k + w_k`, `w_k ~ N(0, Q)`; `F` and `Q` are per step (the `dt`
/// argument is ignored).
#[allow(non_snake_case)]
#[derive(Clone, Debug)]
pub struct LinearProcess<const N: usize> {
    /// Transition.
    pub F: SMatrix<f64, N, N>,
    /// Process noise per step.
    pub Q: SMatrix<f64, N, N>,
}

impl<const N: usize> ProcessModel for LinearProcess<N> {
    type State = SVector<f64, N>;
    type Input = ();

    fn propagate(&self, x: &SVector<f64, N>, _u: &(), _dt: f64) -> SVector<f64, N> {
        self.F * x
    }

    fn jacobians(
        &self,
        _x: &SVector<f64, N>,
        _u: &(),
        _dt: f64,
    ) -> ProcessJacobians<nalgebra::Const<N>> {
        ProcessJacobians { Phi: self.F, Q: self.Q }
    }
}

/// `z = H x + v`, `v ~ N(0, R)` with `R` given at each update.
#[allow(non_snake_case)]
#[derive(Clone, Debug)]
pub struct LinearMeasurement<const M: usize, const N: usize> {
    /// Observation matrix.
    pub H: SMatrix<f64, M, N>,
    /// Stream of this sensor.
    pub stream: StreamId,
}

#[allow(non_snake_case)]
impl<const M: usize, const N: usize> LinearMeasurement<M, N> {
    /// A sensor with observation matrix `H` on the default stream of this type.
    pub fn new(H: SMatrix<f64, M, N>) -> Self {
        Self { H, stream: StreamId::of::<Self>() }
    }

    /// The same sensor on a named stream.
    pub fn on_stream(mut self, name: &'static str) -> Self {
        self.stream = StreamId::named(name);
        self
    }
}

impl<const M: usize, const N: usize> MeasurementModel for LinearMeasurement<M, N> {
    type State = SVector<f64, N>;
    type Measurement = SVector<f64, M>;

    fn predict(&self, x: &SVector<f64, N>) -> SVector<f64, M> {
        self.H * x
    }

    fn jacobian(
        &self,
        _x: &SVector<f64, N>,
    ) -> MeasurementJacobians<nalgebra::Const<M>, nalgebra::Const<N>> {
        MeasurementJacobians { H: self.H }
    }

    fn stream(&self) -> StreamId {
        self.stream
    }
}
