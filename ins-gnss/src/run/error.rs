//! Why a run stopped: [`RunError`].

use super::*;

/// Why a run stopped.
#[derive(Debug)]
pub enum RunError {
    /// A configuration problem.
    Config(crate::config::ConfigError),
    /// A malformed input line or unreadable file.
    Input(LineError),
    /// The filter failed (with time).
    Navigation(NavError),
    /// The filter failed on the record of `path` at `line`: a GNSS epoch whose update
    /// failed, or the IMU sample whose prediction did.
    Located {
        /// The input file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What failed.
        error: NavError,
    },
    /// Writing an output failed.
    Output {
        /// The file.
        path: PathBuf,
        /// The error.
        message: String,
    },
    /// A raw GNSS file (tight coupling) is malformed or cannot be used.
    Raw(gnss::RawError),
    /// The IMU file ends before the start time or has no sample after it.
    NoData(String),
    /// The data do not match the configuration (units, axes, rate), or the initial state
    /// cannot be found from them; the message names the key to change.
    Start(String),
    /// The fixes' errors were probed: the bank judges their model and the run starts
    /// again with the one chosen ([`run`] does; never returned to a caller).
    FixErrorsProbed(FixErrorProbe),
    /// The start's search found the IMU's stamps off and `calibrate.time_offset`
    /// applies it: the run starts again with this `data.imu_time_offset` ([`run`] does;
    /// never returned to a caller), the start's line on it kept.
    TimeOffsetApplied(f64, Vec<String>),
    /// The run failed after it had started writing: its outputs stay as `*.partial` in
    /// `dir`, earlier results there are untouched.
    Incomplete {
        /// Why.
        error: Box<RunError>,
        /// The output directory.
        dir: PathBuf,
    },
}

impl fmt::Display for RunError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RunError::Config(e) => write!(f, "{e}"),
            RunError::Input(e) => write!(f, "{e}"),
            RunError::Navigation(e) => write!(f, "navigation failed {e}"),
            RunError::Located { path, line, error } => {
                write!(f, "{}:{line}: navigation failed {error}", path.display())
            }
            RunError::Output { path, message } => {
                write!(f, "{}: cannot write: {message}", path.display())
            }
            RunError::Raw(e) => write!(f, "{e}"),
            RunError::NoData(m) => write!(f, "{m}"),
            RunError::FixErrorsProbed(p) => write!(
                f,
                "the fixes' errors were probed over {} fixes (lag-one autocorrelation {:.2})",
                p.fixes, p.lag_one
            ),
            RunError::TimeOffsetApplied(offset, _) => {
                write!(f, "the IMU's stamps are shifted by {offset:.3} s (`data.imu_time_offset`)")
            }
            RunError::Start(m) => write!(f, "{m}"),
            RunError::Incomplete { error, dir } => write!(
                f,
                "{error}\n(no earlier result in {} was touched; this run's partial output is \
                 there as *.partial)",
                dir.display()
            ),
        }
    }
}

impl std::error::Error for RunError {}

impl From<LineError> for RunError {
    fn from(e: LineError) -> Self {
        RunError::Input(e)
    }
}

impl From<NavError> for RunError {
    fn from(e: NavError) -> Self {
        RunError::Navigation(e)
    }
}
