//! A gross-error gate in front of any strategy.

use estimator_core::consistency::{chi2_gate, chi2_quantile};
use estimator_core::{
    Adaptation, FilterAlloc, NoiseStrategy, PostUpdate, PriorScaling, StreamMap, Verdict,
};
use nalgebra::{DefaultAllocator, DimName, OVector};

mod chi_square;
mod learn;
mod scale;
mod stream;

pub use chi_square::*;
use learn::*;
pub use learn::{CORRELATED, LEARN_WINDOW, TRUST, TRUST_DOWN, WHITE_LAG};
use scale::*;
use stream::*;

/// Largest measurement dimension whose gate threshold is cached (larger ones are computed
/// at every update).
const CACHED_DIMS: usize = 16;

/// `χ²_{1−p}(m)` for every measurement dimension, computed once per dimension (the
/// quantile is an iterative inverse of the χ² distribution).
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Debug)]
struct Thresholds([f64; CACHED_DIMS + 1]);

impl Default for Thresholds {
    fn default() -> Self {
        Self::new()
    }
}

impl Thresholds {
    fn new() -> Self {
        Self([f64::NAN; CACHED_DIMS + 1])
    }

    fn get(&mut self, m: usize, probability: f64) -> f64 {
        match self.0.get_mut(m) {
            Some(t) => {
                if t.is_nan() {
                    *t = chi2_gate(m, probability);
                }
                *t
            }
            None => chi2_gate(m, probability),
        }
    }
}

/// What the gate does with a stream whose innovations are all larger than its `S`
/// says, not just one of them.
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum GateMode {
    /// Adapt before refusing (the default): the stream's `R` is inflated by a robust
    /// covariance-matching factor when its recent innovations are, as a whole, too large
    /// for their white noise, and the prior is doubted when they keep pointing the same
    /// way (a wrong state); only what stays beyond the gate after that is refused. See
    /// [`GrossErrorGate`].
    #[default]
    Adapt,
    /// Refuse everything beyond the gate, re-admitting one measurement after
    /// `readmit_after` refusals in a row (the behaviour before adaptation existed).
    Refuse,
}

/// Innovations the adaptive gate remembers per stream.
pub const GATE_WINDOW: usize = 10;

/// Largest measurement dimension whose whitened innovation the adaptive gate keeps (larger
/// streams are gated without the direction test).
pub(crate) const WHITE_DIMS: usize = 16;

/// Probability that a consistent stream is judged too noisy in one window (the
/// order-statistic test below).
const SCALE_FALSE_ALARM: f64 = 1e-3;

/// Cosine between successive whitened innovations above which every one of the last
/// few pairs (as many as `same_way_pairs` asks) must lie for them to be taken as
/// pointing the same way (a state error, not noise or gross errors): two independent
/// directions in the plane exceed it with probability 0.14, in three dimensions 0.05,
/// in six 0.003.
const SAME_WAY_COS: f64 = 0.9;

/// Mean cosine over the window below which the innovations are taken for white noise
/// (whose `R` may be matched); once the state is doubted, it stays doubted until the
/// window's mean cosine falls below it.
const WHITE_COS: f64 = 0.5;

/// How close successive whitened innovations must lie for the direction test to take
/// them for one state error: `|wᵢ − wᵢ₋₁|² ≤ (AGREE_FRACTION |wᵢ|)² + AGREE_NOISE m`. A
/// state error moves little between two fixes, so its innovations differ by the fixes'
/// noise (a difference of two white innovations has `E|Δ|² = 2m`) and by its own slow
/// change; gross errors of one size at random bearings (1 km at any bearing on a 5 m fix:
/// `|w|` ≈ 200) pass the cosine test one pair in seven in the plane, and this one one in
/// thirteen.
const AGREE_FRACTION: f64 = 0.25;
/// See [`AGREE_FRACTION`].
const AGREE_NOISE: f64 = 8.0;

