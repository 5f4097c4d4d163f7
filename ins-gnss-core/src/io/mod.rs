//! File formats: streaming readers and writers with located, typed errors.

pub mod columns;
pub mod fixed;
pub mod formats;
pub mod lines;
pub mod nmea;
pub mod ros;
pub mod rtklib;

pub use columns::{ColumnMap, Quantity, Source, TimeScale};
pub use formats::{
    attach_headings, read_headings, write_headings, BadLinePolicy, GnssFormat, GnssReader,
    Headings, ImuFormat, ImuReader, NavReader, NavRecord, SkipCounts,
};
pub use lines::{LineError, LineErrorKind, NumericLines};
