//! The law harness run on every built-in manifold, on tuples and on a named composite.

use manifolds::testing::{arb_rn, arb_rotation_vector, arb_so3, concat_tangent, LawSampler};
use manifolds::{composite_state, Manifold, So2, So3, Tangent, R2, R3};
use proptest::prelude::*;
use proptest::strategy::BoxedStrategy;

manifolds::manifold_law_tests!(so3_laws, So3);
manifolds::manifold_law_tests!(so2_laws, So2);
manifolds::manifold_law_tests!(r3_laws, R3);
manifolds::manifold_law_tests!(pair_laws, (So3, R3));
manifolds::manifold_law_tests!(triple_laws, (So2, R2, So3));

// The same laws in single precision, with the tolerances of `LawTolerance::for_scalar::<f32>()`.
manifolds::manifold_law_tests!(so3_laws_f32, So3<f32>, scalar = f32);
manifolds::manifold_law_tests!(so2_laws_f32, So2<f32>, scalar = f32);
manifolds::manifold_law_tests!(r3_laws_f32, R3<f32>, scalar = f32);
manifolds::manifold_law_tests!(pair_laws_f32, (So3<f32>, R3<f32>), scalar = f32);
manifolds::manifold_law_tests!(triple_laws_f32, (So2<f32>, R2<f32>, So3<f32>), scalar = f32);

composite_state! {
    /// An INS-like state, as the INS/GNSS crate defines it.
    pub struct Ins {
        /// Attitude.
        pub att: So3 => ATT,
        /// Velocity.
        pub vel: R3 => VEL,
        /// Position.
        pub pos: R3 => POS,
        /// Gyro bias.
        pub bg: R3 => BG,
        /// Accelerometer bias.
        pub ba: R3 => BA,
    }
}

impl LawSampler for Ins {
    fn arb_point() -> BoxedStrategy<Self> {
        (arb_so3(), arb_rn::<3>(50.0), arb_rn::<3>(1e4), arb_rn::<3>(1e-2), arb_rn::<3>(1e-1))
            .prop_map(|(att, vel, pos, bg, ba)| Ins { att, vel, pos, bg, ba })
            .boxed()
    }
    fn arb_tangent() -> BoxedStrategy<Tangent<Self>> {
        (arb_rotation_vector(3.0), arb_rn::<12>(10.0))
            .prop_map(|(a, r)| concat_tangent::<Self>(&[a.as_slice(), r.as_slice()]))
            .boxed()
    }
    fn boundary_tangents() -> Vec<Tangent<Self>> {
        manifolds::testing::embed_boundary::<Self, So3>(Ins::ATT.start())
    }
}

manifolds::manifold_law_tests!(composite_laws, Ins);

// A compile-time check: the 5-tuple and the named composite both have 15-dimensional
// tangents as *types* (this line would not compile otherwise).
const _: fn() = || {
    let _: nalgebra::SMatrix<f64, 15, 15> = nalgebra::OMatrix::<
        f64,
        <(So3, R3, R3, R3, R3) as Manifold>::Dim,
        <Ins as Manifold>::Dim,
    >::zeros();
};

#[test]
fn composite_blocks_are_named_ranges() {
    assert_eq!(Ins::ATT.range(), 0..3);
    assert_eq!(Ins::VEL.range(), 3..6);
    assert_eq!(Ins::POS.range(), 6..9);
    assert_eq!(Ins::BG.range(), 9..12);
    assert_eq!(Ins::BA.range(), 12..15);
    assert_eq!(<Ins as Manifold>::DIM, 15);
    assert_eq!(<(So3, R3, R3, R3, R3) as Manifold>::DIM, 15);
}

#[test]
fn composite_and_tuple_agree() {
    // The same state as a named struct and as a tuple gives the same ⊖ and ⊕.
    let a = Ins {
        att: So3::from_euler(0.1, -0.2, 2.9),
        vel: R3::new(1.0, 2.0, 3.0),
        pos: R3::new(-4.0, 5.0, 6.0),
        bg: R3::new(1e-3, 2e-3, 3e-3),
        ba: R3::new(0.01, 0.02, 0.03),
    };
    let d = Tangent::<Ins>::from_fn(|i, _| 0.05 * (i as f64 - 7.0));
    let b = a.oplus(&d);
    let ta = (a.att, a.vel, a.pos, a.bg, a.ba);
    let tb = ta.oplus(&nalgebra::SVector::<f64, 15>::from_column_slice(d.as_slice()));
    assert!((b.ominus(&a) - d).norm() < 1e-12);
    assert!((tb.ominus(&ta) - d).norm() < 1e-12);
    assert!((b.att.ominus(&tb.0)).norm() < 1e-14);
}

/// A rotation whose ⊕ Jacobian is deliberately wrong (the left Jacobian instead of the
/// right one): the harness must reject it, or it would prove nothing.
#[derive(Clone, Debug)]
struct WrongJacobian(So3);

