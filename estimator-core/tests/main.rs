//! The crate's integration tests in one binary (one link of the whole stack instead
//! of one per file): each module is one file of `tests/`, run as before with
//! `cargo test -p estimator-core --test main MODULE::` (a module's tests) or a test's name.

mod adaptation_hook;
mod bad_input;
mod common;
mod covariance_properties;
mod delayed;
mod discretize;
mod fixed_lag;
mod iterated;
mod linear_kf;
mod monte_carlo_nees;
mod segment_smoother;
mod smoother;
mod smoother_manifold;
mod unscented;
