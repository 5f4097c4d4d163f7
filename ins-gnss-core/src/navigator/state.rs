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
        DefaultAllocator: NavAlloc<StateDim<MM::Measurement>>;

    /// Update `filter` with a GNSS fix model of the 15-state navigation state (position,
    /// or position and velocity): as [`update`](Self::update); on a state that carries
    /// the fixes' persisting error through [`OnFixError`] (the error added to the
    /// prediction), on one that carries the calibration through
    /// [`OnCalibration`](crate::calibration::OnCalibration) with the items `process`
    /// estimates and the epoch's specific force `force` (body, m/s²).
    #[allow(clippy::too_many_arguments)]
    fn update_fix<A, MM, O>(
        filter: &mut ErrorStateFilter<Self, A>,
        process: &Self::Model,
        model: &MM,
        z: &MM::Measurement,
        r: &Cov<StateDim<MM::Measurement>>,
        force: &Vector3<f64>,
        observer: &mut O,
    ) -> Result<UpdateSummary, FilterError>
    where
        A: NoiseStrategy,
        MM: GnssFixModel,
        O: Observer,
        DefaultAllocator: NavAlloc<StateDim<MM::Measurement>>,
    {
        let _ = (process, force);
        Self::update(filter, model, z, r, observer)
    }

    /// Update `filter` with a vehicle-frame velocity model (the NHC, the odometer): as
    /// [`update`](Self::update), and on a state that carries the mounting
    /// ([`InsStateCal`](crate::calibration::InsStateCal)) through
    /// [`OnMounting`](crate::calibration::OnMounting) with the items `process` estimates.
    fn update_vehicle<A, MM, O>(
        filter: &mut ErrorStateFilter<Self, A>,
        process: &Self::Model,
        model: &MM,
        z: &MM::Measurement,
        r: &Cov<StateDim<MM::Measurement>>,
        observer: &mut O,
    ) -> Result<UpdateSummary, FilterError>
    where
        A: NoiseStrategy,
        MM: VehicleModel,
        O: Observer,
        DefaultAllocator: NavAlloc<StateDim<MM::Measurement>>,
    {
        let _ = process;
        Self::update(filter, model, z, r, observer)
    }

    /// The fixes' persisting error and the index of its block in the error state, on a
    /// state that carries it.
    fn fix_error(&self) -> Option<(&Vector3<f64>, usize)> {
        None
    }

    /// Set the model of the fixes' persisting error in `model` (from the next prediction
    /// on), on a state that carries it; nothing otherwise.
    fn set_fix_error(model: &mut Self::Model, fix: crate::fix_error::FixErrorModel) {
        let _ = (model, fix);
    }

    /// The model of the fixes' persisting error in `model`, on a state that carries it.
    fn fix_error_model(model: &Self::Model) -> Option<crate::fix_error::FixErrorModel> {
        let _ = model;
        None
    }

    /// The state with the calibration states, on a state that carries them (their block
    /// in the error state is [`InsStateCal::CAL`](crate::calibration::InsStateCal)).
    fn calibration_states(&self) -> Option<&InsStateCal> {
        None
    }

    /// Whether `process` estimates the odometer's scale (the navigator then uses the
    /// odometer from the start, unscaled, instead of calibrating its scale outside the
    /// filter first).
    fn odometer_calibrated(process: &Self::Model) -> bool {
        let _ = process;
        false
    }
}

/// The allocations the navigation states' updates with a measurement of dimension `M`
/// need: one bound for every state dimension the [`Navigator`] runs.
pub trait NavAlloc<M: DimName>:
    FilterAlloc<Const<3>, M>
    + FilterAlloc<Const<15>, M>
    + FilterAlloc<Const<18>, M>
    + FilterAlloc<Const<26>, M>
    + FilterAlloc<Const<20>, M>
    + FilterAlloc<Const<21>, M>
    + FilterAlloc<Const<24>, M>
    + FilterAlloc<Const<26>, M>
{
}

