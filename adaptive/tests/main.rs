//! The crate's integration tests in one binary (one link of the whole stack instead
//! of one per file): each module is one file of `tests/`, run as before with
//! `cargo test -p adaptive --test main MODULE::` (a module's tests) or a test's name.

mod afkf_xia;
mod chi_square_gate;
mod claims;
mod common;
mod fading_memory;
mod fused_readings;
mod invariant;
mod learned_noise;
mod per_stream;
mod safety;
