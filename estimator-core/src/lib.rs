//! The estimation core: model traits, the error-state Kalman filter, the
//! noise-adaptation hook, reports and observers, consistency statistics and Jacobian
//! harnesses.
//!
//! | item | what |
//! |---|---|
//! | [`ProcessModel`], [`MeasurementModel`] | what users implement; Jacobians in named structs |
//! | [`ErrorStateFilter`] | predict / update (Cholesky, Joseph) / inject and reset on any [`Manifold`] state |
//! | [`NoiseStrategy`], [`FixedNoise`], [`Adaptation`] | the adaptation hook and its zero-sized default |
//! | [`UpdateReport`], [`Observer`], [`UpdateLog`] | per-update telemetry |
//! | [`FilterError`] | typed failures; the filter is unchanged after any of them |
//! | [`backend`] | covariance back-ends: nalgebra static (default), nalgebra dynamic, faer |
//! | [`consistency`] | NEES / NIS and χ² bands |
//! | [`harness`] | analytic vs numerical Jacobians through ⊕/⊖ for any model |
//! | [`kernels`] | small column-major kernels (AVX2/FMA when the CPU has them) for the static back-end and structured models |
//! | [`linalg`] | checks and Cholesky helpers with typed errors |
//! | [`linear`] | linear-Gaussian models (the plain Kalman filter as a special case) |
//!
//! Convention: right (body-frame) perturbation, `true = nominal ⊕ δx`
//! (see [`manifolds::Manifold`]).
#![deny(missing_docs)]
#![allow(non_snake_case)]

pub mod adapt;
pub mod backend;
pub mod consistency;
pub mod error;
pub mod filter;
pub mod harness;
pub mod kernels;
pub mod linalg;
pub mod linear;
pub mod report;
pub mod traits;

pub use adapt::{
    Adaptation, CovView, Factors, FixedNoise, NoiseStrategy, PostUpdate, PriorScaling, QAdjust,
    StreamId, StreamMap, Verdict,
};
pub use backend::{CovBackend, DenseCov, DynamicCov, FaerCov, StaticCov, UpdateForm};
pub use error::FilterError;
pub use filter::{ErrorStateFilter, ResetMode};
pub use report::{NoObserver, Observer, UpdateLog, UpdateReport, UpdateSummary};
pub use traits::{
    Cov, FilterAlloc, JacobiansOf, MeasurementJacobians, MeasurementModel, ProcessJacobians,
    ProcessModel, StateDim,
};

pub use manifolds::{self, DimAlloc, Manifold, Tangent, TangentMatrix};
pub use nalgebra;