impl Manifold for WrongJacobian {
    type Dim = nalgebra::Const<3>;
    fn origin() -> Self {
        Self(So3::identity())
    }
    fn oplus(&self, d: &nalgebra::Vector3<f64>) -> Self {
        Self(self.0.oplus(d))
    }
    fn ominus(&self, o: &Self) -> nalgebra::Vector3<f64> {
        self.0.ominus(&o.0)
    }
    fn is_finite(&self) -> bool {
        self.0.is_finite()
    }
    fn oplus_jacobians(&self, d: &nalgebra::Vector3<f64>) -> manifolds::OplusJacobians<Self> {
        let j = self.0.oplus_jacobians(d);
        manifolds::OplusJacobians { J_y_x: j.J_y_x, J_y_delta: manifolds::left_jacobian(d) }
    }
}

#[test]
fn harness_rejects_a_wrong_jacobian() {
    let x = WrongJacobian(So3::from_euler(0.2, 0.1, -0.4));
    let d = nalgebra::Vector3::new(0.3, -0.2, 0.5);
    let err = manifolds::testing::check_laws(&x, &x.oplus(&d), &d, Default::default())
        .expect_err("a wrong Jacobian must be caught");
    assert_eq!(err.law, "J of x ⊕ δ w.r.t. δ");
    // …while the default (numerical) ominus Jacobians of the same type pass.
    let ok = WrongJacobian(So3::identity());
    assert!(manifolds::testing::check_laws(
        &ok,
        &ok,
        &nalgebra::Vector3::zeros(),
        Default::default()
    )
    .is_ok());
}

// A composite state over any scalar (`struct Name<T>`): the laws in f64 (its law sampler)
// and in f32 (a sampler built from the parts').
composite_state! {
    /// Attitude and position over the scalar `T`.
    pub struct Pose<T> { pub att: So3 => ATT, pub pos: R3 => POS }
}

fn pose_sampler_f32() -> manifolds::testing::Sampler<Pose<f32>, f32> {
    use manifolds::testing::Sampler;
    let parts = Sampler::<(So3<f32>, R3<f32>), f32>::of();
    let points = parts.points.prop_map(|(att, pos)| Pose { att, pos }).boxed();
    let tangents = parts
        .tangents
        .prop_map(|t| Tangent::<Pose<f32>, f32>::from_iterator(t.iter().copied()))
        .boxed();
    Sampler::new(points, tangents)
}

manifolds::manifold_law_tests!(
    generic_composite_laws,
    Pose,
    sampler =
        Pose::law_sampler(manifolds::testing::Sampler::of(), manifolds::testing::Sampler::of()),
);
manifolds::manifold_law_tests!(
    generic_composite_laws_f32,
    Pose<f32>,
    sampler = pose_sampler_f32(),
    scalar = f32,
);

#[test]
fn generic_composite_blocks_and_dimension() {
    assert_eq!(<Pose<f32> as Manifold<f32>>::DIM, 6);
    assert_eq!((Pose::<f32>::ATT.range(), Pose::<f32>::POS.range()), (0..3, 3..6));
    let x =
        Pose::<f32> { att: So3::exp(&nalgebra::Vector3::new(0.1, 0.2, -0.3)), pos: R3::zeros() };
    let d = Tangent::<Pose<f32>, f32>::from_element(0.01);
    assert_eq!(Pose::<f32>::POS.of(&d), R3::<f32>::from_element(0.01));
    assert!((x.oplus(&d).ominus(&x) - d).norm() < 1e-6);
}

/// `from_coeffs(coeffs(x))` is `x`, bit for bit, and the row is the parts' rows in order,
/// for every built-in manifold, tuples and composites, over random points (the `Sampler`s
/// above); a composite's row is its tuple's.
fn coeffs_round_trip<M, T>(x: &M) -> Result<(), TestCaseError>
where
    M: manifolds::Coeffs<T> + PartialEq + core::fmt::Debug,
    T: manifolds::Real,
{
    let mut row = vec![nalgebra::convert::<f64, T>(f64::NAN); M::LEN];
    x.coeffs(&mut row);
    prop_assert!(row.iter().all(|v| v.is_finite()), "every number written: {x:?}");
    prop_assert_eq!(&M::from_coeffs(&row), x);
    Ok(())
}

proptest! {
    #[test]
    fn coefficients_come_back_exactly(
        ins in Ins::arb_point(),
        so2 in manifolds::testing::Sampler::<So2>::of().points,
        triple in manifolds::testing::Sampler::<(So2<f32>, R2<f32>, So3<f32>), f32>::of().points,
        pose in pose_sampler_f32().points,
    ) {
        coeffs_round_trip(&ins)?;
        coeffs_round_trip(&so2)?;
        coeffs_round_trip(&ins.att)?;
        coeffs_round_trip(&triple)?;
        coeffs_round_trip(&pose)?;
        let tuple = (ins.att, ins.vel, ins.pos, ins.bg, ins.ba);
        coeffs_round_trip(&tuple)?;
        let (mut a, mut b) = ([0.0; 16], [0.0; 16]);
        manifolds::Coeffs::coeffs(&ins, &mut a);
        manifolds::Coeffs::coeffs(&tuple, &mut b);
        prop_assert_eq!(a, b);
        let q = ins.att.quaternion();
        prop_assert_eq!(a[..4].to_vec(), vec![q.w, q.i, q.j, q.k]);
        prop_assert_eq!(&a[4..7], ins.vel.as_slice());
        prop_assert_eq!(a[15], ins.ba.z);
        prop_assert_eq!(<(So2<f32>, R2<f32>, So3<f32>) as manifolds::Coeffs<f32>>::LEN, 7);
    }
}