impl<M: DimName, T> NavAlloc<M> for T where
    T: FilterAlloc<Const<3>, M>
        + FilterAlloc<Const<15>, M>
        + FilterAlloc<Const<18>, M>
        + FilterAlloc<Const<26>, M>
        + FilterAlloc<Const<20>, M>
        + FilterAlloc<Const<21>, M>
        + FilterAlloc<Const<24>, M>
        + FilterAlloc<Const<26>, M>
{
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

/// A GNSS fix model of the 15-state INS (position, or position and velocity; the first
/// three dimensions of its tangent are the NED-metre position) applied to a state with
/// the fixes' persisting error: `ẑ = h(x) ⊕ b`, residual `z ⊖ h(x) − b`, `H = [H_nav, E]`
/// with `E` the identity on the position rows.
#[derive(Debug)]
pub struct OnFixError<'a, S, M> {
    model: &'a M,
    _state: core::marker::PhantomData<fn() -> S>,
}

impl<'a, S, M> OnFixError<'a, S, M> {
    /// `model` on the state `S`.
    pub fn new(model: &'a M) -> Self {
        Self { model, _state: core::marker::PhantomData }
    }
}

impl<S, M> Clone for OnFixError<'_, S, M> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<S, M> Copy for OnFixError<'_, S, M> {}

/// `h` (the 15-state model's `H`) in the first 15 columns of an `R × C` matrix, the
/// identity on the first three rows at the fix block's columns from `f` (none without).
fn with_fix_columns<R: DimName, C: DimName, St: RawStorage<f64, R, Const<15>>>(
    h: &Matrix<f64, R, Const<15>, St>,
    f: Option<usize>,
) -> OMatrix<f64, R, C>
where
    DefaultAllocator: Allocator<R, C>,
{
    OMatrix::<f64, R, C>::from_fn(|r, c| {
        if c < 15 {
            h[(r, c)]
        } else if f.is_some_and(|f| r < 3 && c == f + r) {
            1.0
        } else {
            0.0
        }
    })
}

impl<S, M> MeasurementModel for OnFixError<'_, S, M>
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
        let mut b = Tangent::<M::Measurement>::zeros();
        if let Some((e, _)) = x.fix_error() {
            for k in 0..3 {
                b[k] = e[k];
            }
        }
        self.model.predict(x.nav()).oplus(&b)
    }

    fn jacobian(&self, x: &S) -> JacobiansOf<Self> {
        let start = x.fix_error().map(|(_, s)| s);
        MeasurementJacobians { H: with_fix_columns(&self.model.jacobian(x.nav()).H, start) }
    }

    fn innovation(
        &self,
        x: &S,
        z: &M::Measurement,
    ) -> (Tangent<M::Measurement>, JacobiansOf<Self>) {
        let (mut r, j) = self.model.innovation(x.nav(), z);
        let start = x.fix_error().map(|(e, s)| {
            for k in 0..3 {
                r[k] -= e[k];
            }
            s
        });
        (r, MeasurementJacobians { H: with_fix_columns(&j.H, start) })
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
        DefaultAllocator: NavAlloc<StateDim<MM::Measurement>>,
    {
        filter.update_observed(model, z, r, observer).map(|r| r.summary())
    }
}

/// A navigation state larger than the 15-state one (its error state begins with those
/// 15): the 15-state measurement models apply through [`OnNav`]. `nav` and `noise` are
/// the field paths to its [`InsState`] and to its model's [`ImuNoise`]; a trailing
/// `{ … }` holds the impl's further items.
macro_rules! on_nav_state {
    ($state:ty, $model:ty, nav: $($nav:ident).+, noise: $($noise:ident).+ $({ $($more:tt)* })?) => {
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
                DefaultAllocator: NavAlloc<StateDim<MM::Measurement>>,
            {
                filter
                    .update_observed(&OnNav::<Self, MM>::new(model), z, r, observer)
                    .map(|r| r.summary())
            }

            $($($more)*)?
        }
    };
}

