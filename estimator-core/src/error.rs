//! Typed failures of the filter. After any error the filter's state and covariance are
//! exactly what they were before the call.

use core::fmt;

/// What went wrong, and with which quantity.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum FilterError {
    /// A covariance (named by `what`) has no Cholesky factor.
    NotPositiveDefinite {
        /// The matrix, e.g. `"measurement noise R"`.
        what: &'static str,
    },
    /// The filter's own covariance `P` lost its positive definiteness in a step: the
    /// filter refused the step and was left as it was before it (the invariant that `P`
    /// is symmetric positive definite after every prediction and update holds for every
    /// strategy, or the step fails with this error). Checked in full after a step the
    /// strategy changed (a fading λ, a scaled prior, an adapted `Q` or `R`), on the
    /// diagonal after a plain one, which is positive definite by construction.
    CovarianceLost {
        /// The step: `"prediction"` or `"update"`.
        step: &'static str,
        /// The noise strategy in force (its [`name`](crate::NoiseStrategy::name)).
        strategy: &'static str,
    },
    /// A covariance is not symmetric within tolerance.
    NotSymmetric {
        /// The matrix.
        what: &'static str,
        /// Largest `|A − Aᵀ|` entry.
        asymmetry: f64,
    },
    /// A NaN or infinity in an input or a result.
    NonFinite {
        /// The quantity, e.g. `"measurement z"`, `"updated covariance P"`.
        what: &'static str,
    },
    /// A runtime-sized matrix has the wrong shape.
    DimensionMismatch {
        /// The matrix.
        what: &'static str,
        /// `(rows, cols)` expected.
        expected: (usize, usize),
        /// `(rows, cols)` given.
        found: (usize, usize),
    },
    /// A process model's discrete noise `Q_d` is not a covariance.
    InvalidProcessNoise {
        /// The model's type name.
        model: &'static str,
        /// What is wrong: `"not finite"`, `"not symmetric"`, `"not positive semi-definite"`.
        problem: &'static str,
        /// The offending number: the asymmetry, or the most negative pivot of `Q_d`'s
        /// LDLᵀ factorisation (NaN for a non-finite entry).
        value: f64,
    },
    /// A time step that is negative or not finite.
    InvalidTimeStep {
        /// The offending step in seconds.
        dt: f64,
    },
    /// A delayed measurement older than the replay history.
    TooLate {
        /// How far in the past it was stamped, s.
        delay: f64,
        /// How far back the history reaches, s.
        history: f64,
    },
    /// An iteration (a mean on a manifold) did not converge within its cap.
    NotConverged {
        /// What was iterated.
        what: &'static str,
    },
    /// A combination the library does not support.
    Unsupported {
        /// What was asked, and what to do instead.
        what: &'static str,
    },
}

impl fmt::Display for FilterError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FilterError::NotPositiveDefinite { what } => write!(
                f,
                "{what} is not positive definite (Cholesky failed); check the noise settings \
                 and the initial covariance — the filter was left unchanged"
            ),
            FilterError::CovarianceLost { step, strategy } => write!(
                f,
                "the covariance P after this {step} (strategy `{strategy}`) would not be \
                 positive definite, so the {step} was refused — the filter was left unchanged; \
                 the model's Jacobians and noise, or the strategy's scaling, made P indefinite: \
                 try the `fixed` strategy to tell which"
            ),
            FilterError::NotSymmetric { what, asymmetry } => write!(
                f,
                "{what} is not symmetric (largest |A − Aᵀ| = {asymmetry:.3e}); \
                 pass a symmetric matrix — the filter was left unchanged"
            ),
            FilterError::NonFinite { what } => {
                write!(f, "{what} contains NaN or infinity — the filter was left unchanged")
            }
            FilterError::DimensionMismatch { what, expected, found } => write!(
                f,
                "{what} is {}×{}, expected {}×{}",
                found.0, found.1, expected.0, expected.1
            ),
            FilterError::InvalidProcessNoise { model, problem, value } => write!(
                f,
                "process noise Q_d of model `{model}` is {problem} ({value:.3e}); check the \
                 model's noise settings — the filter was left unchanged"
            ),
            FilterError::InvalidTimeStep { dt } => {
                write!(f, "time step {dt} s is negative or not finite (time went backwards?)")
            }
            FilterError::TooLate { delay, history } => write!(
                f,
                "a measurement {delay:.3} s old is older than the replay history \
                 ({history:.3} s); keep a longer history — the filter was left unchanged"
            ),
            FilterError::NotConverged { what } => write!(
                f,
                "{what} did not converge within its iteration cap (points spread too far on a \
                 curved state? try a smaller α) — the filter was left unchanged"
            ),
            FilterError::Unsupported { what } => {
                write!(f, "not supported: {what} — the filter was left unchanged")
            }
        }
    }
}

impl core::error::Error for FilterError {}
