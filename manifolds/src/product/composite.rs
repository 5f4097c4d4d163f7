//! `composite_state!`: a named product state, with its serde and law-sampler helpers
//! (exported at the crate root; their `cfg` follows the crate's features).

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
                        $( $crate::__private::set_block(&mut t, Self::$BLOCK.start(), &$field); )+
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

/// A composite state's [`Coeffs`](crate::Coeffs): its fields' numbers in declaration order
/// (when every field has them).
#[doc(hidden)]
#[macro_export]
macro_rules! __composite_coeffs {
    ($Name:ty, $S:ty; $($field:ident : $T:ty),+) => {
        fn coeffs(&self, out: &mut [$S]) {
            let mut _off = 0usize;
            $(
                let n = <$T as $crate::Coeffs<$S>>::LEN;
                $crate::Coeffs::<$S>::coeffs(&self.$field, &mut out[_off.._off + n]);
                _off += n;
            )+
        }
        fn from_coeffs(c: &[$S]) -> Self {
            let mut _off = 0usize;
            Self {
                $(
                    $field: {
                        let n = <$T as $crate::Coeffs<$S>>::LEN;
                        let part = <$T as $crate::Coeffs<$S>>::from_coeffs(&c[_off.._off + n]);
                        _off += n;
                        part
                    },
                )+
            }
        }
    };
}

/// Define a named composite state whose tangent dimension is the sum of its fields',
/// known at compile time, with a typed [`Block`](crate::Block) constant per field.
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

        // (higher-ranked bounds, as for serde: a field without coefficients makes the impl
        // absent instead of an error)
        impl $crate::Coeffs for $Name
        where
            $(for<'__a> $T: $crate::Coeffs,)+
        {
            const LEN: usize = 0 $(+ <$T as $crate::Coeffs>::LEN)+;
            $crate::__composite_coeffs!($Name, f64; $($field : $T),+);
        }

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

        impl<$S: $crate::Real> $crate::Coeffs<$S> for $Name<$S>
        where
            $(for<'__a> $T<$S>: $crate::Coeffs<$S>,)+
        {
            const LEN: usize = 0 $(+ <$T<$S> as $crate::Coeffs<$S>>::LEN)+;
            $crate::__composite_coeffs!($Name<$S>, $S; $($field : $T<$S>),+);
        }

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
                    $crate::__private::set_block(
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
                    $crate::__private::set_diagonal_block(&mut J_y_x, Self::$BLOCK.start(), &j.J_y_x);
                    $crate::__private::set_diagonal_block(
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
                    $crate::__private::set_diagonal_block(
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
                    $crate::__private::set_diagonal_block(&mut J_d_y, Self::$BLOCK.start(), &j.J_d_y);
                    $crate::__private::set_diagonal_block(&mut J_d_x, Self::$BLOCK.start(), &j.J_d_x);
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
