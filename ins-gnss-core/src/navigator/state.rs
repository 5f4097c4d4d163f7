//! The navigation states a [`Navigator`] runs (15 and 21 states, loosely or tightly
//! coupled) and how the 15-state measurement models apply to each.

use super::*;

/// A navigation state the [`Navigator`] runs: the 15-state [`InsState`] or the 21-state
/// [`InsState21`]. Measurement models are written once, for [`InsState`]; each state
/// applies them its own way.
pub trait NavState: Manifold + Clone + core::fmt::Debug
where
    DefaultAllocator: DimAlloc<Self::Dim>,
{
    /// The process model.
    type Model: estimator_core::ProcessModel<State = Self, Input = ImuInput>
        + Clone
        + core::fmt::Debug;

    /// The attitude, velocity, position and biases.
    fn nav(&self) -> &InsState;

    /// The IMU noise of a model.
    fn imu_noise(model: &Self::Model) -> &ImuNoise;

    /// Update `filter` with a measurement model of the 15-state navigation state.
    fn update<A, MM, O>(
        filter: &mut ErrorStateFilter<Self, A>,
        model: &MM,
        z: &MM::Measurement,
        r: &Cov<StateDim<MM::Measurement>>,
        observer: &mut O,
    ) -> Result<UpdateSummary, FilterError>
    where
        A: NoiseStrategy,
        MM: MeasurementModel<State = InsState>,
        O: Observer,
        DefaultAllocator: FilterAlloc<Const<15>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<20>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<21>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<26>, StateDim<MM::Measurement>>;
}

/// A measurement model of the 15-state navigation state applied to a larger navigation
/// state `S` whose error state begins with those 15 (the 21-state [`InsState21`], the
/// tightly coupled [`InsStateTc`]): the same prediction from [`NavState::nav`], `H`
/// padded with zero columns for the other states.
#[derive(Debug)]
pub struct OnNav<'a, S, M> {
    model: &'a M,
    _state: PhantomData<fn() -> S>,
}

impl<'a, S, M> OnNav<'a, S, M> {
    /// `model` on the state `S`.
    pub fn new(model: &'a M) -> Self {
        Self { model, _state: PhantomData }
    }
}

impl<S, M> Clone for OnNav<'_, S, M> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<S, M> Copy for OnNav<'_, S, M> {}

/// `h` with zero columns appended up to `C`.
fn pad<R: DimName, C: DimName, St: RawStorage<f64, R, Const<15>>>(
    h: &Matrix<f64, R, Const<15>, St>,
) -> OMatrix<f64, R, C>
where
    DefaultAllocator: Allocator<R, C>,
{
    OMatrix::<f64, R, C>::from_fn(|r, c| if c < 15 { h[(r, c)] } else { 0.0 })
}

impl<S, M> MeasurementModel for OnNav<'_, S, M>
where
    S: NavState,
    M: MeasurementModel<State = InsState>,
    DefaultAllocator: DimAlloc<S::Dim>
        + FilterAlloc<Const<15>, StateDim<M::Measurement>>
        + FilterAlloc<S::Dim, StateDim<M::Measurement>>,
{
    type State = S;
    type Measurement = M::Measurement;

    fn predict(&self, x: &S) -> M::Measurement {
        self.model.predict(x.nav())
    }

    fn jacobian(&self, x: &S) -> JacobiansOf<Self> {
        MeasurementJacobians { H: pad(&self.model.jacobian(x.nav()).H) }
    }

    fn innovation(
        &self,
        x: &S,
        z: &M::Measurement,
    ) -> (Tangent<M::Measurement>, JacobiansOf<Self>) {
        let (r, j) = self.model.innovation(x.nav(), z);
        (r, MeasurementJacobians { H: pad(&j.H) })
    }

    fn stream(&self) -> StreamId {
        self.model.stream()
    }
}

impl NavState for InsState {
    type Model = InsModel;

    fn nav(&self) -> &InsState {
        self
    }

    fn imu_noise(model: &InsModel) -> &ImuNoise {
        &model.noise
    }

    fn update<A, MM, O>(
        filter: &mut ErrorStateFilter<Self, A>,
        model: &MM,
        z: &MM::Measurement,
        r: &Cov<StateDim<MM::Measurement>>,
        observer: &mut O,
    ) -> Result<UpdateSummary, FilterError>
    where
        A: NoiseStrategy,
        MM: MeasurementModel<State = InsState>,
        O: Observer,
        DefaultAllocator: FilterAlloc<Const<15>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<20>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<21>, StateDim<MM::Measurement>>
            + FilterAlloc<Const<26>, StateDim<MM::Measurement>>,
    {
        filter.update_observed(model, z, r, observer).map(|r| r.summary())
    }
}

/// A navigation state larger than the 15-state one (its error state begins with those
/// 15): the 15-state measurement models apply through [`OnNav`]. `nav` and `noise` are
/// the field paths to its [`InsState`] and to its model's [`ImuNoise`].
macro_rules! on_nav_state {
    ($state:ty, $model:ty, nav: $($nav:ident).+, noise: $($noise:ident).+) => {
        impl NavState for $state {
            type Model = $model;

            fn nav(&self) -> &InsState {
                &self.$($nav).+
            }

            fn imu_noise(model: &$model) -> &ImuNoise {
                &model.$($noise).+
            }

            fn update<A, MM, O>(
                filter: &mut ErrorStateFilter<Self, A>,
                model: &MM,
                z: &MM::Measurement,
                r: &Cov<StateDim<MM::Measurement>>,
                observer: &mut O,
            ) -> Result<UpdateSummary, FilterError>
            where
                A: NoiseStrategy,
                MM: MeasurementModel<State = InsState>,
                O: Observer,
                DefaultAllocator: FilterAlloc<Const<15>, StateDim<MM::Measurement>>
                    + FilterAlloc<Const<20>, StateDim<MM::Measurement>>
                    + FilterAlloc<Const<21>, StateDim<MM::Measurement>>
                    + FilterAlloc<Const<26>, StateDim<MM::Measurement>>,
            {
                filter
                    .update_observed(&OnNav::<Self, MM>::new(model), z, r, observer)
                    .map(|r| r.summary())
            }
        }
    };
}

on_nav_state!(InsState21, InsModel21, nav: nav, noise: base.noise);
on_nav_state!(InsStateTc, InsModelTc, nav: nav, noise: base.noise);
on_nav_state!(InsStateTc21, InsModelTc21, nav: nav.nav, noise: base.base.noise);
