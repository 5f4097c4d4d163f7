//! The crate's integration tests in one binary (one link of the whole stack instead
//! of one per file): each module is one file of `tests/`, run as before with
//! `cargo test -p estimator --test main MODULE::` (a module's tests) or a test's name.

mod backends;
mod calibration;
mod checkpoint;
mod custom_manifold;
mod custom_strategy;
mod everyday;
mod everyday_gnss;
mod house;
mod repro_fused;
mod repro_iakf;
mod repro_sample_data;
mod rtk;
// (shared with examples/rtk_corpus.rs, which uses all of it)
#[allow(dead_code)]
mod rtk_drive;
mod simulated_drive;
mod start_campaign;
mod strategy_invariant;
mod tight_coupling;
mod two_antennas;
mod ubx;
mod ukf_filterpy;
