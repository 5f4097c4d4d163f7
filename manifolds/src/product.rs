//! Product states: tuples of manifolds and named composite states.
//!
//! The tangent of a product is the concatenation of its parts' tangents, in order, and its
//! dimension is their type-level sum (`(So3, R3, R3, R3, R3)` has `Dim = Const<15>`).
//! ⊕ and ⊖ act block by block, so every Jacobian is block diagonal.

use core::marker::PhantomData;
use core::ops::Range;

use nalgebra::allocator::Allocator;
use nalgebra::{DefaultAllocator, DimName, DimNameAdd, DimNameSum, OMatrix, OVector};

use crate::scalar::Real;
use crate::traits::{DimAlloc, Manifold, Tangent, TangentMatrix};

/// Copy of the block of `v` that starts at `offset` and has `B::DIM` rows.
#[doc(hidden)]
pub fn block_of<D, B, T: Real>(v: &OVector<T, D>, offset: usize) -> OVector<T, B>
where
    D: DimName,
    B: DimName,
    DefaultAllocator: Allocator<D> + Allocator<B>,
{
    OVector::<T, B>::from_fn(|i, _| v[offset + i])
}

/// Write `b` into `v` from row `offset` on.
#[doc(hidden)]
pub fn set_block<D, B, T: Real>(v: &mut OVector<T, D>, offset: usize, b: &OVector<T, B>)
where
    D: DimName,
    B: DimName,
    DefaultAllocator: Allocator<D> + Allocator<B>,
{
    for i in 0..B::DIM {
        v[offset + i] = b[i];
    }
}

/// Write the square block `b` on the diagonal of `m` at `(offset, offset)`.
#[doc(hidden)]
pub fn set_diagonal_block<D, B, T: Real>(
    m: &mut OMatrix<T, D, D>,
    offset: usize,
    b: &OMatrix<T, B, B>,
) where
    D: DimName,
    B: DimName,
    DefaultAllocator: Allocator<D, D> + Allocator<B, B>,
{
    for c in 0..B::DIM {
        for r in 0..B::DIM {
            m[(offset + r, offset + c)] = b[(r, c)];
        }
    }
}

/// A typed handle on one block of a composite state's tangent space: its offset and
/// the manifold it belongs to. Composite states expose one per field (e.g.
/// `InsState::ATT`), so code names blocks instead of using bare indices.
pub struct Block<M> {
    offset: usize,
    _m: PhantomData<fn() -> M>,
}

impl<M> Clone for Block<M> {
    fn clone(&self) -> Self {
        *self
    }
}
impl<M> Copy for Block<M> {}

impl<M> core::fmt::Debug for Block<M> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "Block({}..)", self.offset)
    }
}

impl<M> Block<M> {
    /// A block starting at `offset`.
    pub const fn new(offset: usize) -> Self {
        Self { offset, _m: PhantomData }
    }

    /// First tangent index of the block.
    pub const fn start(&self) -> usize {
        self.offset
    }

    /// Tangent dimension of the block.
    pub const fn len<T: Real>(&self) -> usize
    where
        M: Manifold<T>,
        DefaultAllocator: DimAlloc<M::Dim>,
    {
        M::DIM
    }

    /// Blocks are never empty unless their manifold is zero-dimensional.
    pub const fn is_empty<T: Real>(&self) -> bool
    where
        M: Manifold<T>,
        DefaultAllocator: DimAlloc<M::Dim>,
    {
        M::DIM == 0
    }

    /// The tangent index range of the block.
    pub const fn range<T: Real>(&self) -> Range<usize>
    where
        M: Manifold<T>,
        DefaultAllocator: DimAlloc<M::Dim>,
    {
        self.offset..self.offset + M::DIM
    }

    /// The block's part of a full tangent vector (or of a gain column, a residual …).
    pub fn of<T: Real, D: DimName>(&self, v: &OVector<T, D>) -> Tangent<M, T>
    where
        M: Manifold<T>,
        DefaultAllocator: DimAlloc<M::Dim> + Allocator<D>,
    {
        block_of::<D, M::Dim, T>(v, self.offset)
    }

