//! [`NoiseStrategy`] and what serves it (the documentation is on the item).

use core::marker::PhantomData;

use nalgebra::{DefaultAllocator, DimName, OMatrix, OVector};

use manifolds::DimAlloc;

use crate::dims::{Cov, FilterAlloc};
use crate::entries::Entries;
use crate::scalar::FilterScalar;
use crate::stream::StreamId;

/// Read access to an `N × N` covariance where its back-end keeps it, without copying it:
/// entries, contiguous columns, or a static copy on demand
/// ([`to_matrix`](Self::to_matrix)). A dense back-end at 120 states would otherwise copy
/// 115 KB for every update that a strategy might look at.
#[derive(Clone, Copy)]
pub struct CovView<'a, N, T: FilterScalar = f64> {
    p: &'a dyn Entries<T>,
    _n: PhantomData<N>,
}

impl<'a, N: DimName, T: FilterScalar> CovView<'a, N, T>
where
    DefaultAllocator: DimAlloc<N>,
{
    /// A view of `p`, which must be `N × N`.
    pub fn new(p: &'a dyn Entries<T>) -> Self {
        Self { p, _n: PhantomData }
    }

    /// Entry `(r, c)`.
    pub fn at(&self, r: usize, c: usize) -> T {
        self.p.at(r, c)
    }

    /// Column `c`.
    pub fn column(&self, c: usize) -> &'a [T] {
        self.p.col(c)
    }

    /// A copy as a static matrix.
    pub fn to_matrix(&self) -> Cov<N, T> {
        Cov::<N, T>::from_fn(|r, c| self.p.at(r, c))
    }
}

impl<N: DimName, T: FilterScalar> core::fmt::Debug for CovView<'_, N, T>
where
    DefaultAllocator: DimAlloc<N>,
{
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "CovView({0}×{0})", N::DIM)
    }
}

/// What happened to a measurement.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Verdict {
    /// Used with the nominal noise.
    Accepted,
    /// Used with inflated / adapted noise or a scaled prior.
    Inflated,
    /// Used with adapted noise that the innovation finds smaller than the nominal one
    /// (its adapted NIS above the nominal NIS: a strategy that estimated `R` or `Q` below
    /// its nominal value). Strategies set [`Verdict::Inflated`]; the filter tells the two
    /// apart.
    Deflated,
    /// Not used; state and covariance unchanged.
    Rejected,
}

impl Verdict {
    /// Lower-case name for logs and CSV files.
    pub fn as_str(&self) -> &'static str {
        match self {
            Verdict::Accepted => "accepted",
            Verdict::Inflated => "inflated",
            Verdict::Deflated => "deflated",
            Verdict::Rejected => "rejected",
        }
    }
}

/// The numbers behind a decision (NaN where a strategy does not compute one).
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Factors {
    /// Degree of mismatch `tr(Ĉ)/tr(S)`.
    pub dom: f64,
    /// Scale applied to `P⁻` (fading / forgetting factor).
    pub lambda_p: f64,
    /// Scale applied to `R` (or `tr(R*)/tr(R)` when `R` was replaced).
    pub lambda_r: f64,
}

impl Default for Factors {
    fn default() -> Self {
        Self { dom: f64::NAN, lambda_p: 1.0, lambda_r: 1.0 }
    }
}

/// How a prior scale `λ = prior_scale` is applied to `P⁻`.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum PriorScaling {
    /// Along the measurement subspace only:
    /// `P⁻* = P⁻ + (λ − 1) P⁻Hᵀ (H P⁻ Hᵀ)⁺ H P⁻` (default; `⁺` the pseudo-inverse, over
    /// the directions the prior constrains, when `H P⁻ Hᵀ` is rank-deficient). `H P⁻* = λ H P⁻`, so the gain
    /// and the state correction are exactly those of full scaling, but directions the
    /// measurement cannot see are not inflated — with full scaling they grow by λ at every
    /// update and the covariance eventually overflows.
    #[default]
    MeasurementSubspace,
    /// `P⁻* = λ P⁻`, the textbook form.
    Full,
}

