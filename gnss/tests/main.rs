//! The crate's integration tests in one binary: each module is one file of `tests/`, run
//! with `cargo test -p gnss --test main MODULE::` (a module's tests) or a test's name.

mod raw_rinex;