    /// The block's diagonal sub-matrix of a full covariance.
    pub fn cov<T: Real, D: DimName>(&self, P: &OMatrix<T, D, D>) -> TangentMatrix<M, T>
    where
        M: Manifold<T>,
        DefaultAllocator: DimAlloc<M::Dim> + Allocator<D, D>,
    {
        TangentMatrix::<M, T>::from_fn(|r, c| P[(self.offset + r, self.offset + c)])
    }

    /// 1σ of each component of the block from a full covariance.
    pub fn sigma<T: Real, D: DimName>(&self, P: &OMatrix<T, D, D>) -> Tangent<M, T>
    where
        M: Manifold<T>,
        DefaultAllocator: DimAlloc<M::Dim> + Allocator<D, D>,
    {
        Tangent::<M, T>::from_fn(|r, _| P[(self.offset + r, self.offset + r)].max(T::zero()).sqrt())
    }
}

macro_rules! impl_tuple_manifold {
    (
        dim = $Dim:ty;
        bounds = [$($bound:tt)*];
        $($T:ident . $idx:tt),+
    ) => {
        impl<Sc: Real, $($T: Manifold<Sc>),+> Manifold<Sc> for ($($T,)+)
        where
            $($bound)*
            DefaultAllocator: $(DimAlloc<$T::Dim> +)+ DimAlloc<$Dim>,
        {
            type Dim = $Dim;

            fn origin() -> Self {
                ($($T::origin(),)+)
            }

            fn oplus(&self, delta: &Tangent<Self, Sc>) -> Self {
                let mut _off = 0usize;
                ($({
                    let d = block_of::<Self::Dim, $T::Dim, Sc>(delta, _off);
                    _off += $T::DIM;
                    self.$idx.oplus(&d)
                },)+)
            }

            fn ominus(&self, origin: &Self) -> Tangent<Self, Sc> {
                let mut out = Tangent::<Self, Sc>::zeros();
                let mut _off = 0usize;
                $(
                    set_block(&mut out, _off, &self.$idx.ominus(&origin.$idx));
                    _off += $T::DIM;
                )+
                out
            }

            fn is_finite(&self) -> bool {
                true $(&& self.$idx.is_finite())+
            }

            fn oplus_jacobians(&self, delta: &Tangent<Self, Sc>) -> crate::OplusJacobians<Self, Sc> {
                let mut J_y_x = TangentMatrix::<Self, Sc>::zeros();
                let mut J_y_delta = TangentMatrix::<Self, Sc>::zeros();
                let mut _off = 0usize;
                $(
                    let d = block_of::<Self::Dim, $T::Dim, Sc>(delta, _off);
                    let j = self.$idx.oplus_jacobians(&d);
                    set_diagonal_block(&mut J_y_x, _off, &j.J_y_x);
                    set_diagonal_block(&mut J_y_delta, _off, &j.J_y_delta);
                    _off += $T::DIM;
                )+
                crate::OplusJacobians { J_y_x, J_y_delta }
            }

            fn oplus_jacobian_delta(&self, delta: &Tangent<Self, Sc>) -> TangentMatrix<Self, Sc> {
                let mut J_y_delta = TangentMatrix::<Self, Sc>::zeros();
                let mut _off = 0usize;
                $(
                    let d = block_of::<Self::Dim, $T::Dim, Sc>(delta, _off);
                    set_diagonal_block(&mut J_y_delta, _off, &self.$idx.oplus_jacobian_delta(&d));
                    _off += $T::DIM;
                )+
                J_y_delta
            }

            fn reset_blocks(
                &self,
                delta: &Tangent<Self, Sc>,
                visit: &mut dyn FnMut(usize, nalgebra::DMatrixView<'_, Sc>),
            ) {
                let mut _off = 0usize;
                $(
                    let d = block_of::<Self::Dim, $T::Dim, Sc>(delta, _off);
                    self.$idx.reset_blocks(&d, &mut |o, b| visit(_off + o, b));
                    _off += $T::DIM;
                )+
            }

            fn oplus_reset(
                &self,
                delta: &Tangent<Self, Sc>,
                visit: &mut dyn FnMut(usize, nalgebra::DMatrixView<'_, Sc>),
            ) -> Self {
                let mut _off = 0usize;
                ($({
                    let d = block_of::<Self::Dim, $T::Dim, Sc>(delta, _off);
                    let off = _off;
                    _off += $T::DIM;
                    self.$idx.oplus_reset(&d, &mut |o, b| visit(off + o, b))
                },)+)
            }

            fn ominus_jacobians(&self, origin: &Self) -> crate::OminusJacobians<Self, Sc> {
                let mut J_d_y = TangentMatrix::<Self, Sc>::zeros();
                let mut J_d_x = TangentMatrix::<Self, Sc>::zeros();
                let mut _off = 0usize;
                $(
                    let j = self.$idx.ominus_jacobians(&origin.$idx);
                    set_diagonal_block(&mut J_d_y, _off, &j.J_d_y);
                    set_diagonal_block(&mut J_d_x, _off, &j.J_d_x);
                    _off += $T::DIM;
                )+
                crate::OminusJacobians { J_d_y, J_d_x }
            }
        }
    };
}

type S2<A, B, Sc> = DimNameSum<<A as Manifold<Sc>>::Dim, <B as Manifold<Sc>>::Dim>;
type S3<A, B, C, Sc> = DimNameSum<S2<A, B, Sc>, <C as Manifold<Sc>>::Dim>;
type S4<A, B, C, D, Sc> = DimNameSum<S3<A, B, C, Sc>, <D as Manifold<Sc>>::Dim>;
type S5<A, B, C, D, E, Sc> = DimNameSum<S4<A, B, C, D, Sc>, <E as Manifold<Sc>>::Dim>;
type S6<A, B, C, D, E, F, Sc> = DimNameSum<S5<A, B, C, D, E, Sc>, <F as Manifold<Sc>>::Dim>;

impl_tuple_manifold!(
    dim = S2<A, B, Sc>;
    bounds = [A::Dim: DimNameAdd<B::Dim>,];
    A.0, B.1
);
impl_tuple_manifold!(
    dim = S3<A, B, C, Sc>;
    bounds = [A::Dim: DimNameAdd<B::Dim>, S2<A, B, Sc>: DimNameAdd<C::Dim>,];
    A.0, B.1, C.2
);
impl_tuple_manifold!(
    dim = S4<A, B, C, D, Sc>;
    bounds = [
        A::Dim: DimNameAdd<B::Dim>,
        S2<A, B, Sc>: DimNameAdd<C::Dim>,
        S3<A, B, C, Sc>: DimNameAdd<D::Dim>,
    ];
    A.0, B.1, C.2, D.3
);
impl_tuple_manifold!(
    dim = S5<A, B, C, D, E, Sc>;
    bounds = [
        A::Dim: DimNameAdd<B::Dim>,
        S2<A, B, Sc>: DimNameAdd<C::Dim>,
        S3<A, B, C, Sc>: DimNameAdd<D::Dim>,
        S4<A, B, C, D, Sc>: DimNameAdd<E::Dim>,
    ];
    A.0, B.1, C.2, D.3, E.4
);
impl_tuple_manifold!(
    dim = S6<A, B, C, D, E, F, Sc>;
    bounds = [
        A::Dim: DimNameAdd<B::Dim>,
        S2<A, B, Sc>: DimNameAdd<C::Dim>,
        S3<A, B, C, Sc>: DimNameAdd<D::Dim>,
        S4<A, B, C, D, Sc>: DimNameAdd<E::Dim>,
        S5<A, B, C, D, E, Sc>: DimNameAdd<F::Dim>,
    ];
    A.0, B.1, C.2, D.3, E.4, F.5
);

/// With the `testing` feature: `law_sampler`, one [`Sampler`](crate::testing::Sampler) per
/// field in, the composite's sampler out (points from the parts' points, tangents
/// concatenated, every part's boundary tangents embedded at its block).
#[cfg(feature = "testing")]
#[doc(hidden)]
#[macro_export]
macro_rules! __composite_law_sampler {
    ($Name:ty; $($field:ident : $T:ty => $BLOCK:ident),+) => {
        impl $Name {
            /// The law harness's sampler of this state from one sampler per field, in
            /// declaration order (`manifolds::testing`, feature `testing`).
            pub fn law_sampler(
                $($field: $crate::testing::Sampler<$T>),+
            ) -> $crate::testing::Sampler<Self> {
                use $crate::testing::proptest::strategy::Strategy as _;
                let mut boundary = Vec::new();
                $( boundary.extend($field.boundary_in::<Self>(Self::$BLOCK.start())); )+
                let points = ($($field.points,)+)
                    .prop_map(|($($field,)+)| Self { $($field),+ })
                    .boxed();
                let tangents = ($($field.tangents,)+)
                    .prop_map(|($($field,)+)| {
                        let mut t = $crate::Tangent::<Self>::zeros();
                        $( $crate::product::set_block(&mut t, Self::$BLOCK.start(), &$field); )+
                        t
                    })
                    .boxed();
                $crate::testing::Sampler { points, tangents, boundary }
            }
        }
    };
}

/// Without the `testing` feature composite states have no sampler.
#[cfg(not(feature = "testing"))]
#[doc(hidden)]
#[macro_export]
macro_rules! __composite_law_sampler {
    ($($t:tt)*) => {};
}

/// With the feature `serde`: a composite state (de)serialises as the tuple of its fields
/// (when they all do).
#[cfg(feature = "serde")]
#[doc(hidden)]
#[macro_export]
macro_rules! __composite_serde {
    ($Name:ident; $($field:ident : $T:ty),+) => {
        // (the bounds are higher-ranked so that a field type without serde makes the impl
        // absent instead of an error: enabling the feature never breaks a build)
        impl $crate::__serde::Serialize for $Name
        where
            $(for<'__a> $T: $crate::__serde::Serialize,)+
        {
            fn serialize<S: $crate::__serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                $crate::__serde::Serialize::serialize(&($(&self.$field,)+), s)
            }
        }
        impl<'de> $crate::__serde::Deserialize<'de> for $Name
        where
            $(for<'__a> $T: $crate::__serde::Deserialize<'de>,)+
        {
            fn deserialize<D: $crate::__serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                let ($($field,)+) =
                    <($($T,)+) as $crate::__serde::Deserialize<'de>>::deserialize(d)?;
                Ok(Self { $($field),+ })
            }
        }
    };
    (@generic $Name:ident, $S:ident; $($field:ident : $T:ident),+) => {
        impl<$S: $crate::Real> $crate::__serde::Serialize for $Name<$S>
        where
            $(for<'__a> $T<$S>: $crate::__serde::Serialize,)+
        {
            fn serialize<Ser: $crate::__serde::Serializer>(
                &self,
                s: Ser,
            ) -> Result<Ser::Ok, Ser::Error> {
                $crate::__serde::Serialize::serialize(&($(&self.$field,)+), s)
            }
        }
        impl<'de, $S: $crate::Real> $crate::__serde::Deserialize<'de> for $Name<$S>
        where
            $(for<'__a> $T<$S>: $crate::__serde::Deserialize<'de>,)+
        {
            fn deserialize<D: $crate::__serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                let ($($field,)+) =
                    <($($T<$S>,)+) as $crate::__serde::Deserialize<'de>>::deserialize(d)?;
                Ok(Self { $($field),+ })
            }
        }
    };
}

/// Without the feature `serde`: nothing.
#[cfg(not(feature = "serde"))]
#[doc(hidden)]
#[macro_export]
macro_rules! __composite_serde {
    ($($t:tt)*) => {};
}

/// Define a named composite state whose tangent dimension is the sum of its fields',
/// known at compile time, with a typed [`Block`] constant per field.
///
/// ```
/// use manifolds::{composite_state, Manifold, So3, R3};
///
/// composite_state! {
///     /// An INS-like state.
///     pub struct Ins {
///         /// Attitude `R_nb`.
///         pub att: So3 => ATT,
///         /// Velocity.
///         pub vel: R3 => VEL,
///         /// Position.
///         pub pos: R3 => POS,
///         /// Gyro bias.
///         pub bg: R3 => BG,
///         /// Accelerometer bias.
///         pub ba: R3 => BA,
///     }
/// }
/// // The dimension is a type: a 15×15 covariance is a stack matrix.
/// let p = nalgebra::OMatrix::<f64, <Ins as Manifold>::Dim, <Ins as Manifold>::Dim>::identity();
/// assert_eq!(p.nrows(), 15);
/// assert_eq!(Ins::VEL.range(), 3..6);
/// assert_eq!(Ins::BA.range(), 12..15);
/// ```
///
/// Over any scalar (`f64` by default): declare the struct with a parameter and name the
/// fields' types without one.
///
/// ```
/// use manifolds::{composite_state, Manifold, So3, R3};
///
/// composite_state! {
///     /// A pose.
///     pub struct Pose<T> { pub att: So3 => ATT, pub pos: R3 => POS }
/// }
/// let x = Pose::<f32> { att: So3::identity(), pos: R3::zeros() };
/// let d = nalgebra::SVector::<f32, 6>::from_element(0.01);
/// assert!((x.oplus(&d).ominus(&x) - d).norm() < 1e-6);
/// let y: Pose = Pose { att: So3::identity(), pos: R3::zeros() }; // Pose<f64>
/// assert_eq!(<Pose as Manifold>::DIM, 6);
/// # let _ = y;
/// ```
#[macro_export]
macro_rules! composite_state {
    (
        $(#[$meta:meta])*
        $vis:vis struct $Name:ident {
            $(
                $(#[$fmeta:meta])*
                $fvis:vis $field:ident : $T:ty => $BLOCK:ident
            ),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Debug, PartialEq)]
        $vis struct $Name {
            $( $(#[$fmeta])* $fvis $field: $T, )+
        }

        $crate::composite_state!(@blocks $Name, 0usize, $($field : $T => $BLOCK),+);
        $crate::__composite_serde!($Name; $($field : $T),+);
        $crate::__composite_law_sampler!($Name; $($field : $T => $BLOCK),+);

        impl $crate::Manifold for $Name {
            $crate::composite_state!(@body f64; $($field : $T, $T => $BLOCK),+);
        }
    };

    (
        $(#[$meta:meta])*
        $vis:vis struct $Name:ident<$S:ident> {
            $(
                $(#[$fmeta:meta])*
                $fvis:vis $field:ident : $T:ident => $BLOCK:ident
            ),+ $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Clone, Debug, PartialEq)]
        $vis struct $Name<$S: $crate::Real = f64> {
            $( $(#[$fmeta])* $fvis $field: $T<$S>, )+
        }

        $crate::composite_state!(@gblocks $Name, $S, 0usize, $($field : $T => $BLOCK),+);
        $crate::__composite_serde!(@generic $Name, $S; $($field : $T),+);
        $crate::__composite_law_sampler!($Name<f64>; $($field : $T<f64> => $BLOCK),+);

        impl<$S: $crate::Real> $crate::Manifold<$S> for $Name<$S> {
            $crate::composite_state!(@body $S; $($field : $T, $T<$S> => $BLOCK),+);
        }
    };

    // `$T` names the field's type at f64 (for the dimension, a constant), `$FT` at `$S`
    (@body $S:ty; $($field:ident : $T:ty, $FT:ty => $BLOCK:ident),+) => {
            type Dim = $crate::nalgebra::Const<{ 0usize $(+ <$T as $crate::Manifold>::DIM)+ }>;

            fn origin() -> Self {
                Self { $( $field: <$FT as $crate::Manifold<$S>>::origin(), )+ }
            }

            fn oplus(&self, delta: &$crate::Tangent<Self, $S>) -> Self {
                Self {
                    $( $field: self.$field.oplus(&Self::$BLOCK.of(delta)), )+
                }
            }

            fn ominus(&self, origin: &Self) -> $crate::Tangent<Self, $S> {
                let mut out = $crate::Tangent::<Self, $S>::zeros();
                $(
                    $crate::product::set_block(
                        &mut out,
                        Self::$BLOCK.start(),
                        &self.$field.ominus(&origin.$field),
                    );
                )+
                out
            }

            fn is_finite(&self) -> bool {
                true $(&& self.$field.is_finite())+
            }

            fn oplus_jacobians(
                &self,
                delta: &$crate::Tangent<Self, $S>,
            ) -> $crate::OplusJacobians<Self, $S> {
                let mut J_y_x = $crate::TangentMatrix::<Self, $S>::zeros();
                let mut J_y_delta = $crate::TangentMatrix::<Self, $S>::zeros();
                $(
                    let j = self.$field.oplus_jacobians(&Self::$BLOCK.of(delta));
                    $crate::product::set_diagonal_block(&mut J_y_x, Self::$BLOCK.start(), &j.J_y_x);
                    $crate::product::set_diagonal_block(
                        &mut J_y_delta,
                        Self::$BLOCK.start(),
                        &j.J_y_delta,
                    );
                )+
                $crate::OplusJacobians { J_y_x, J_y_delta }
            }

            fn oplus_jacobian_delta(
                &self,
                delta: &$crate::Tangent<Self, $S>,
            ) -> $crate::TangentMatrix<Self, $S> {
                let mut J_y_delta = $crate::TangentMatrix::<Self, $S>::zeros();
                $(
                    $crate::product::set_diagonal_block(
                        &mut J_y_delta,
                        Self::$BLOCK.start(),
                        &self.$field.oplus_jacobian_delta(&Self::$BLOCK.of(delta)),
                    );
                )+
                J_y_delta
            }

            fn reset_blocks(
                &self,
                delta: &$crate::Tangent<Self, $S>,
                visit: &mut dyn FnMut(usize, $crate::nalgebra::DMatrixView<'_, $S>),
            ) {
                $(
                    self.$field.reset_blocks(
                        &Self::$BLOCK.of(delta),
                        &mut |o, b| visit(Self::$BLOCK.start() + o, b),
                    );
                )+
            }

            fn oplus_reset(
                &self,
                delta: &$crate::Tangent<Self, $S>,
                visit: &mut dyn FnMut(usize, $crate::nalgebra::DMatrixView<'_, $S>),
            ) -> Self {
                Self {
                    $(
                        $field: self.$field.oplus_reset(
                            &Self::$BLOCK.of(delta),
                            &mut |o, b| visit(Self::$BLOCK.start() + o, b),
                        ),
                    )+
                }
            }

            fn ominus_jacobians(&self, origin: &Self) -> $crate::OminusJacobians<Self, $S> {
                let mut J_d_y = $crate::TangentMatrix::<Self, $S>::zeros();
                let mut J_d_x = $crate::TangentMatrix::<Self, $S>::zeros();
                $(
                    let j = self.$field.ominus_jacobians(&origin.$field);
                    $crate::product::set_diagonal_block(&mut J_d_y, Self::$BLOCK.start(), &j.J_d_y);
                    $crate::product::set_diagonal_block(&mut J_d_x, Self::$BLOCK.start(), &j.J_d_x);
                )+
                $crate::OminusJacobians { J_d_y, J_d_x }
            }
    };

    (@gblocks $Name:ident, $S:ident, $off:expr, $field:ident : $T:ident => $BLOCK:ident $(, $rf:ident : $rT:ident => $RB:ident)*) => {
        impl<$S: $crate::Real> $Name<$S> {
            #[doc = concat!("Tangent block of `", stringify!($field), "`.")]
            pub const $BLOCK: $crate::Block<$T<$S>> = $crate::Block::new($off);
        }
        $crate::composite_state!(@gblocks $Name, $S, $off + <$T as $crate::Manifold>::DIM $(, $rf : $rT => $RB)*);
    };
    (@gblocks $Name:ident, $S:ident, $off:expr) => {};

    (@blocks $Name:ident, $off:expr, $field:ident : $T:ty => $BLOCK:ident $(, $rf:ident : $rT:ty => $RB:ident)*) => {
        impl $Name {
            #[doc = concat!("Tangent block of `", stringify!($field), "`.")]
            pub const $BLOCK: $crate::Block<$T> = $crate::Block::new($off);
        }
        $crate::composite_state!(@blocks $Name, $off + <$T as $crate::Manifold>::DIM $(, $rf : $rT => $RB)*);
    };
    (@blocks $Name:ident, $off:expr) => {};
}
