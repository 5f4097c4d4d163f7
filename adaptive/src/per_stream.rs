//! Different strategies on different measurement streams of one filter.

use estimator_core::{Adaptation, FilterAlloc, NoiseStrategy, PostUpdate, StreamId};
use nalgebra::{DefaultAllocator, DimName};

/// Strategy `A` on one stream, `B` on every other: compose by type, nest for more
/// streams. The prediction fading is the larger of the two (only a fading strategy has
/// one above 1).
///
/// ```
/// use adaptive::{FusedDualWindow, Route};
/// use estimator_core::{FixedNoise, NoiseStrategy, StreamId};
///
/// // Robust on GNSS position, the plain filter on a compass and anything else.
/// let s = Route::new(StreamId::named("gnss-position"), FusedDualWindow::default(), FixedNoise);
/// assert_eq!(s.name(), "per-stream");
/// ```
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Clone, Debug)]
pub struct Route<A, B> {
    /// The stream that gets `on`.
    pub stream: StreamId,
    /// The strategy of that stream.
    pub on: A,
    /// The strategy of every other stream.
    pub otherwise: B,
}

impl<A: NoiseStrategy, B: NoiseStrategy> Route<A, B> {
    /// `on` for `stream`, `otherwise` for the rest.
    pub fn new(stream: StreamId, on: A, otherwise: B) -> Self {
        Self { stream, on, otherwise }
    }
}

impl<A: NoiseStrategy, B: NoiseStrategy> NoiseStrategy for Route<A, B> {
    fn name(&self) -> &'static str {
        "per-stream"
    }

    fn adapt<N: DimName, M: DimName>(&mut self, a: &mut Adaptation<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        if a.stream == self.stream {
            self.on.adapt(a)
        } else {
            self.otherwise.adapt(a)
        }
    }

    fn prediction_fading(&self) -> f64 {
        self.on.prediction_fading().max(self.otherwise.prediction_fading())
    }

    fn tracks_process_noise(&self) -> bool {
        self.on.tracks_process_noise() || self.otherwise.tracks_process_noise()
    }

    fn after_update<N: DimName, M: DimName>(&mut self, p: &mut PostUpdate<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        if p.stream == self.stream {
            self.on.after_update(p)
        } else {
            self.otherwise.after_update(p)
        }
    }
}

/// One strategy type per stream, chosen at run time: a default and any number of
/// `(stream, strategy)` overrides, for configurations (`PerStream<AnyStrategy>`, built
/// from names). The prediction fading is the largest of all.
///
/// ```
/// use adaptive::{AnyStrategy, PerStream};
/// use estimator_core::{NoiseStrategy, StreamId};
///
/// let s = PerStream::new("fixed".parse::<AnyStrategy>().unwrap())
///     .with(StreamId::named("gnss-position"), "fused".parse().unwrap());
/// assert_eq!(s.strategy_of(StreamId::named("gnss-position")).name(), "fused");
/// assert_eq!(s.strategy_of(StreamId::named("compass")).name(), "fixed");
/// ```
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[derive(Debug)]
pub struct PerStream<A> {
    default: A,
    streams: Vec<(StreamId, A)>,
}

/// `clone_from` refills the strategies in place (see [`GrossErrorGate`](crate::GrossErrorGate)'s).
impl<A: Clone> Clone for PerStream<A> {
    fn clone(&self) -> Self {
        Self { default: self.default.clone(), streams: self.streams.clone() }
    }

    fn clone_from(&mut self, source: &Self) {
        self.default.clone_from(&source.default);
        estimator_core::__private::clone_entries_from(&mut self.streams, &source.streams);
    }
}

impl<A: NoiseStrategy> PerStream<A> {
    /// `default` on every stream.
    pub fn new(default: A) -> Self {
        Self { default, streams: Vec::new() }
    }

    /// `strategy` on `stream` (replacing an earlier choice for it).
    pub fn with(mut self, stream: StreamId, strategy: A) -> Self {
        self.streams.retain(|(s, _)| *s != stream);
        self.streams.push((stream, strategy));
        self
    }

    /// The strategy that `stream` gets.
    pub fn strategy_of(&self, stream: StreamId) -> &A {
        self.streams.iter().find(|(s, _)| *s == stream).map(|(_, a)| a).unwrap_or(&self.default)
    }

    /// The default strategy.
    pub fn default_strategy(&self) -> &A {
        &self.default
    }

    /// The streams with their own strategy.
    pub fn overrides(&self) -> impl Iterator<Item = (StreamId, &A)> {
        self.streams.iter().map(|(s, a)| (*s, a))
    }

    fn get_mut(&mut self, stream: StreamId) -> &mut A {
        match self.streams.iter().position(|(s, _)| *s == stream) {
            Some(i) => &mut self.streams[i].1,
            None => &mut self.default,
        }
    }
}

impl<A: NoiseStrategy> NoiseStrategy for PerStream<A> {
    /// The default strategy's name when no stream has its own, else `"per-stream"`.
    fn name(&self) -> &'static str {
        if self.streams.is_empty() {
            self.default.name()
        } else {
            "per-stream"
        }
    }

    fn adapt<N: DimName, M: DimName>(&mut self, a: &mut Adaptation<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        self.get_mut(a.stream).adapt(a)
    }

    fn prediction_fading(&self) -> f64 {
        self.streams
            .iter()
            .map(|(_, a)| a.prediction_fading())
            .fold(self.default.prediction_fading(), f64::max)
    }

    fn tracks_process_noise(&self) -> bool {
        self.default.tracks_process_noise()
            || self.streams.iter().any(|(_, a)| a.tracks_process_noise())
    }

    fn after_update<N: DimName, M: DimName>(&mut self, p: &mut PostUpdate<'_, N, M>)
    where
        DefaultAllocator: FilterAlloc<N, M>,
    {
        self.get_mut(p.stream).after_update(p)
    }
}