/// The fewest successive pairs that must agree ([`AGREE_FRACTION`]) before a stream's
/// state is doubted, whatever the dimension: eight innovations beyond the gate in a row,
/// each close to the one before. A state error shows in every fix, so it passes as soon
/// as it is large; gross errors at random bearings pass one pair in thirteen, seven in a
/// row about once in 10⁸ (with four pairs, one seed in ten of navego with half of its
/// fixes 1 km off was pulled away, `benches/campaign.py`).
const MIN_AGREE_PAIRS: usize = 7;

/// How far beyond the gate (at the scale a window's lower quartile shows) an innovation
/// must be to be left out of the scale test as a gross error: 1 km on a 5 m fix is about
/// 1,000 gates away; RTK fixes with 5× their σ at most 5 (the simulated drive of
/// `the_default_gate_adapts_before_it_refuses`, whose matching a factor of 1 delayed from
/// the 4th to the 8th fix: 0.330 → 1.115 m).
const GROSS_BEYOND: f64 = 10.0;

/// The reason of an update whose noise the gate learned from the stream's residuals (and
/// nothing else changed): its adapted NIS is the one at the learned noise.
pub const LEARNED_REASON: &str = "gate: R learned from the stream's residuals";

/// Upper bound on the `R` factor (σ × 100).
pub const MAX_R_FACTOR: f64 = 1e4;

/// Refuses an innovation far outside anything the filter believes, whatever the strategy
/// behind it, after first asking whether the whole stream, not this innovation, is what
/// is wrong.
///
/// The gate is `χ²_{1−p}(m)` on `NIS = rᵀ S⁻¹ r` (nominal `S`); with `p = 1e-6` (the
/// program's default) a consistent filter refuses one update in a million, and a 1 km
/// error on a 5 m fix is refused at once. Refused innovations never reach the inner
/// strategy (its windows stay free of gross errors).
///
/// In [`GateMode::Adapt`] (the default) every innovation of a stream, refused or not, is
/// remembered for [`GATE_WINDOW`] epochs, and two tests run before the gate:
///
/// - **Noise too small for the stream (covariance matching, robust).** When the `k`-th
///   smallest NIS of the window (`k = max(1, n/2)`, its median) exceeds the level a
///   consistent stream passes with probability 1e-3, the innovations are, as a whole,
///   larger than `S` (matching stays on until the factor falls to 1): the factor
///   `s = NIS_(k) / χ²_{(k−0.3)/(n+0.4)}(m)` (the order statistic over its
///   median-unbiased quantile) estimates `E[r rᵀ] ≈ s S`,
///   and the excess is put on the measurement: `R* = R + (s − 1) S`, so that
///   `S* = s S`. The gate then judges `NIS / s`. A factor beyond [`MAX_R_FACTOR`] (σ
///   more than 100× too small) is not taken for noise, nor is a window whose smallest NIS
///   is more than 10× below `s χ²_{1e-3}(m)` (good fixes among gross errors); nor a
///   window whose successive innovations keep their direction on the whole (mean cosine
///   above 0.5): noise is white.
/// - **A wrong state (innovations that keep their direction).** When the innovation is
///   beyond the gate, the last `k + 1` all were, and each of the last `k` pairs of
///   successive whitened innovations (`L⁻¹ r`, `S = L Lᵀ`) has a cosine above 0.9
///   (white noise gives 0 ± `1/√m`; `k` is the fewest pairs that white innovations pass
///   together with probability below 1e-3: 4 for `m = 2`, 3 for `m = 3`, 2 for a
///   position + velocity fix), the filter, not the measurement, is doubted until the
///   window's mean cosine falls below 0.5 (white again): each innovation beyond the
///   gate meanwhile is used
///   with the prior inflated along the measurement subspace so that its NIS equals the
///   gate (`λ = NIS/gate`, as at a re-admission). An initial heading 90° off or a
///   filter come back from an outage is pulled in instead of locked out. The `R` factor
///   is not applied to such a stream.
///
/// Whatever stays beyond the gate is refused; after `readmit_after` refusals in a row the
/// next one is admitted with the prior inflated (`P⁻* = P⁻ + (λ − 1) P⁻Hᵀ(HP⁻Hᵀ)⁻¹HP⁻`,
/// `λ = NIS/gate`, a Huber-like bounded influence), so that nothing can lock a stream
/// out. [`GateMode::Refuse`] skips the two tests (the behaviour before them).
///
/// Decisions: `Rejected` with reason `"gate: NIS beyond the χ² gate"`; `Inflated` with
/// `lambda_r = s` (`"gate: R matched to the stream's innovations"`) or with `lambda_p = λ`
/// (re-admitted, or the state doubted). The factor `dom` reports `NIS / gate`.
///
/// ```
/// use adaptive::GrossErrorGate;
/// use estimator_core::linear::LinearMeasurement;
/// use estimator_core::{ErrorStateFilter, FixedNoise, Verdict};
/// use nalgebra::{Matrix1, Matrix1x2, Matrix2, Vector1, Vector2};
///
/// let gate = GrossErrorGate::new(FixedNoise, 1e-6, 10);
/// let mut f = ErrorStateFilter::new(Vector2::zeros(), Matrix2::identity(), gate).unwrap();
/// let gps = LinearMeasurement::<1, 2>::new(Matrix1x2::new(1.0, 0.0));
/// let r = f.update(&gps, &Vector1::new(1000.0), &Matrix1::new(1.0)).unwrap();
/// assert_eq!(r.verdict, Verdict::Rejected);
/// assert_eq!(f.state()[0], 0.0);
/// ```
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug)]
pub struct GrossErrorGate<A> {
    /// The strategy behind the gate.
    pub inner: A,
    /// Probability that a consistent innovation is refused (the gate is the
    /// `1 − probability` quantile of χ²(m)); 0 disables the gate.
    pub probability: f64,
    /// Refusals in a row after which the next gated measurement is admitted
    /// down-weighted.
    pub readmit_after: u32,
    /// Whether a stream is adapted to before it is refused. Default [`GateMode::Adapt`].
    pub mode: GateMode,
    /// Whether, in [`GateMode::Adapt`], each stream's noise is learned from its inliers'
    /// residuals and the declared `R` moved toward it: raised to what white innovations
    /// show, lowered where they show it more than [`TRUST_DOWN`]× too large, kept within
    /// [`TRUST`]× for correlated ones (see [`GrossErrorGate::learned`]). Default true.
    pub learn: bool,
    /// Streams whose noise is never learned (a constraint's tuning, not a sensor's noise).
    unlearned: Vec<estimator_core::StreamId>,
    streams: StreamMap<GateStream>,
    // caches of values computed from the dimension alone: not state, not serialised
    #[cfg_attr(feature = "serde", serde(skip))]
    thresholds: Thresholds,
    #[cfg_attr(feature = "serde", serde(skip))]
    scale_tests: ScaleTests,
    #[cfg_attr(feature = "serde", serde(skip))]
    same_way_pairs: PairCounts,
    /// The last update was decided by the gate, not by `inner`.
    bypassed: bool,
}

