//! Samplers: the points and tangents the laws are checked at (proptest strategies for the
//! built-in types, [`Sampler`] for any type).

use super::*;

/// Sample points and tangents of a manifold for the law harness (over the scalar `T`,
/// `f64` unless named; the built-in types sample `f32` by rounding their `f64` samples).
pub trait LawSampler<T: Real = f64>: Manifold<T>
where
    DefaultAllocator: DimAlloc<Self::Dim>,
{
    /// Points spread over the manifold (or a large box of a vector space).
    fn arb_point() -> BoxedStrategy<Self>;
    /// Tangents inside the chart (for rotations: angle below π − 1e-3).
    fn arb_tangent() -> BoxedStrategy<Tangent<Self, T>>;
    /// Tangents at the chart boundary (for rotations: angle π − 1e-4 along several axes).
    /// Empty for flat spaces.
    fn boundary_tangents() -> Vec<Tangent<Self, T>> {
        Vec::new()
    }
}

/// A tangent of norm `norm` along the (normalised) direction `dir`.
pub fn scaled<M: Manifold>(dir: &Tangent<M>, norm: f64) -> Tangent<M>
where
    DefaultAllocator: DimAlloc<M::Dim>,
{
    scaled_in::<M, f64>(dir, norm)
}

/// [`scaled`] over any scalar.
pub fn scaled_in<M: Manifold<T>, T: Real>(dir: &Tangent<M, T>, norm: f64) -> Tangent<M, T>
where
    DefaultAllocator: DimAlloc<M::Dim>,
{
    let n = dir.norm();
    if n > T::zero() {
        dir * (T::lit(norm) / n)
    } else {
        let mut e = Tangent::<M, T>::zeros();
        if M::DIM > 0 {
            e[0] = T::lit(norm);
        }
        e
    }
}

/// A uniformly distributed random rotation (normalised 4-D box sample, rejection of the
/// corners and of near-zero samples).
pub fn arb_so3() -> BoxedStrategy<So3> {
    prop::array::uniform4(-1.0f64..1.0)
        .prop_filter("inside the unit ball, away from 0", |a| {
            let n2: f64 = a.iter().map(|v| v * v).sum();
            n2 > 1e-2 && n2 <= 1.0
        })
        .prop_map(|a| {
            So3::from_quaternion(nalgebra::UnitQuaternion::from_quaternion(
                nalgebra::Quaternion::new(a[0], a[1], a[2], a[3]),
            ))
        })
        .boxed()
}

