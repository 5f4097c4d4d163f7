//! Reusable models for the error-state filter.
//!
//! | item | what |
//! |---|---|
//! | [`planar::Unicycle`], [`planar::RangeBearing`] | planar robot on `(R², SO(2))` with landmark range-bearing |
#![deny(missing_docs)]
#![allow(non_snake_case)]

pub mod planar;
