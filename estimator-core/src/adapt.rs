//! The noise-adaptation hook (design decision 6): a strategy sees each innovation with
//! `S`, `H`, `P⁻` and `R`, and may rescale `P⁻`, replace `R`, adjust `Q` for the
//! predictions that follow, or reject the measurement. Strategies keep their windows per
//! measurement [`StreamId`]. [`FixedNoise`], the zero-sized default, does none of it.

use core::marker::PhantomData;

use nalgebra::{DefaultAllocator, DimName, OMatrix, OVector};

use manifolds::DimAlloc;

use crate::kernels::Entries;
use crate::traits::{Cov, FilterAlloc};

/// Read access to an `N × N` covariance where its back-end keeps it, without copying it:
/// entries, contiguous columns, or a static copy on demand
/// ([`to_matrix`](Self::to_matrix)). A dense back-end at 120 states would otherwise copy
/// 115 KB for every update that a strategy might look at.
#[derive(Clone, Copy)]
pub struct CovView<'a, N> {
    p: &'a dyn Entries,
    _n: PhantomData<N>,
}

impl<'a, N: DimName> CovView<'a, N>
where
    DefaultAllocator: DimAlloc<N>,
{
    /// A view of `p`, which must be `N × N`.
    pub fn new(p: &'a dyn Entries) -> Self {
        Self { p, _n: PhantomData }
    }

    /// Entry `(r, c)`.
    pub fn at(&self, r: usize, c: usize) -> f64 {
        self.p.at(r, c)
    }

    /// Column `c`.
    pub fn column(&self, c: usize) -> &'a [f64] {
        self.p.col(c)
    }

    /// A copy as a static matrix.
    pub fn to_matrix(&self) -> Cov<N> {
        Cov::<N>::from_fn(|r, c| self.p.at(r, c))
    }
}

impl<N: DimName> core::fmt::Debug for CovView<'_, N>
where
    DefaultAllocator: DimAlloc<N>,
{
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "CovView({0}×{0})", N::DIM)
    }
}

/// Identifies a measurement stream (GNSS position, GNSS velocity, magnetometer …).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct StreamId(pub u64);

const fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut i = 0;
    while i < bytes.len() {
        h ^= bytes[i] as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
        i += 1;
    }
    h
}

impl StreamId {
    /// A stream named by a string (FNV-1a hash, usable in `const`).
    pub const fn named(name: &str) -> Self {
        Self(fnv1a(name.as_bytes()))
    }

    /// The default stream of a model type (hash of its type name).
    pub fn of<T: ?Sized>() -> Self {
        Self(fnv1a(core::any::type_name::<T>().as_bytes()))
    }
}

/// Per-stream state of a strategy: a small vector searched linearly (a filter has a
/// handful of streams). Allocates only when a new stream first appears.
#[derive(Clone, Debug, Default)]
pub struct StreamMap<T> {
    entries: Vec<(StreamId, T)>,
}

impl<T> StreamMap<T> {
    /// An empty map.
    pub fn new() -> Self {
        Self { entries: Vec::new() }
    }

    /// The entry of `id`, created with `make` on first use.
    pub fn get_or_insert_with(&mut self, id: StreamId, make: impl FnOnce() -> T) -> &mut T {
        let i = match self.entries.iter().position(|(k, _)| *k == id) {
            Some(i) => i,
            None => {
                self.entries.push((id, make()));
                self.entries.len() - 1
            }
        };
        &mut self.entries[i].1
    }

    /// The entry of `id`, if any.
    pub fn get(&self, id: StreamId) -> Option<&T> {
        self.entries.iter().find(|(k, _)| *k == id).map(|(_, v)| v)
    }

    /// Number of streams seen.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True before any stream was seen.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

/// What happened to a measurement.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Verdict {
    /// Used with the nominal noise.
    Accepted,
    /// Used with inflated / adapted noise or a scaled prior.
    Inflated,
    /// Not used; state and covariance unchanged.
    Rejected,
}

impl Verdict {
    /// Lower-case name for logs and CSV files.
    pub fn as_str(&self) -> &'static str {
        match self {
            Verdict::Accepted => "accepted",
            Verdict::Inflated => "inflated",
            Verdict::Rejected => "rejected",
        }
    }
}

