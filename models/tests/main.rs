//! The crate's integration tests in one binary (one link of the whole stack instead
//! of one per file): each module is one file of `tests/`, run as before with
//! `cargo test -p models --test main MODULE::` (a module's tests) or a test's name.

mod ahrs_f32;
mod ahrs_onboard;
mod cs_maekf_claim;
mod laws;
mod range_bearing;
mod smoother_range_bearing;
