//! The INS/GNSS file formats: streaming readers and writers with located, typed errors
//! (file and line). Built on `ins-gnss-core`'s types (`ImuSample`, `GnssEpoch`, `GeoPos`,
//! `AntennaHeading`) and the `gnss` crate's calendar and file opening.
//!
//! | module | what |
//! |---|---|
//! | [`formats`] | KF-GINS text by what is read or written: IMU, GNSS, headings, navigation; opening (decompressed) and atomic publishing |
//! | [`columns`] | column maps: any column order, units and time scale of a CSV log |
//! | [`lines`] | numeric lines, fast: the readers' tokenizer and its located errors |
//! | [`rtklib`] | RTKLIB `.pos` solutions: reader and writer |
//! | [`nmea`] | NMEA 0183 logs: `GGA`, `GST`, `RMC`/`ZDA`, `HDT`/`THS` |
//! | [`ros`] | ROS 1 bags and MCAP: IMU, fixes and odometry messages into the formats' rows, and the writer of a run's output as a recording |
//! | [`fixed`] | fast fixed-point text for the output files |
#![deny(missing_docs)]

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
