//! A point as the flat row of its representation's numbers ([`Coeffs`], manif's
//! `coeffs()`).

use nalgebra::{Quaternion, SVector, UnitQuaternion};

use crate::{Real, So3};

/// A value as the flat row of its representation's numbers, exactly: `from_coeffs` of what
/// `coeffs` wrote is the same value, bit for bit. This is manif's `coeffs()`: the numbers
/// the type stores (a rotation's unit quaternion `w, i, j, k`; a planar rotation's angle;
/// a vector's entries; a product's parts in order), not a chart of the tangent space.
///
/// Storage built on it needs no code per type: the segment smoother's records
/// (`estimator_core::Spill` is implemented for every `Coeffs<f64>` type). Tuples and
/// [`composite_state!`](crate::composite_state) states implement it when their parts do.
///
/// ```
/// use manifolds::{Coeffs, So3, R3};
/// use nalgebra::Vector3;
///
/// let x = (So3::exp(&Vector3::new(0.1, -0.2, 0.3)), R3::new(1.0, 2.0, 3.0));
/// let mut row = [0.0; 7];
/// x.coeffs(&mut row);
/// assert_eq!(row[4..], [1.0, 2.0, 3.0]);
/// assert_eq!(<(So3, R3)>::from_coeffs(&row), x);
/// ```
pub trait Coeffs<T: Real = f64>: Sized {
    /// How many numbers.
    const LEN: usize;
    /// Write the numbers into `out` (`out.len() == LEN`).
    fn coeffs(&self, out: &mut [T]);
    /// The value whose numbers are `c` (`c.len() == LEN`), taken as they are: numbers
    /// `coeffs` wrote give the same value back; others are not normalised (a quaternion
    /// that is not unit stays so), so build foreign numbers with the type's constructors.
    fn from_coeffs(c: &[T]) -> Self;
}

impl<T: Real, const N: usize> Coeffs<T> for SVector<T, N> {
    const LEN: usize = N;
    fn coeffs(&self, out: &mut [T]) {
        out.copy_from_slice(self.as_slice());
    }
    fn from_coeffs(c: &[T]) -> Self {
        Self::from_column_slice(c)
    }
}

impl<T: Real> Coeffs<T> for So3<T> {
    /// The unit quaternion `w, i, j, k`.
    const LEN: usize = 4;
    fn coeffs(&self, out: &mut [T]) {
        let q = self.quaternion();
        out.copy_from_slice(&[q.w, q.i, q.j, q.k]);
    }
    fn from_coeffs(c: &[T]) -> Self {
        let q = Quaternion::new(c[0], c[1], c[2], c[3]);
        So3::from_unit_quaternion_unchecked(UnitQuaternion::new_unchecked(q))
    }
}

impl Coeffs<f64> for f64 {
    const LEN: usize = 1;
    fn coeffs(&self, out: &mut [f64]) {
        out[0] = *self;
    }
    fn from_coeffs(c: &[f64]) -> Self {
        c[0]
    }
}

impl Coeffs<f32> for f32 {
    const LEN: usize = 1;
    fn coeffs(&self, out: &mut [f32]) {
        out[0] = *self;
    }
    fn from_coeffs(c: &[f32]) -> Self {
        c[0]
    }
}

impl<T: Real> Coeffs<T> for () {
    const LEN: usize = 0;
    fn coeffs(&self, _: &mut [T]) {}
    fn from_coeffs(_: &[T]) -> Self {}
}

macro_rules! impl_tuple_coeffs {
    ($($P:ident . $idx:tt),+) => {
        impl<Sc: Real, $($P: Coeffs<Sc>),+> Coeffs<Sc> for ($($P,)+) {
            const LEN: usize = 0 $(+ $P::LEN)+;
            fn coeffs(&self, out: &mut [Sc]) {
                let mut _off = 0usize;
                $(
                    self.$idx.coeffs(&mut out[_off.._off + $P::LEN]);
                    _off += $P::LEN;
                )+
            }
            fn from_coeffs(c: &[Sc]) -> Self {
                let mut _off = 0usize;
                ($({
                    let part = $P::from_coeffs(&c[_off.._off + $P::LEN]);
                    _off += $P::LEN;
                    part
                },)+)
            }
        }
    };
}

impl_tuple_coeffs!(A.0);
impl_tuple_coeffs!(A.0, B.1);
impl_tuple_coeffs!(A.0, B.1, C.2);
impl_tuple_coeffs!(A.0, B.1, C.2, D.3);
impl_tuple_coeffs!(A.0, B.1, C.2, D.3, E.4);
impl_tuple_coeffs!(A.0, B.1, C.2, D.3, E.4, F.5);

/// With the feature `serde`: any [`Coeffs`] value (de)serialised as the sequence of its
/// numbers, for a field of a type that has no serde of its own:
/// `#[serde(with = "manifolds::serde_coeffs")]`. Reading refuses a sequence of another
/// length.
///
/// ```
/// use manifolds::So3;
///
/// #[derive(serde::Serialize, serde::Deserialize, PartialEq, Debug)]
/// struct Saved {
///     #[serde(with = "manifolds::serde_coeffs")]
///     att: So3,
/// }
/// let s = Saved { att: So3::from_euler(0.1, 0.2, 0.3) };
/// let text = serde_json::to_string(&s).unwrap();
/// assert_eq!(serde_json::from_str::<Saved>(&text).unwrap(), s);
/// assert!(serde_json::from_str::<Saved>(r#"{"att":[1.0,0.0,0.0]}"#).is_err());
/// ```
#[cfg(feature = "serde")]
pub mod serde_coeffs {
    use super::Coeffs;
    use crate::Real;

    /// Write `x` as the sequence of its [`Coeffs`].
    pub fn serialize<M, T, S>(x: &M, s: S) -> Result<S::Ok, S::Error>
    where
        M: Coeffs<T>,
        T: Real + serde::Serialize,
        S: serde::Serializer,
    {
        let mut row = vec![T::zero(); M::LEN];
        x.coeffs(&mut row);
        serde::Serialize::serialize(&row, s)
    }

    /// Read a value from the sequence of its [`Coeffs`] (exactly `M::LEN` numbers).
    pub fn deserialize<'de, M, T, D>(d: D) -> Result<M, D::Error>
    where
        M: Coeffs<T>,
        T: Real + serde::Deserialize<'de>,
        D: serde::Deserializer<'de>,
    {
        let row: Vec<T> = serde::Deserialize::deserialize(d)?;
        if row.len() != M::LEN {
            return Err(serde::de::Error::invalid_length(
                row.len(),
                &format!("{} coefficients", M::LEN).as_str(),
            ));
        }
        Ok(M::from_coeffs(&row))
    }
}