/// How the strategy wants the process noise of the following predictions changed.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(bound(
        serialize = "Cov<N, T>: serde::Serialize, T: serde::Serialize",
        deserialize = "Cov<N, T>: serde::Deserialize<'de>, T: serde::Deserialize<'de>"
    ))
)]
pub enum QAdjust<N: DimName, T: FilterScalar = f64>
where
    DefaultAllocator: nalgebra::allocator::Allocator<N, N>,
{
    /// Leave `Q` as it is.
    Keep,
    /// Use the model's `Q_d` times this factor.
    Scale(T),
    /// Add `rate · dt` to the model's `Q_d` (an extra covariance per second; the model's
    /// `Q_d` stays as a floor, so `P` stays positive definite).
    AddRate(Cov<N, T>),
    /// Back to the model's `Q_d`.
    Model,
}

/// One decision: inputs the strategy reads, outputs it may change.
///
/// On entry the outputs hold the nominal values (`prior_scale = 1`, `R = R_nominal`,
/// `verdict = Accepted`). The filter then scales `P⁻` as `prior_scaling` says, uses `R`,
/// or skips the update when `verdict = Rejected`.
#[allow(non_snake_case)]
pub struct Adaptation<'a, N: DimName, M: DimName, T: FilterScalar = f64>
where
    DefaultAllocator: FilterAlloc<N, M>,
{
    /// Stream of the measurement.
    pub stream: StreamId,
    /// Filter update counter (all streams), starting at 1 for the first update.
    pub epoch: u64,
    /// Filter time in seconds.
    pub time: f64,
    /// Innovation `r = z ⊖ h(x̂⁻)`.
    pub innovation: &'a OVector<T, M>,
    /// Measurement Jacobian.
    pub H: &'a OMatrix<T, M, N>,
    /// Predicted covariance `P⁻`, read in place.
    pub P_prior: CovView<'a, N, T>,
    /// `H P⁻ Hᵀ`.
    pub HPHt: &'a OMatrix<T, M, M>,
    /// `H Q_Σ Hᵀ`, `Q_Σ` the process noise accumulated since the previous update
    /// (`Q_Σ ← Φ Q_Σ Φᵀ + Q_d` over the predictions in between, so that
    /// `P⁻ = Φ_Σ P Φ_Σᵀ + Q_Σ`); `Some` only when the strategy asked for it
    /// ([`NoiseStrategy::tracks_process_noise`]).
    pub HQHt: Option<&'a OMatrix<T, M, M>>,
    /// The measurement noise the caller gave.
    pub R_nominal: &'a OMatrix<T, M, M>,
    /// Nominal innovation covariance `S = H P⁻ Hᵀ + R_nominal`.
    pub S: &'a OMatrix<T, M, M>,
    /// `NIS = rᵀ S⁻¹ r` with the nominal `S`.
    pub nis: f64,
    /// Output: factor on `P⁻` (≥ 1 inflates).
    pub prior_scale: f64,
    /// Output: how `prior_scale` is applied.
    pub prior_scaling: PriorScaling,
    /// Output: `prior_scale` scales the propagated part `P⁻ − Q_Σ = Φ_Σ P Φ_Σᵀ` only, not
    /// the process noise added since the previous update (Xia's fading factor). Honoured
    /// only when [`HQHt`](Self::HQHt) is `Some`. Default `false`.
    pub scale_propagated_only: bool,
    /// Output: the `R` to use (symmetric positive definite; the filter checks).
    pub R: OMatrix<T, M, M>,
    /// Output: the verdict.
    pub verdict: Verdict,
    /// Output: why (shown in reports and logs).
    pub reason: &'static str,
    /// Output: the factors behind the decision.
    pub factors: Factors,
    /// Output: process-noise change for the following predictions.
    pub q: QAdjust<N, T>,
    /// Output: the strategy's adaptation has run without making the innovations smaller,
    /// and the strategy holds it off (it is not helping on this stream). Reported in
    /// [`UpdateReport::not_helping`](crate::UpdateReport::not_helping). Default `false`.
    pub not_helping: bool,
}