// (`clone_from` refills the per-stream state and the caches in place)
clone_in_place!(GrossErrorGate<A> {
    inner,
    probability,
    readmit_after,
    mode,
    learn,
    unlearned,
    streams,
    thresholds,
    scale_tests,
    same_way_pairs,
    bypassed,
});

impl<A: NoiseStrategy> GrossErrorGate<A> {
    /// `inner` behind a gate at `χ²_{1−probability}(m)`, re-admitting after
    /// `readmit_after` refusals in a row.
    pub fn new(inner: A, probability: f64, readmit_after: u32) -> Self {
        Self {
            inner,
            probability,
            readmit_after: readmit_after.max(1),
            mode: GateMode::Adapt,
            learn: true,
            unlearned: Vec::new(),
            streams: StreamMap::new(),
            thresholds: Thresholds::new(),
            scale_tests: ScaleTests(Vec::new()),
            same_way_pairs: PairCounts([0; CACHED_DIMS + 1]),
            bypassed: false,
        }
    }

    /// The program's default gate in front of `inner`: `χ²_{1−10⁻⁶}(m)`, re-admitting after
    /// [`DEFAULT_READMIT_AFTER`] refusals in a row, adapting before it refuses
    /// ([`GateMode::Adapt`]) — what [`Default`] gives with `A`'s default.
    pub fn around(inner: A) -> Self {
        Self::new(inner, DEFAULT_PROBABILITY, DEFAULT_READMIT_AFTER)
    }