/// Rotation vectors with angle below `max_angle`.
pub fn arb_rotation_vector(max_angle: f64) -> BoxedStrategy<Vector3<f64>> {
    prop::array::uniform3(-max_angle..max_angle)
        .prop_filter("angle below the bound", move |a| {
            (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt() < max_angle
        })
        .prop_map(|a| Vector3::new(a[0], a[1], a[2]))
        .boxed()
}

/// Vectors of `R^N` with components in `(-scale, scale)`.
pub fn arb_rn<const N: usize>(scale: f64) -> BoxedStrategy<SVector<f64, N>> {
    prop::collection::vec(-scale..scale, N).prop_map(SVector::<f64, N>::from_vec).boxed()
}

/// An `f64` vector rounded to the scalar `T`.
pub(super) fn round_to<T: Real, const N: usize>(v: SVector<f64, N>) -> SVector<T, N> {
    v.map(T::lit)
}

/// How far from π the sampled rotation tangents stay: inside the chart `π − max(1e-3,
/// 100 h)`, at its boundary `π − max(1e-4, 50 h)`, with `h` the scalar's difference step
/// (the central differences at `h` and `10 h` must not cross π): in `f64` 1e-3 and 1e-4, in
/// `f32` 0.1 and 0.05.
pub(super) fn chart_margins<T: Real>() -> (f64, f64) {
    let h = T::DIFF_STEP.to_f64();
    ((100.0 * h).max(1e-3), (50.0 * h).max(1e-4))
}

/// Half-width of the box Euclidean points are drawn from: 1e3 in `f64`; 1 in a coarser
/// scalar, where a difference step `h` added to a point of size `|x|` loses `ulp(|x|)/h`
/// (6 % at 644 in `f32` with `h` = 1e-3; 1e-4 at 1).
pub(super) fn point_box<T: Real>() -> f64 {
    if T::EPS_F64 > 1e-10 {
        1.0
    } else {
        1e3
    }
}

impl<T: Real> LawSampler<T> for So3<T> {
    fn arb_point() -> BoxedStrategy<Self> {
        arb_so3().prop_map(|r| r.cast::<T>()).boxed()
    }
    fn arb_tangent() -> BoxedStrategy<Vector3<T>> {
        arb_rotation_vector(PI - chart_margins::<T>().0).prop_map(round_to).boxed()
    }
    fn boundary_tangents() -> Vec<Vector3<T>> {
        let a = PI - chart_margins::<T>().1;
        [Vector3::x(), Vector3::y(), Vector3::z(), Vector3::new(1.0, -2.0, 0.5)]
            .iter()
            .map(|d| round_to(d.normalize() * a))
            .collect()
    }
}

impl<T: Real> LawSampler<T> for So2<T> {
    fn arb_point() -> BoxedStrategy<Self> {
        (-PI..PI).prop_map(|a| So2::new(T::lit(a))).boxed()
    }
    fn arb_tangent() -> BoxedStrategy<Vector1<T>> {
        let a = PI - chart_margins::<T>().0;
        (-a..a).prop_map(|a| Vector1::new(T::lit(a))).boxed()
    }
    fn boundary_tangents() -> Vec<Vector1<T>> {
        let a = PI - chart_margins::<T>().1;
        vec![Vector1::new(T::lit(a)), Vector1::new(T::lit(-a))]
    }
}

impl<T: Real, const N: usize> LawSampler<T> for SVector<T, N> {
    fn arb_point() -> BoxedStrategy<Self> {
        arb_rn::<N>(point_box::<T>()).prop_map(round_to).boxed()
    }
    fn arb_tangent() -> BoxedStrategy<Self> {
        arb_rn::<N>(10.0).prop_map(round_to).boxed()
    }
}

/// Embed each boundary tangent of a part at `offset` into an otherwise zero tangent.
pub fn embed_boundary<Whole: Manifold, Part: LawSampler>(offset: usize) -> Vec<Tangent<Whole>>
where
    DefaultAllocator: DimAlloc<Whole::Dim> + DimAlloc<Part::Dim>,
{
    embed_boundary_in::<Whole, Part, f64>(offset)
}

pub(super) fn embed_boundary_in<Whole: Manifold<T>, Part: LawSampler<T>, T: Real>(
    offset: usize,
) -> Vec<Tangent<Whole, T>>
where
    DefaultAllocator: DimAlloc<Whole::Dim> + DimAlloc<Part::Dim>,
{
    Part::boundary_tangents()
        .iter()
        .map(|b| {
            let mut t = Tangent::<Whole, T>::zeros();
            set_block(&mut t, offset, b);
            t
        })
        .collect()
}

/// Concatenate part tangents into a whole tangent (for composite strategies).
pub fn concat_tangent<Whole: Manifold>(parts: &[&[f64]]) -> Tangent<Whole>
where
    DefaultAllocator: DimAlloc<Whole::Dim>,
{
    concat_tangent_in::<Whole, f64>(parts)
}

pub(super) fn concat_tangent_in<Whole: Manifold<T>, T: Real>(parts: &[&[T]]) -> Tangent<Whole, T>
where
    DefaultAllocator: DimAlloc<Whole::Dim>,
{
    let mut t = Tangent::<Whole, T>::zeros();
    let mut i = 0;
    for p in parts {
        for v in *p {
            t[i] = *v;
            i += 1;
        }
    }
    t
}

macro_rules! tuple_sampler {
    ($($T:ident . $idx:tt),+) => {
        impl<Sc: Real, $($T: LawSampler<Sc> + 'static),+> LawSampler<Sc> for ($($T,)+)
        where
            ($($T,)+): Manifold<Sc>,
            DefaultAllocator: $(DimAlloc<$T::Dim> +)+ DimAlloc<<($($T,)+) as Manifold<Sc>>::Dim>,
            $(Tangent<$T, Sc>: 'static,)+
        {
            fn arb_point() -> BoxedStrategy<Self> {
                ($($T::arb_point(),)+).boxed()
            }
            fn arb_tangent() -> BoxedStrategy<Tangent<Self, Sc>> {
                ($($T::arb_tangent(),)+)
                    .prop_map(|t| concat_tangent_in::<Self, Sc>(&[$(t.$idx.as_slice()),+]))
                    .boxed()
            }
            fn boundary_tangents() -> Vec<Tangent<Self, Sc>> {
                let mut v = Vec::new();
                let mut _offset = 0;
                $(
                    v.extend(embed_boundary_in::<Self, $T, Sc>(_offset));
                    _offset += $T::DIM;
                )+
                v
            }
        }
    };
}

tuple_sampler!(A.0, B.1);
tuple_sampler!(A.0, B.1, C.2);
tuple_sampler!(A.0, B.1, C.2, D.3);
tuple_sampler!(A.0, B.1, C.2, D.3, E.4);
tuple_sampler!(A.0, B.1, C.2, D.3, E.4, F.5);

/// How the law harness samples a manifold: points, tangents inside the chart, and
/// tangents at the chart's boundary (empty for flat spaces). Build one for any type —
/// yours or a foreign one — from proptest strategies; [`Sampler::of`] for a
/// [`LawSampler`] type.
pub struct Sampler<M: Manifold<T>, T: Real = f64>
where
    DefaultAllocator: DimAlloc<M::Dim>,
{
    /// Points spread over the manifold (or a large box of a vector space).
    pub points: BoxedStrategy<M>,
    /// Tangents inside the chart (for rotations: angle below π − 1e-3).
    pub tangents: BoxedStrategy<Tangent<M, T>>,
    /// Tangents at the chart boundary (for rotations: angle π − 1e-4).
    pub boundary: Vec<Tangent<M, T>>,
}

impl<M: Manifold<T>, T: Real> Clone for Sampler<M, T>
where
    DefaultAllocator: DimAlloc<M::Dim>,
{
    fn clone(&self) -> Self {
        Self {
            points: self.points.clone(),
            tangents: self.tangents.clone(),
            boundary: self.boundary.clone(),
        }
    }
}

impl<M: Manifold<T>, T: Real> Sampler<M, T>
where
    DefaultAllocator: DimAlloc<M::Dim>,
{
    /// Points and tangents from these strategies, no boundary tangents.
    pub fn new(points: BoxedStrategy<M>, tangents: BoxedStrategy<Tangent<M, T>>) -> Self {
        Self { points, tangents, boundary: Vec::new() }
    }

    /// The same sampler with these boundary tangents.
    pub fn with_boundary(mut self, boundary: Vec<Tangent<M, T>>) -> Self {
        self.boundary = boundary;
        self
    }

    /// The sampler of a [`LawSampler`] type.
    pub fn of() -> Self
    where
        M: LawSampler<T>,
    {
        Self {
            points: M::arb_point(),
            tangents: M::arb_tangent(),
            boundary: M::boundary_tangents(),
        }
    }

    /// `(x, y, δ)` triples for the random-point test.
    pub fn triples(&self) -> BoxedStrategy<(M, M, Tangent<M, T>)>
    where
        M: 'static,
        Tangent<M, T>: 'static,
    {
        (self.points.clone(), self.points.clone(), self.tangents.clone()).boxed()
    }

    /// Embed this part's boundary tangents at `offset` of a whole tangent (for composite
    /// samplers).
    pub fn boundary_in<Whole: Manifold<T>>(&self, offset: usize) -> Vec<Tangent<Whole, T>>
    where
        DefaultAllocator: DimAlloc<Whole::Dim>,
    {
        self.boundary
            .iter()
            .map(|b| {
                let mut t = Tangent::<Whole, T>::zeros();
                set_block(&mut t, offset, b);
                t
            })
            .collect()
    }
}
