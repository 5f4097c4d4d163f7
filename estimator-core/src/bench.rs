//! Criterion benchmarks of the covariance back-ends on *your* model (feature `bench`):
//! which back-end is fastest for your state size and measurement is a measurement, not a
//! rule of thumb.
//!
//! ```no_run
//! use criterion::Criterion;
//! use estimator_core::bench::compare_backends;
//! use estimator_core::linear::{LinearMeasurement, LinearProcess};
//! use nalgebra::{SMatrix, SVector};
//!
//! fn my_model(c: &mut Criterion) {
//!     let process = LinearProcess {
//!         F: SMatrix::<f64, 12, 12>::identity(),
//!         Q: SMatrix::<f64, 12, 12>::identity() * 1e-4,
//!     };
//!     let sensor = LinearMeasurement::<3, 12>::new(SMatrix::<f64, 3, 12>::identity());
//!     compare_backends(
//!         c,
//!         "my_model",
//!         &SVector::<f64, 12>::zeros(),
//!         &SMatrix::<f64, 12, 12>::identity(),
//!         (&process, &(), 0.01),
//!         (&sensor, &SVector::<f64, 3>::zeros(), &SMatrix::<f64, 3, 3>::identity()),
//!     );
//! }
//! criterion::criterion_group!(benches, my_model);
//! criterion::criterion_main!(benches);
//! ```
//!
//! In a bench target of your crate (`[[bench]] harness = false`), with
//! `estimator-core = { …, features = ["bench"] }` (and `"faer"` to include `FaerCov`),
//! `cargo bench` reports, for every back-end, one prediction (`GROUP/predict/BACKEND`) and
//! one prediction followed by one update (`GROUP/predict_update/BACKEND`), each on a
//! filter that starts from your `x0` and `P0` and runs with the fixed strategy.

use std::hint::black_box;

use criterion::Criterion;
use manifolds::{DimAlloc, Manifold};
use nalgebra::DefaultAllocator;

#[cfg(feature = "faer")]
use crate::FaerCov;
use crate::{
    Cov, CovBackend, DynamicCov, ErrorStateFilter, FilterAlloc, FixedNoise, MeasurementModel,
    ProcessModel, StateDim, StaticCov,
};

/// A prediction's model, input and interval.
pub type Prediction<'a, PM> = (&'a PM, &'a <PM as ProcessModel>::Input, f64);

/// An update's model, measurement and noise.
pub type Update<'a, MM> = (
    &'a MM,
    &'a <MM as MeasurementModel>::Measurement,
    &'a Cov<StateDim<<MM as MeasurementModel>::Measurement>>,
);

/// Benchmarks one prediction, and one prediction with one update, on every covariance
/// back-end (`StaticCov`, `DynamicCov` and, with feature `faer`, `FaerCov`), in the
/// criterion group `group`. A back-end that refuses the start (`P0` not a covariance) or
/// a step is reported on standard error and left out.
pub fn compare_backends<X, PM, MM>(
    c: &mut Criterion,
    group: &str,
    x0: &X,
    p0: &Cov<X::Dim>,
    predict: Prediction<'_, PM>,
    update: Update<'_, MM>,
) where
    X: Manifold,
    PM: ProcessModel<State = X>,
    MM: MeasurementModel<State = X>,
    DefaultAllocator: DimAlloc<X::Dim> + FilterAlloc<X::Dim, StateDim<MM::Measurement>>,
{
    let mut g = c.benchmark_group(group);
    one(&mut g, x0, p0, predict, update, StaticCov);
    one(&mut g, x0, p0, predict, update, DynamicCov::default());
    #[cfg(feature = "faer")]
    one(&mut g, x0, p0, predict, update, FaerCov::default());
    g.finish();
}

fn one<X, PM, MM, B>(
    g: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    x0: &X,
    p0: &Cov<X::Dim>,
    (process, u, dt): Prediction<'_, PM>,
    (sensor, z, r): Update<'_, MM>,
    backend: B,
) where
    X: Manifold,
    PM: ProcessModel<State = X>,
    MM: MeasurementModel<State = X>,
    B: CovBackend<X::Dim> + Clone,
    DefaultAllocator: DimAlloc<X::Dim> + FilterAlloc<X::Dim, StateDim<MM::Measurement>>,
{
    let name = B::NAME;
    let start = match ErrorStateFilter::with_backend(x0.clone(), p0.clone(), FixedNoise, backend) {
        Ok(f) => f,
        Err(e) => {
            eprintln!("{name}: the start is refused: {e}");
            return;
        }
    };
    // a step the filter refuses is said once and the back-end left out
    let mut probe = start.clone();
    if let Err(e) =
        probe.predict(process, u, dt).and_then(|_| probe.update(sensor, z, r).map(|_| ()))
    {
        eprintln!("{name}: a step is refused: {e}");
        return;
    }
    let mut f = start.clone();
    g.bench_function(format!("predict/{name}"), |b| {
        b.iter(|| {
            if f.predict(black_box(process), u, dt).is_err() {
                f = start.clone();
            }
        })
    });
    let mut f = start.clone();
    g.bench_function(format!("predict_update/{name}"), |b| {
        b.iter(|| {
            let step = f.predict(black_box(process), u, dt).and_then(|_| f.update(sensor, z, r));
            match step {
                Ok(report) => {
                    black_box(report.nis);
                }
                Err(_) => f = start.clone(),
            }
        })
    });
}