    /// `inner` with the gate open (every innovation goes to `inner`): KF-GINS's
    /// behaviour.
    pub fn disabled(inner: A) -> Self {
        Self::new(inner, 0.0, 1)
    }

    /// The same gate in `mode`.
    pub fn with_mode(mut self, mode: GateMode) -> Self {
        self.mode = mode;
        self
    }

    /// The same gate, learning each stream's noise or not ([`learn`](Self::learn)).
    pub fn with_learning(mut self, learn: bool) -> Self {
        self.learn = learn;
        self
    }

    /// The same gate, never learning the noise of `streams` (the vehicle's constraints:
    /// their noise is a tuning, not a sensor's).
    pub fn without_learning_on(mut self, streams: &[estimator_core::StreamId]) -> Self {
        self.unlearned.extend_from_slice(streams);
        self
    }

    /// Per stream seen: its name, the variance factor `λ̂` its inliers show on the
    /// declared `R` (`√λ̂` is the σ factor), the factor applied, and the updates it was
    /// learned from.
    pub fn learned(&self) -> impl Iterator<Item = LearnedNoise> + '_ {
        self.streams.iter().filter(|(id, _)| !self.unlearned.contains(id)).map(|(id, st)| {
            LearnedNoise {
                stream: id.name(),
                factor: st.learned.factor(),
                applied: if self.learn && self.mode == GateMode::Adapt {
                    st.learned.applied()
                } else {
                    1.0
                },
                updates: st.learned.seen(),
                lag_one: st.learned.lag_one(),
            }
        })
    }

    /// Whether the gate refuses anything.
    pub fn is_enabled(&self) -> bool {
        self.probability > 0.0
    }

    /// The gate for an `m`-dimensional innovation.
    pub fn threshold(&mut self, m: usize) -> f64 {
        self.thresholds.get(m, self.probability)
    }
}

/// The gate's default probability that a consistent innovation is refused (the program's
/// `filter.gate.probability`).
pub const DEFAULT_PROBABILITY: f64 = 1e-6;

/// The gate's default count of refusals in a row before a re-admission (the program's
/// `filter.gate.readmit_after`).
pub const DEFAULT_READMIT_AFTER: u32 = 20;

/// [`GrossErrorGate::around`] the inner strategy's default: the documented values.
impl<A: NoiseStrategy + Default> Default for GrossErrorGate<A> {
    fn default() -> Self {
        Self::around(A::default())
    }
}

impl<A: NoiseStrategy> NoiseStrategy for GrossErrorGate<A> {
    /// The inner strategy's name.
    fn name(&self) -> &'static str {
        self.inner.name()
    }

    fn adapt<N: DimName, M: DimName>(&mut self, a: &mut Adaptation<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        self.bypassed = false;
        if !self.is_enabled() {
            return self.inner.adapt(a);
        }
        if !self.learn
            || self.mode != GateMode::Adapt
            || a.nis.is_nan()
            || self.unlearned.contains(&a.stream)
        {
            return self.decide(a);
        }
        let c = self.streams.get_or_insert_with(a.stream, GateStream::new).learned.applied();
        if c == 1.0 {
            self.decide(a);
            self.learn_from(a.stream, a.innovation, a.HPHt, a.R_nominal, 1.0);
            return;
        }
        // the learned noise stands for the declared one: the gate judges against it
        let r_learned = a.R_nominal * c;
        let s_learned = a.HPHt + &r_learned;
        let Some(chol) = s_learned.clone().cholesky() else {
            return self.decide(a);
        };
        let nis = a.innovation.dot(&chol.solve(a.innovation));
        on_noise(a, &r_learned, &s_learned, nis, c, LEARNED_REASON, |b| self.decide(b));
        self.learn_from(a.stream, a.innovation, a.HPHt, &r_learned, c);
    }

    fn prediction_fading(&self) -> f64 {
        self.inner.prediction_fading()
    }

    fn tracks_process_noise(&self) -> bool {
        self.inner.tracks_process_noise()
    }

    fn after_update<N: DimName, M: DimName>(&mut self, p: &mut PostUpdate<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        // a gross error the gate re-admitted is not the inner strategy's to learn from
        if !self.bypassed {
            self.inner.after_update(p)
        }
    }
}

