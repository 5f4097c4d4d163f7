//! File formats: streaming readers and writers with located, typed errors.

pub mod fixed;
pub mod formats;
pub mod lines;

pub use formats::{
    BadLinePolicy, GnssReader, ImuFormat, ImuReader, NavReader, NavRecord, SkipCounts,
};
pub use lines::{LineError, LineErrorKind, NumericLines};