/// The numbers behind a decision (NaN where a strategy does not compute one).
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
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum PriorScaling {
    /// Along the measurement subspace only:
    /// `P⁻* = P⁻ + (λ − 1) P⁻Hᵀ (H P⁻ Hᵀ)⁻¹ H P⁻` (default). `H P⁻* = λ H P⁻`, so the gain
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
pub enum QAdjust<N: DimName>
where
    DefaultAllocator: nalgebra::allocator::Allocator<N, N>,
{
    /// Leave `Q` as it is.
    Keep,
    /// Use the model's `Q_d` times this factor.
    Scale(f64),
    /// Add `rate · dt` to the model's `Q_d` (an extra covariance per second; the model's
    /// `Q_d` stays as a floor, so `P` stays positive definite).
    AddRate(Cov<N>),
    /// Back to the model's `Q_d`.
    Model,
}

/// One decision: inputs the strategy reads, outputs it may change.
///
/// On entry the outputs hold the nominal values (`prior_scale = 1`, `R = R_nominal`,
/// `verdict = Accepted`). The filter then scales `P⁻` as `prior_scaling` says, uses `R`,
/// or skips the update when `verdict = Rejected`.
#[allow(non_snake_case)]
pub struct Adaptation<'a, N: DimName, M: DimName>
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
    pub innovation: &'a OVector<f64, M>,
    /// Measurement Jacobian.
    pub H: &'a OMatrix<f64, M, N>,
    /// Predicted covariance `P⁻`, read in place.
    pub P_prior: CovView<'a, N>,
    /// `H P⁻ Hᵀ`.
    pub HPHt: &'a OMatrix<f64, M, M>,
    /// The measurement noise the caller gave.
    pub R_nominal: &'a OMatrix<f64, M, M>,
    /// Nominal innovation covariance `S = H P⁻ Hᵀ + R_nominal`.
    pub S: &'a OMatrix<f64, M, M>,
    /// `NIS = rᵀ S⁻¹ r` with the nominal `S`.
    pub nis: f64,
    /// Output: factor on `P⁻` (≥ 1 inflates).
    pub prior_scale: f64,
    /// Output: how `prior_scale` is applied.
    pub prior_scaling: PriorScaling,
    /// Output: the `R` to use (symmetric positive definite; the filter checks).
    pub R: OMatrix<f64, M, M>,
    /// Output: the verdict.
    pub verdict: Verdict,
    /// Output: why (shown in reports and logs).
    pub reason: &'static str,
    /// Output: the factors behind the decision.
    pub factors: Factors,
    /// Output: process-noise change for the following predictions.
    pub q: QAdjust<N>,
}

/// After a successful update: the gain, for strategies that adapt `Q` from it.
#[allow(non_snake_case)]
pub struct PostUpdate<'a, N: DimName, M: DimName>
where
    DefaultAllocator: FilterAlloc<N, M>,
{
    /// Stream of the measurement.
    pub stream: StreamId,
    /// Filter time in seconds.
    pub time: f64,
    /// The gain actually used.
    pub K: &'a OMatrix<f64, N, M>,
    /// The innovation.
    pub innovation: &'a OVector<f64, M>,
    /// Output: process-noise change for the following predictions.
    pub q: QAdjust<N>,
}

/// A noise-adaptation strategy. One method is required; the post-update hook defaults
/// to doing nothing.
///
/// Contract: whatever the innovations, the `R` a strategy leaves in
/// [`Adaptation::R`] is symmetric positive definite and finite and `prior_scale` is
/// finite and positive; the filter verifies both and fails the update with a typed error
/// (leaving itself unchanged) if not.
pub trait NoiseStrategy {
    /// Short name (`"fixed"`, `"iae"` …) for logs and the command line.
    fn name(&self) -> &'static str;

    /// Decide on one measurement.
    fn adapt<N: DimName, M: DimName>(&mut self, a: &mut Adaptation<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>;

    /// Factor `λ` on `Φ P Φᵀ` in every prediction, `P⁻ = λ Φ P Φᵀ + Q_d` (a fading-memory
    /// filter). Default 1.
    #[inline]
    fn prediction_fading(&self) -> f64 {
        1.0
    }

    /// Called after an accepted or inflated update with the gain used.
    fn after_update<N: DimName, M: DimName>(&mut self, _p: &mut PostUpdate<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
    }
}

/// The standard Kalman filter: nominal `Q` and `R`, every measurement accepted.
/// Zero-sized; the default strategy of every filter.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FixedNoise;

impl NoiseStrategy for FixedNoise {
    fn name(&self) -> &'static str {
        "fixed"
    }

    #[inline]
    fn adapt<N: DimName, M: DimName>(&mut self, _a: &mut Adaptation<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
    }
}