on_nav_state!(InsState21, InsModel21, nav: nav, noise: base.noise);
on_nav_state!(InsStateTc, InsModelTc, nav: nav, noise: base.noise);
on_nav_state!(InsStateTc21, InsModelTc21, nav: nav.nav, noise: base.base.noise);

/// A navigation state with the fixes' persisting error ([`InsStateFe`],
/// [`InsState21Fe`]): the 15-state models apply through [`OnNav`], the GNSS fixes through
/// [`OnFixError`].
macro_rules! fix_error_state {
    ($state:ty, $model:ty, nav: $($nav:ident).+, noise: $($noise:ident).+) => {
        on_nav_state!($state, $model, nav: $($nav).+, noise: $($noise).+ {
            fn update_fix<A, MM, O>(
                filter: &mut ErrorStateFilter<Self, A>,
                _process: &$model,
                model: &MM,
                z: &MM::Measurement,
                r: &Cov<StateDim<MM::Measurement>>,
                _force: &Vector3<f64>,
                observer: &mut O,
            ) -> Result<UpdateSummary, FilterError>
            where
                A: NoiseStrategy,
                MM: GnssFixModel,
                O: Observer,
                DefaultAllocator: NavAlloc<StateDim<MM::Measurement>>,
            {
                filter
                    .update_observed(&OnFixError::<Self, MM>::new(model), z, r, observer)
                    .map(|r| r.summary())
            }

            fn fix_error(&self) -> Option<(&Vector3<f64>, usize)> {
                Some((&self.fix, <$state>::FIX.start()))
            }

            fn set_fix_error(model: &mut $model, fix: crate::fix_error::FixErrorModel) {
                model.fix = fix;
            }

            fn fix_error_model(model: &$model) -> Option<crate::fix_error::FixErrorModel> {
                Some(model.fix)
            }
        });
    };
}

fix_error_state!(InsStateFe, InsModelFe, nav: nav, noise: base.noise);
fix_error_state!(InsState21Fe, InsModel21Fe, nav: nav.nav, noise: base.base.noise);

// The 15-state INS with the rig's calibration (`InsStateCal`): the 15-state models apply
// through `OnNav`, the GNSS fixes through `OnCalibration`.
on_nav_state!(InsStateCal, InsModelCal, nav: nav, noise: base.noise {
    fn update_fix<A, MM, O>(
        filter: &mut ErrorStateFilter<Self, A>,
        process: &InsModelCal,
        model: &MM,
        z: &MM::Measurement,
        r: &Cov<StateDim<MM::Measurement>>,
        force: &Vector3<f64>,
        observer: &mut O,
    ) -> Result<UpdateSummary, FilterError>
    where
        A: NoiseStrategy,
        MM: GnssFixModel,
        O: Observer,
        DefaultAllocator: NavAlloc<StateDim<MM::Measurement>>,
    {
        let on = crate::calibration::OnCalibration::new(model, *force, process.calibration);
        filter.update_observed(&on, z, r, observer).map(|r| r.summary())
    }

    fn update_vehicle<A, MM, O>(
        filter: &mut ErrorStateFilter<Self, A>,
        process: &InsModelCal,
        model: &MM,
        z: &MM::Measurement,
        r: &Cov<StateDim<MM::Measurement>>,
        observer: &mut O,
    ) -> Result<UpdateSummary, FilterError>
    where
        A: NoiseStrategy,
        MM: VehicleModel,
        O: Observer,
        DefaultAllocator: NavAlloc<StateDim<MM::Measurement>>,
    {
        let on = crate::calibration::OnMounting::new(model, process.calibration);
        filter.update_observed(&on, z, r, observer).map(|r| r.summary())
    }

    fn calibration_states(&self) -> Option<&InsStateCal> {
        Some(self)
    }

    fn odometer_calibrated(process: &InsModelCal) -> bool {
        process.calibration.odometer
    }
});
