//! `ins-gnss`: see the workspace README. (Being built.)
#![deny(missing_docs)]