/// What a stream's inliers show of its noise ([`GrossErrorGate::learned`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LearnedNoise {
    /// The stream's name.
    pub stream: &'static str,
    /// `λ̂`: the variance factor the stream's residuals show on its declared `R` (its
    /// square root is the σ factor).
    pub factor: f64,
    /// The factor applied on the declared `R` (1: the declared noise was kept).
    pub applied: f64,
    /// Updates it was learned from.
    pub updates: u64,
    /// The lag-one autocorrelation of its whitened innovations (0 for white ones).
    pub lag_one: f64,
}

impl<A: NoiseStrategy> GrossErrorGate<A> {
    /// Feed a stream's learner with an update judged at the applied noise `R = c R₀`
    /// (an inlier at that noise only: the gate's decision on it was not a refusal, a
    /// re-admission or a doubted state).
    fn learn_from<M: DimName>(
        &mut self,
        stream: estimator_core::StreamId,
        r: &OVector<f64, M>,
        hpht: &nalgebra::OMatrix<f64, M, M>,
        applied_r: &nalgebra::OMatrix<f64, M, M>,
        c: f64,
    ) where
        DefaultAllocator: nalgebra::allocator::Allocator<M, M> + nalgebra::allocator::Allocator<M>,
    {
        let bypassed = self.bypassed;
        let st = self.streams.get_or_insert_with(stream, GateStream::new);
        let before = core::mem::replace(&mut st.learned_before, false);
        if bypassed || st.doubting {
            return;
        }
        // q at the learned noise, not the applied one: the applied one stays above it by
        // up to TRUST, and q at a noise above the stream's is biased up by the prior
        let l = st.learned.factor().clamp(1.0 / MAX_R_FACTOR, MAX_R_FACTOR);
        let r_l = applied_r * (l / c);
        let s_l = hpht + &r_l;
        if let Some(q) = residual_factor(r, hpht, &s_l, &r_l, l) {
            let pair = if before { Some(st.last_pair) } else { None };
            st.learned.push(q, pair);
            st.learned_before = true;
        }
    }

