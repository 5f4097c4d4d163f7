//! The crate's integration tests in one binary (one link of the whole stack instead
//! of one per file): each module is one file of `tests/`, run as before with
//! `cargo test -p ins-gnss --test main MODULE::` (a module's tests) or a test's name.

mod allan;
mod bad_input;
mod campaign;
mod cli;
mod common;
mod consistency;
mod datasheet_noise;
mod formats;
mod fuzz_readers;
mod guide;
mod in_memory;
mod jacobians;
mod laws;
mod mechanization;
mod monte_carlo;
mod navego;
mod navigator;
mod plots_report;
mod rate_path;
mod ros;
mod rtk_run;
mod rtklib;
#[path = "../../tests/sample_data/mod.rs"]
mod sample_data;
mod scale_factors;
mod smoothing;
mod spp_rtklib;
mod start_from_data;
mod tight_run;
mod unit;
mod vehicle_aiding;
