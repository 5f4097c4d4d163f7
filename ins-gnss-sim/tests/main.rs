//! The crate's integration tests in one binary (one link of the whole stack instead
//! of one per file): each module is one file of `tests/`, run as before with
//! `cargo test -p ins-gnss-sim --test main MODULE::` (a module's tests) or a test's name.

mod exact;
mod heading_bank;
mod in_motion_alignment;
mod raw_sim;
