//! `estimator`: the umbrella crate. Re-exports the member libraries so that one
//! dependency brings the whole framework (the `ins-gnss` program and the `ins-gnss-sim`
//! simulator are separate crates, so depending on this one compiles neither):
//!
//! | module | crate | what |
//! |---|---|---|
//! | [`manifolds`] | `manifolds` | ⊕/⊖ states, SO(3), products, law harness (feature `testing`) |
//! | [`estimator_core`] | `estimator-core` | model traits, the error-state filter, back-ends, reports, Jacobian harness (feature `testing`) |
//! | [`adaptive`] | `adaptive` | noise-adaptation strategies |
//! | [`models`] | `models` | reusable motion models and the AHRS |
//! | [`ins_gnss`] | `ins-gnss-core` | the INS/GNSS library: Earth model, mechanization, 15-state filter, file formats |
//!
//! Features: `faer` (opt-in) forwards to `estimator-core/faer` (the `FaerCov` back-end);
//! `testing` forwards to `manifolds/testing` and `estimator-core/testing` (the law and
//! Jacobian harnesses).
#![deny(missing_docs)]

pub use adaptive;
pub use estimator_core;
pub use gnss;
pub use ins_gnss_core as ins_gnss;
pub use ins_gnss_io;
pub use manifolds;
pub use models;

/// Every Rust block of the README, compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
mod readme {}

/// Every Rust block of the guide's chapters (`docs/guide/`), compiled and run as doctests.
#[cfg(doctest)]
mod guide {
    #[doc = include_str!("../docs/guide/install.md")]
    mod install {}
    #[doc = include_str!("../docs/guide/program.md")]
    mod program {}
    #[doc = include_str!("../docs/guide/python.md")]
    mod python {}
    #[doc = include_str!("../docs/guide/library.md")]
    mod library {}
    #[doc = include_str!("../docs/guide/microcontroller.md")]
    mod microcontroller {}
    #[doc = include_str!("../docs/guide/house.md")]
    mod house {}
}