/// After a successful update: the gain, for strategies that adapt `Q` from it.
#[allow(non_snake_case)]
pub struct PostUpdate<'a, N: DimName, M: DimName, T: FilterScalar = f64>
where
    DefaultAllocator: FilterAlloc<N, M>,
{
    /// Stream of the measurement.
    pub stream: StreamId,
    /// Filter time in seconds.
    pub time: f64,
    /// The gain actually used.
    pub K: &'a OMatrix<T, N, M>,
    /// The innovation.
    pub innovation: &'a OVector<T, M>,
    /// Output: process-noise change for the following predictions.
    pub q: QAdjust<N, T>,
}

/// A noise-adaptation strategy. One method is required, [`adapt`](Self::adapt); the
/// name, the prediction fading and the post-update hook have defaults.
///
/// Contract: whatever the innovations, the `R` a strategy leaves in
/// [`Adaptation::R`] is symmetric positive definite and finite and `prior_scale` is
/// finite and positive; the filter verifies both and fails the update with a typed error
/// if not. After any `Err` the filter restores the strategy as it was before the update
/// (it keeps a clone, hence the `Clone` bound; a zero-sized strategy clones for free).
/// State kept between updates belongs in a [`StreamMap`](crate::StreamMap), one entry per measurement
/// stream.
///
/// # Example
///
/// A strategy that inflates `R` by a fixed factor whenever the NIS exceeds a gate, with
/// its own count per stream:
///
/// ```
/// use estimator_core::linear::LinearMeasurement;
/// use estimator_core::{
///     Adaptation, ErrorStateFilter, FilterAlloc, NoiseStrategy, StreamMap, Verdict,
/// };
/// use nalgebra::{DefaultAllocator, DimName, Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};
///
/// #[derive(Clone, Default)]
/// struct Inflate { gate: f64, inflated: StreamMap<u32> }
///
/// impl NoiseStrategy for Inflate {
///     fn adapt<N: DimName, M: DimName>(&mut self, a: &mut Adaptation<'_, N, M>)
///     where
///         DefaultAllocator: FilterAlloc<N, M>,
///     {
///         if a.nis > self.gate {
///             a.R = a.R_nominal * 10.0;          // R* = 10 R
///             a.verdict = Verdict::Inflated;
///             a.reason = "NIS above the gate";
///             *self.inflated.get_or_insert_with(a.stream, || 0) += 1;
///         }
///     }
/// }
///
/// let s = Inflate { gate: 9.0, ..Default::default() };
/// assert_eq!(s.name(), "Inflate");                // the default name: the type's
/// let mut f = ErrorStateFilter::new(Vector2::zeros(), Matrix2::identity(), s).unwrap();
/// let gps = LinearMeasurement::<1, 2>::new(Matrix1x2::new(1.0, 0.0)).on_stream("gps");
/// let report = f.update(&gps, &Vector1::new(50.0), &Matrix1::new(1.0)).unwrap();
/// assert_eq!(report.verdict, Verdict::Inflated);
/// assert_eq!(report.stream.name(), "gps");
/// assert_eq!(f.strategy().inflated.get(gps.stream), Some(&1));
/// ```
///
/// # Scalar
///
/// `impl NoiseStrategy for S` is `NoiseStrategy<f64>`: the strategies of `adaptive` run in
/// double precision. [`FixedNoise`] serves every scalar.
///
/// The noise-adaptation hook (design decision 6): a strategy sees each innovation with
/// `S`, `H`, `P⁻` and `R`, and may rescale `P⁻`, replace `R`, adjust `Q` for the
/// predictions that follow, or reject the measurement. Strategies keep their windows per
/// measurement [`StreamId`]. [`FixedNoise`], the zero-sized default, does none of it.
pub trait NoiseStrategy<T: FilterScalar = f64>: Clone {
    /// Short name (`"fixed"`, `"iae"` …) for logs and the command line. Default: the
    /// type's name without its module path.
    fn name(&self) -> &'static str {
        crate::stream::short_type_name::<Self>()
    }

    /// Decide on one measurement.
    fn adapt<N: DimName, M: DimName>(&mut self, a: &mut Adaptation<'_, N, M, T>)
    where
        DefaultAllocator: FilterAlloc<N, M>;

    /// Factor `λ` on `Φ P Φᵀ` in every prediction, `P⁻ = λ Φ P Φᵀ + Q_d` (a fading-memory
    /// filter). Default 1.
    #[inline]
    fn prediction_fading(&self) -> f64 {
        1.0
    }

    /// Whether the filter should accumulate the process noise added since the previous
    /// update, `Q_Σ`, and pass `H Q_Σ Hᵀ` in [`Adaptation::HQHt`] (it costs a second
    /// covariance propagation per prediction). Default `false`.
    #[inline]
    fn tracks_process_noise(&self) -> bool {
        false
    }

    /// Called after an accepted or inflated update with the gain used.
    fn after_update<N: DimName, M: DimName>(&mut self, _p: &mut PostUpdate<'_, N, M, T>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
    }
}