    /// The gate's decision on one innovation at the noise `a` declares (see the type's
    /// documentation).
    fn decide<N: DimName, M: DimName>(&mut self, a: &mut Adaptation<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        let m = M::DIM;
        let gate = self.threshold(m);
        let adapt = self.mode == GateMode::Adapt;
        let st = self.streams.get_or_insert_with(a.stream, GateStream::new);
        if a.nis.is_nan() {
            st.refusals = 0;
            return self.inner.adapt(a);
        }
        let (mut scale, mut same_way) = (1.0, false);
        if adapt {
            let mut buf = [0.0; WHITE_DIMS];
            let white = whiten(a.S, a.innovation, &mut buf);
            st.push(a.nis, white);
            // a wrong state: entered when the last pairs all keep their direction and were
            // all beyond the gate, kept until the window's innovations look white again
            // (the pairs must also lie close: gross errors of one size at random bearings
            // keep their direction by chance, never their place)
            st.doubting = if st.doubting {
                st.mean_cos() > WHITE_COS
            } else {
                let pairs = self.same_way_pairs.get(m);
                let close = pairs.max(MIN_AGREE_PAIRS);
                st.same_way(pairs) > SAME_WAY_COS
                    && st.agree(close)
                    && st.all_beyond(close + 1, gate)
            };
            // while doubted, an innovation beyond the gate is used only when it lies close
            // to the one before (a gross error among the state's innovations is refused)
            same_way = st.doubting && st.agree(1);
            let n = st.filled;
            // noise is white: a window whose innovations keep their direction on the whole
            // is a state error, whatever its size
            // the window less its gross errors: those far beyond the gate even at the
            // scale its lower quartile shows (a noisy stream keeps its window; a good one
            // among gross errors keeps its good fixes, whose median then stays where it
            // belongs instead of on the largest of them). "Far": GROSS_BEYOND × the gate,
            // as a window's lower quartile of three or four innovations may sit well
            // below the stream's scale
            let kept = if n >= MIN_WINDOW {
                let full = self.scale_tests.get(m, n);
                let low = (st.order_statistic(full.low_k) / full.low_reference).max(1.0);
                st.count_below(GROSS_BEYOND * gate * low)
            } else {
                0
            };
            if kept >= MIN_WINDOW && !st.doubting && st.mean_cos() < WHITE_COS {
                let test = self.scale_tests.get(m, kept);
                // (the k-th smallest of the kept is the window's k-th smallest)
                let x = st.order_statistic(test.k);
                let s = x / test.reference;
                // switched on by the test, off when the window looks consistent again
                st.matching = if st.matching { s > 1.0 } else { x > test.detect };
                // beyond the bound the stream is not noisier than it says but wrong; and a
                // window that also holds innovations the nominal noise explains is gross
                // errors among good fixes, not a noisy stream
                let plausible = s <= MAX_R_FACTOR && st.smallest() * 10.0 >= s * test.floor;
                if st.matching && plausible {
                    scale = s.max(1.0);
                }
            } else {
                st.matching = false;
            }
        }
        if a.nis <= gate * scale {
            st.refusals = 0;
            if scale > 1.0 {
                adapt_matched(&mut self.inner, a, scale);
            } else {
                self.inner.adapt(a);
            }
            return;
        }
        self.bypassed = true;
        a.factors.dom = a.nis / gate;
        if same_way {
            st.refusals = 0;
            doubt_prior(a, gate, "gate: innovations keep their direction, the state is doubted");
            return;
        }
        // (re-admitted only when it lies close to the refused innovation before it, as a
        // state error's do: a stream of gross errors never is)
        if st.refusals < self.readmit_after || (adapt && !st.agree(1)) {
            st.refusals += 1;
            a.verdict = Verdict::Rejected;
            a.reason = "gate: NIS beyond the χ² gate";
            return;
        }
        st.refusals = 0;
        doubt_prior(a, gate, "gate: re-admitted after refusals in a row, prior inflated");
    }
}

/// The inner strategy's decision on a stream whose `R` the gate matched by `scale`: it
/// sees the matched noise as the stream's declared one, `R' = R + (s − 1) S` (so that
/// `S' = s S` and its NIS is `NIS / s`), and adapts from there. A strategy behind the gate
/// thus adapts to what the matched noise leaves unexplained instead of reading the
/// stream's noise a second time (a fading strategy would otherwise take noise the gate
/// has matched for a prior too confident). With [`FixedNoise`](estimator_core::FixedNoise)
/// the result is the matched `R` itself.
fn adapt_matched<A: NoiseStrategy, N: DimName, M: DimName>(
    inner: &mut A,
    a: &mut Adaptation<'_, N, M>,
    scale: f64,
) where
    DefaultAllocator: FilterAlloc<N, M>,
{
    // R' = R + (s − 1) S: S' = s S
    let r_matched = a.R_nominal + a.S * (scale - 1.0);
    let s_matched = a.S * scale;
    let nis = a.nis / scale;
    on_noise(
        a,
        &r_matched,
        &s_matched,
        nis,
        scale,
        "gate: R matched to the stream's innovations",
        |b| inner.adapt(b),
    );
}

