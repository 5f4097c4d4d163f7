//! `ins-gnss run`'s options: those that change the configuration
//! ([`crate::config::Overrides`]) and those of the command (outputs, truth, progress,
//! what is kept).

use std::path::Path;

pub use crate::config::Overrides;

/// Options of a run as `ins-gnss run` takes them.
#[derive(Clone, Copy, Debug, Default)]
pub struct RunOptions<'a> {
    /// The options that change the configuration.
    pub config: Overrides<'a>,
    /// Output directory (default: the configuration's).
    pub out: Option<&'a Path>,
    /// Truth file for an evaluation at the end.
    pub truth: Option<&'a Path>,
    /// Seconds skipped by the evaluation.
    pub skip: f64,
    /// Show a progress bar.
    pub progress: bool,
    /// Write SVG plots.
    pub plots: bool,
    /// Write `report.html` (with the plots when there is a truth).
    pub report: bool,
    /// Keep a run [`crate::health::assess`] judges quietly wrong with a warning instead
    /// of an error.
    pub accept_inconsistent: bool,
}