/// The standard Kalman filter: nominal `Q` and `R`, every measurement accepted.
/// Zero-sized; the default strategy of every filter.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FixedNoise;

impl FixedNoise {
    /// `"fixed"` (the strategy serves every scalar, so this spares callers naming one).
    pub fn name(&self) -> &'static str {
        "fixed"
    }
}

impl<T: FilterScalar> NoiseStrategy<T> for FixedNoise {
    fn name(&self) -> &'static str {
        "fixed"
    }

    #[inline]
    fn adapt<N: DimName, M: DimName>(&mut self, _a: &mut Adaptation<'_, N, M, T>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
    }
}

/// Rejects a measurement whose NIS (with the nominal `S`) exceeds a fixed threshold; the
/// filter is otherwise the standard one. The threshold is the caller's χ² quantile for the
/// measurement's dimension (e.g. 16.81: 6 degrees of freedom at 99 %), so the gate needs
/// neither statrs nor the heap: the outlier gate of a `no_std` filter, over any scalar
/// (`adaptive`'s `ChiSquareGate` computes its quantiles, and needs `std`).
///
/// ```
/// use estimator_core::linear::LinearMeasurement;
/// use estimator_core::{ErrorStateFilter, NisGate, Verdict};
/// use nalgebra::{Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};
///
/// let gate = NisGate { threshold: 6.63 }; // χ²(1) at 99 %
/// let mut f = ErrorStateFilter::new(Vector2::zeros(), Matrix2::identity(), gate).unwrap();
/// let h = LinearMeasurement::<1, 2>::new(Matrix1x2::new(1.0, 0.0));
/// assert_eq!(f.update(&h, &Vector1::new(0.5), &Matrix1::new(1.0)).unwrap().verdict, Verdict::Accepted);
/// assert_eq!(f.update(&h, &Vector1::new(50.0), &Matrix1::new(1.0)).unwrap().verdict, Verdict::Rejected);
/// ```
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NisGate {
    /// Largest NIS accepted.
    pub threshold: f64,
}

impl NisGate {
    /// `"nis-gate"` (the strategy serves every scalar, so this spares callers naming one).
    pub fn name(&self) -> &'static str {
        "nis-gate"
    }
}

impl<T: FilterScalar> NoiseStrategy<T> for NisGate {
    fn name(&self) -> &'static str {
        "nis-gate"
    }

    #[inline]
    fn adapt<N: DimName, M: DimName>(&mut self, a: &mut Adaptation<'_, N, M, T>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        // (a NaN NIS is refused too)
        if a.nis.is_nan() || a.nis > self.threshold {
            a.verdict = Verdict::Rejected;
            a.reason = "NIS above the gate";
        }
    }
}
