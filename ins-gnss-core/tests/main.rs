//! The crate's integration tests in one binary (one link of the whole stack instead
//! of one per file): each module is one file of `tests/`, run as before with
//! `cargo test -p ins-gnss-core --test main MODULE::` (a module's tests) or a test's name.

mod static_start;
