//! The `ins-gnss` program as a library: what its subcommands do, callable from code
//! (the binary only parses arguments). The navigation itself is `ins-gnss-core`; the
//! simulator is `ins-gnss-sim`.
//!
//! | module | what |
//! |---|---|
//! | [`raw_input`] | raw GNSS input (RINEX or u-blox with the ephemerides), epoch by epoch: tight coupling, `spp`, `rtk` |
//! | [`cli`] | the subcommands: `run`, `eval`, `simulate`, `compare`, the demo |
//! | [`config`] | run configurations: our TOML and KF-GINS YAML, validated, datasheet units |
//! | [`columns`] | column maps for logs with a header (CSV): names, units, axes, conventions |
//! | [`run`] | one streaming run over files (bounded memory), or over data in memory |
//! | [`eval`] | errors of a result against a truth file: RMS, maxima, windows |
//! | [`plot`] | SVG plots of errors with ±3σ envelopes and adaptation factors |
//! | [`report`] | `report.html`: a run's summary, tables, plots and configuration in one file |
//! | [`start`] | before the run: the data checked against the declared units and axes, the initial state found from them |
//! | [`scenario`] | scenario files for `simulate`, and Monte Carlo over seeds |
//! | [`spp`] | `spp`: single-point positions of a RINEX file, written as `.pos`, compared with another solution |
#![deny(missing_docs)]
#![allow(non_snake_case)]

/// `println!` that never panics: a closed standard output (`ins-gnss eval … | head`) ends
/// the output quietly instead of aborting the program. (Defined before the modules, so
/// that every one of them can use it.)
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}

pub mod allan;
mod checks;
pub mod cli;
pub mod columns;
pub mod config;
pub mod eval;
pub mod health;
pub mod plot;
pub mod raw_input;
pub mod report;
pub mod rtk;
pub mod run;
pub mod scenario;
pub mod spp;
pub mod start;