/// `decide` on `a` as if its declared noise were `r` (`S = s`, NIS `nis`), the outcome
/// copied back into `a` with `factor` on its `R` factor (the declared `R` the noise stands
/// for) and, unless refused, the verdict `Inflated` with `why` where `decide` gave none
/// (the filter tells a noise below the declared one apart, as `Deflated`).
fn on_noise<N: DimName, M: DimName>(
    a: &mut Adaptation<'_, N, M>,
    r: &nalgebra::OMatrix<f64, M, M>,
    s: &nalgebra::OMatrix<f64, M, M>,
    nis: f64,
    factor: f64,
    why: &'static str,
    decide: impl FnOnce(&mut Adaptation<'_, N, M>),
) where
    DefaultAllocator: FilterAlloc<N, M>,
{
    let mut b = Adaptation {
        stream: a.stream,
        epoch: a.epoch,
        time: a.time,
        innovation: a.innovation,
        H: a.H,
        P_prior: a.P_prior,
        HPHt: a.HPHt,
        HQHt: a.HQHt,
        R_nominal: r,
        S: s,
        nis,
        prior_scale: a.prior_scale,
        prior_scaling: a.prior_scaling,
        scale_propagated_only: a.scale_propagated_only,
        R: r.clone(),
        verdict: a.verdict,
        reason: a.reason,
        factors: a.factors,
        q: estimator_core::QAdjust::Keep,
        not_helping: a.not_helping,
    };
    decide(&mut b);
    a.prior_scale = b.prior_scale;
    a.prior_scaling = b.prior_scaling;
    a.scale_propagated_only = b.scale_propagated_only;
    a.factors = b.factors;
    a.q = b.q;
    a.not_helping = b.not_helping;
    a.verdict = b.verdict;
    a.reason = b.reason;
    a.R = b.R;
    if a.verdict != Verdict::Rejected {
        a.factors.lambda_r *= factor;
        if a.reason.is_empty() || a.verdict == Verdict::Accepted {
            a.reason = why;
        }
        a.verdict = Verdict::Inflated;
    }
}

/// Use the measurement with the prior inflated along the measurement subspace so that its
/// NIS equals the gate: `P⁻* = P⁻ + (λ − 1) P⁻Hᵀ(HP⁻Hᵀ)⁻¹HP⁻`, `λ = NIS/gate`.
fn doubt_prior<N: DimName, M: DimName>(a: &mut Adaptation<'_, N, M>, gate: f64, why: &'static str)
where
    DefaultAllocator: FilterAlloc<N, M>,
{
    let k = a.nis / gate;
    a.prior_scale = k;
    a.prior_scaling = PriorScaling::MeasurementSubspace;
    a.factors.lambda_p = k;
    a.verdict = Verdict::Inflated;
    a.reason = why;
}

/// `L⁻¹ r` with `S = L Lᵀ`, in `buf`; `None` when `S` is not positive definite or the
/// dimension is beyond [`WHITE_DIMS`].
pub(crate) fn whiten<'b, M: DimName>(
    s: &nalgebra::OMatrix<f64, M, M>,
    r: &OVector<f64, M>,
    buf: &'b mut [f64; WHITE_DIMS],
) -> Option<&'b [f64]>
where
    DefaultAllocator: nalgebra::allocator::Allocator<M, M> + nalgebra::allocator::Allocator<M>,
{
    let m = M::DIM;
    if m > WHITE_DIMS {
        return None;
    }
    // forward substitution on the Cholesky factor, computed in place of a copy of S
    let chol = s.clone().cholesky()?;
    let l = chol.l_dirty();
    for i in 0..m {
        let mut v = r[i];
        for j in 0..i {
            v -= l[(i, j)] * buf[j];
        }
        buf[i] = v / l[(i, i)];
    }
    Some(&buf[..m])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cosine_tail_matches_its_closed_forms() {
        // m = 3: the cosine is uniform on [−1, 1]; m = 2: the angle is uniform
        assert!((cosine_tail(3, 0.9) - 0.05).abs() < 1e-6);
        assert!((cosine_tail(2, 0.9) - 0.9_f64.acos() / std::f64::consts::PI).abs() < 1e-3);
        // m = 5: density ∝ 1 − x², tail (2/3 − c + c³/3) / (4/3)
        let c: f64 = 0.9;
        assert!((cosine_tail(5, c) - (2.0 / 3.0 - c + c.powi(3) / 3.0) * 0.75).abs() < 1e-6);
    }

    #[test]
    fn the_direction_test_needs_fewer_pairs_in_more_dimensions() {
        let k: Vec<usize> = [1, 2, 3, 6, 9].iter().map(|&m| same_way_pairs(m)).collect();
        assert_eq!(k, [9, 4, 3, 2, 1]);
        for (m, k) in [(2, 4), (3, 3), (6, 2)] {
            assert!(cosine_tail(m, SAME_WAY_COS).powi(k) <= SCALE_FALSE_ALARM);
            assert!(cosine_tail(m, SAME_WAY_COS).powi(k - 1) > SCALE_FALSE_ALARM);
        }
    }
}
