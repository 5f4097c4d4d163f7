//! Noise-adaptation strategies for [`estimator_core::ErrorStateFilter`]: each one reads
//! the innovation sequence and may scale `P⁻`, replace `R` (and `Q`), or reject a
//! measurement. Swap them with one type or, at run time, one name.
//!
//! | strategy | name | adapts | reference |
//! |---|---|---|---|
//! | [`FixedNoise`] | `fixed` | nothing (the standard KF) | — |
//! | [`Iae`] | `iae` | `R` (and optionally `Q`) from a window of innovations | Mohamed & Schwarz 1999 |
//! | [`Afkf`] | `afkf` | a fading factor on `P⁻` | Xia et al. 1994 |
//! | [`FusedDualWindow`] | `fused` | `λ_P` on `P⁻` and `λ_R` on `R` from two windows; gross errors skipped | paper `fused-iae-afkf` |
//! | [`Iakf`] | `iakf` (`1/k`), `iakf-raw` | `R` inflated when a χ² test fails | paper `iakf-chi-square` |
//! | [`SageHusa`] | `sage-husa` | recursive `R` with forgetting | Sage & Husa 1969 |
//! | [`AnyStrategy`] | any of the above | run-time choice by name | — |
//! | [`Route`], [`PerStream`] | one strategy per measurement stream (by type, by name) | — | — |
//! | [`GrossErrorGate`] | any strategy behind a χ² gate that refuses gross errors and re-admits down-weighted | — | — |
//!
//! Every strategy keeps its windows per measurement stream
//! ([`estimator_core::StreamId`]), works for any measurement dimension and any state
//! manifold, keeps `R`, `Q` and `P` symmetric positive definite whatever the
//! innovations, and reports each decision (DOM, λ_P, λ_R, verdict, reason) in the
//! filter's [`estimator_core::UpdateReport`].
//!
//! ```
//! use adaptive::{AnyStrategy, Iakf};
//! use estimator_core::{ErrorStateFilter, NoiseStrategy};
//! use nalgebra::{Matrix2, Vector2};
//!
//! // By type …
//! let f = ErrorStateFilter::new(Vector2::zeros(), Matrix2::identity(), Iakf::default()).unwrap();
//! // … or by name.
//! let g: AnyStrategy = "sage-husa".parse().unwrap();
//! assert_eq!(g.name(), "sage-husa");
//! # let _ = f;
//! ```
#![deny(missing_docs)]
#![allow(non_snake_case)]

/// `Clone` for a struct, field by field, with a `clone_from` that refills each field in
/// place. The filter copies its strategy before every update (to put it back if the update
/// fails) with `clone_from`; a derived `Clone`'s `clone_from` makes a new copy, allocating
/// every vector of the strategy's windows anew. Every field is named: one left out is a
/// compile error. A type with one type parameter names it (`Gate<A> { … }`).
macro_rules! clone_in_place {
    ($t:ident $(<$g:ident>)? { $($f:ident),* $(,)? }) => {
        impl$(<$g: Clone>)? Clone for $t$(<$g>)? {
            fn clone(&self) -> Self {
                Self { $($f: self.$f.clone()),* }
            }

            fn clone_from(&mut self, source: &Self) {
                let Self { $($f),* } = source;
                $(self.$f.clone_from($f);)*
            }
        }
    };
}

mod afkf;
mod any;
mod fused;
mod gate;
mod guard;
mod iae;
mod iakf;
mod per_stream;
mod sage_husa;
mod window;

pub use afkf::{Afkf, FadingAt, MismatchEstimate};
pub use any::{AnyStrategy, UnknownStrategy, STRATEGY_NAMES};
pub use estimator_core::FixedNoise;
pub use fused::{FusedDualWindow, GrossTest, RReading};
pub use gate::{
    ChiSquareGate, GateMode, GrossErrorGate, LearnedNoise, CORRELATED, DEFAULT_PROBABILITY,
    DEFAULT_READMIT_AFTER, GATE_WINDOW, LEARNED_REASON, LEARN_WINDOW, MAX_R_FACTOR, TRUST,
    TRUST_DOWN, WHITE_LAG,
};
pub use guard::FadingGuard;
pub use iae::Iae;
pub use iakf::{Iakf, Inflation};
pub use per_stream::{PerStream, Route};
pub use sage_husa::{SageHusa, PRIOR_UPDATES as SAGE_HUSA_PRIOR_UPDATES};
pub use window::NoiseBounds;
