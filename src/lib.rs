//! `estimator`: the umbrella crate. Re-exports the member crates so that one dependency
//! brings the whole framework:
//!
//! | module | crate | what |
//! |---|---|---|
//! | [`manifolds`] | `manifolds` | ⊕/⊖ states, SO(3), products, law harness |
//! | [`core`] | `estimator-core` | model traits, the error-state filter, reports, harnesses |
//! | [`adaptive`] | `adaptive` | noise-adaptation strategies |
//! | [`models`] | `models` | reusable motion models and the AHRS |
//! | [`ins_gnss`] | `ins-gnss` | the 15-state INS/GNSS filter and its file formats |
#![deny(missing_docs)]

pub use adaptive;
pub use estimator_core as core;
pub use ins_gnss;
pub use manifolds;
pub use models;
