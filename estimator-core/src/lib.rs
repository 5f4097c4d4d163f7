//! estimator-core
#![deny(missing_docs)]
