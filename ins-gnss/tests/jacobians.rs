//! F, G and H against numerical Jacobians through ⊕/⊖ (the core harness), at states that
//! exercise every term: turning, accelerating, climbing, high latitude, lever arm.

#![allow(non_snake_case)]

use estimator_core::harness::{check_measurement_model_with_step, compare, numerical_jacobian};
use estimator_core::ProcessModel;
use ins_gnss::earth::{earth_rate_ned, gravity_ned, radii, transport_rate};
use ins_gnss::imu::ImuSample;
use ins_gnss::model::{ImuInput, InsModel, M15};
use ins_gnss::sim::scenarios;
use ins_gnss::{GeoPos, GnssPosVel, GnssPosition, GnssVelocity, InsState, Mechanization};
use manifolds::{hat, right_jacobian_inverse, Manifold, So3};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

fn states() -> Vec<(InsState, ImuInput)> {
    let deg = core::f64::consts::PI / 180.0;
    let mk = |lat: f64, yaw: f64, v: Vector3<f64>, w: Vector3<f64>, f: Vector3<f64>| {
        let x = InsState {
            att: So3::from_euler(4.0 * deg, -7.0 * deg, yaw),
            vel: v,
            pos: GeoPos::from_degrees(lat, 114.0, 350.0),
            bg: Vector3::new(1e-4, -2e-4, 3e-4),
            ba: Vector3::new(0.02, -0.01, 0.03),
        };
        let dt = 0.005;
        let cur = ImuSample { t: 1.0, dt, dtheta: w * dt, dvel: f * dt };
        let prev = ImuSample { t: 1.0 - dt, dt, dtheta: w * dt * 0.98, dvel: f * dt * 1.01 };
        (x, ImuInput { prev: Some(prev), cur })
    };
    vec![
        mk(
            30.5,
            20.0 * deg,
            Vector3::new(12.0, 8.0, -0.5),
            Vector3::new(0.01, -0.02, 0.3),
            Vector3::new(1.5, 0.8, -9.7),
        ),
        mk(
            -62.0,
            -150.0 * deg,
            Vector3::new(-30.0, 45.0, 2.0),
            Vector3::new(-0.2, 0.1, -0.05),
            Vector3::new(-2.0, 3.0, -10.5),
        ),
        mk(0.3, 90.0 * deg, Vector3::zeros(), Vector3::zeros(), Vector3::new(0.0, 0.0, -9.78)),
    ]
}

/// Continuous nominal dynamics of attitude, velocity and position (WGS-84 NED or flat
/// earth) for a state with *its own* bias-corrected rate and specific force.
fn derivatives(
    mech: &Mechanization,
    x: &InsState,
    w_meas: &Vector3<f64>,
    f_meas: &Vector3<f64>,
) -> (Matrix3<f64>, Vector3<f64>, Vector3<f64>) {
    let c = x.att.matrix();
    let (w, f) = (w_meas - x.bg, f_meas - x.ba);
    let (w_in, cor, g, geo_rate) = match mech {
        Mechanization::Wgs84 => {
            let w_ie = earth_rate_ned(x.pos.lat);
            let w_en = transport_rate(x.pos.lat, x.pos.h, &x.vel);
            let (rm, rn) = radii(x.pos.lat);
            let rate = Vector3::new(
                x.vel.x / (rm + x.pos.h),
                x.vel.y / ((rn + x.pos.h) * x.pos.lat.cos()),
                -x.vel.z,
            );
            (w_ie + w_en, (w_ie * 2.0 + w_en).cross(&x.vel), gravity_ned(x.pos.lat, x.pos.h), rate)
        }
        Mechanization::FlatEarth { reference } => {
            let m = reference.metric();
            let rate = Vector3::new(x.vel.x / m.x, x.vel.y / m.y, -x.vel.z);
            (Vector3::zeros(), Vector3::zeros(), gravity_ned(reference.lat, reference.h), rate)
        }
    };
    // Ċ = C[ω×] − [ω_in×]C,  v̇ = C f + g − (2ω_ie + ω_en) × v
    (c * hat(&w) - hat(&w_in) * c, c * f + g - cor, geo_rate)
}

/// `d/dt (x_true ⊖ x̂)` when both evolve under the continuous dynamics with the same
/// measurements: an independent, nonlinear statement of the error dynamics.
fn error_rate(
    mech: &Mechanization,
    nominal: &InsState,
    truth: &InsState,
    w: &Vector3<f64>,
    f: &Vector3<f64>,
    inv_tau: f64,
) -> SVector<f64, 15> {
    let (cd_n, vd_n, pd_n) = derivatives(mech, nominal, w, f);
    let (cd_t, vd_t, pd_t) = derivatives(mech, truth, w, f);
    let (cn, ct) = (nominal.att.matrix(), truth.att.matrix());
    let e = cn.transpose() * ct; // = Exp(δθ)
    let e_dot = cd_n.transpose() * ct + cn.transpose() * cd_t;
    let k = e.transpose() * e_dot; // = [(Jr(δθ) δθ̇)×]
    let dtheta = truth.att.ominus(&nominal.att);
    let th_dot = right_jacobian_inverse(&dtheta) * Vector3::new(k[(2, 1)], k[(0, 2)], k[(1, 0)]);
    // δp = ((φ−φ̂) m_N(p̂), (λ−λ̂) m_E(p̂), −(h−ĥ)), differentiated by the product rule;
    // the metric's rate along the nominal path by a central difference in time.
    let metric = |p: &GeoPos| match mech {
        Mechanization::Wgs84 => p.metric(),
        Mechanization::FlatEarth { reference } => reference.metric(),
    };
    let tau = 1e-3;
    let shift = |s: f64| GeoPos {
        lat: nominal.pos.lat + pd_n.x * s,
        lon: nominal.pos.lon + pd_n.y * s,
        h: nominal.pos.h + pd_n.z * s,
    };
    let m = metric(&nominal.pos);
    let m_dot = (metric(&shift(tau)) - metric(&shift(-tau))) / (2.0 * tau);
    let d = Vector3::new(
        truth.pos.lat - nominal.pos.lat,
        truth.pos.lon - nominal.pos.lon,
        truth.pos.h - nominal.pos.h,
    );
    let d_dot = pd_t - pd_n;
    let p_dot = d_dot.component_mul(&m) + d.component_mul(&m_dot);
    let mut out = SVector::<f64, 15>::zeros();
    out.fixed_rows_mut::<3>(0).copy_from(&th_dot);
    out.fixed_rows_mut::<3>(3).copy_from(&(vd_t - vd_n));
    out.fixed_rows_mut::<3>(6).copy_from(&p_dot);
    out.fixed_rows_mut::<3>(9).copy_from(&((truth.bg - nominal.bg) * -inv_tau));
    out.fixed_rows_mut::<3>(12).copy_from(&((truth.ba - nominal.ba) * -inv_tau));
    out
}

#[test]
fn continuous_f_matches_the_nonlinear_error_dynamics() {
    for mech in [
        Mechanization::Wgs84,
        Mechanization::FlatEarth { reference: GeoPos::from_degrees(30.0, 114.0, 0.0) },
    ] {
        let model = InsModel { mechanization: mech, noise: scenarios::mems_imu().noise };
        for (i, (x, u)) in states().into_iter().enumerate() {
            let (w, f) = (u.cur.rate(), u.cur.specific_force());
            let inv_tau = model.noise.inverse_tau();
            let numeric = estimator_core::manifolds::numdiff::jacobian(
                &x,
                |xt| error_rate(&mech, &x, xt, &w, &f, inv_tau),
                1e-3,
            );
            let analytic = model.error_dynamics(&x, &(w - x.bg), &(f - x.ba));
            // Block by block, each against its own scale, so that the small Earth-rate
            // and transport-rate terms are checked too.
            for bi in 0..5 {
                for bj in 0..5 {
                    let a: Matrix3<f64> = analytic.fixed_view::<3, 3>(3 * bi, 3 * bj).into_owned();
                    let n: Matrix3<f64> = numeric.fixed_view::<3, 3>(3 * bi, 3 * bj).into_owned();
                    // Absolute floor: rounding of a 1e-3 difference step is ≈ 1e-13.
                    let tol = 1e-5 * n.abs().max() + 1e-12;
                    let err = (a - n).abs().max();
                    assert!(err <= tol, "{mech:?} state {i}: block ({bi},{bj}) |Δ| {err:.3e} > {tol:.3e}\nanalytic {a}\nnumeric {n}");
                }
            }
        }
    }
}

#[test]
fn discrete_phi_matches_one_mechanization_step_to_first_order() {
    // Φ = I + F dt against the Jacobian of one real mechanization step: equal up to
    // O((F dt)²), so the tolerance is a fraction of |F dt| per block.
    let model = InsModel::wgs84(scenarios::mems_imu().noise);
    for (x, u) in states() {
        let numeric = numerical_jacobian(&x, |xp| model.propagate(xp, &u, u.cur.dt), 1e-3);
        let phi = model.jacobians(&x, &u, u.cur.dt).Phi;
        let err = (phi - numeric).abs().max();
        let fdt = (phi - M15::identity()).abs().max();
        assert!(err <= 0.05 * fdt, "|Φ − Φ_num| {err:.3e} vs |F dt| {fdt:.3e}");
    }
}

#[test]
fn noise_input_g_matches_perturbed_increments() {
    // Gyro and accelerometer white noise enter through the increments: a rate error n
    // held over dt moves the *nominal* solution by −G n dt relative to the truth.
    let model = InsModel::wgs84(scenarios::mems_imu().noise);
    for (x, u) in states() {
        let dt = u.cur.dt;
        let base = model.propagate(&x, &u, dt);
        let G = InsModel::noise_input(&x.att);
        let mut numeric = SMatrix::<f64, 15, 6>::zeros();
        let h = 1e-4;
        for j in 0..6 {
            let shifted = |sign: f64| {
                let mut v = u;
                let mut e = Vector3::zeros();
                e[j % 3] = sign * h * dt;
                if j < 3 {
                    v.cur.dtheta += e
                } else {
                    v.cur.dvel += e
                }
                model.propagate(&x, &v, dt).ominus(&base)
            };
            // δx = truth ⊖ nominal = −(nominal with noise ⊖ nominal)
            numeric.set_column(j, &(-(shifted(1.0) - shifted(-1.0)) / (2.0 * h * dt)));
        }
        let analytic: SMatrix<f64, 15, 6> = G.fixed_view::<15, 6>(0, 0).into_owned();
        // The first-order G misses O(dt) cross terms (e.g. δp from n_a): compare the
        // blocks G defines (θ from n_g, v from n_a) and require the others to be O(dt).
        compare(
            "G θ←n_g",
            &analytic.fixed_view::<3, 3>(0, 0).into_owned(),
            &numeric.fixed_view::<3, 3>(0, 0).into_owned(),
            1e-2,
        )
        .unwrap();
        compare(
            "G v←n_a",
            &analytic.fixed_view::<3, 3>(3, 3).into_owned(),
            &numeric.fixed_view::<3, 3>(3, 3).into_owned(),
            1e-2,
        )
        .unwrap();
    }
}

#[test]
fn gnss_h_matches_numerical_jacobians() {
    let lever = Vector3::new(0.8, -0.3, -1.2);
    for (x, u) in states() {
        let rate = u.cur.rate();
        check_measurement_model_with_step(&GnssPosition { lever_arm: lever }, &x, 1e-6, 1e-3)
            .unwrap();
        check_measurement_model_with_step(
            &GnssVelocity { lever_arm: lever, gyro_rate: rate },
            &x,
            1e-6,
            1e-3,
        )
        .unwrap();
        check_measurement_model_with_step(
            &GnssPosVel { lever_arm: lever, gyro_rate: rate },
            &x,
            1e-6,
            1e-3,
        )
        .unwrap();
    }
}

#[test]
fn structured_propagation_equals_dense() {
    let model = InsModel::wgs84(scenarios::mems_imu().noise);
    for (x, u) in states() {
        let jac = model.jacobians(&x, &u, u.cur.dt);
        let a = SMatrix::<f64, 15, 15>::from_fn(|r, c| ((r * 7 + c * 3) % 11) as f64 * 0.1);
        let p0 = a * a.transpose() + M15::identity();
        let mut p = M15::zeros();
        model.propagate_covariance(&p0, &jac, &mut p);
        let dense = jac.Phi * p0 * jac.Phi.transpose() + jac.Q;
        assert!((p - dense).abs().max() <= 1e-12 * dense.abs().max());
        // the kernel without AVX2/FMA (what other CPUs run) agrees too
        let mut portable = M15::zeros();
        ins_gnss::model::phi_sandwich_portable(&jac.Phi, &p0, &jac.Q, &mut portable);
        assert!((portable - dense).abs().max() <= 1e-12 * dense.abs().max());
        let product = ins_gnss::model::phi_times(&jac.Phi, &p0);
        assert!((product - jac.Phi * p0).abs().max() <= 1e-12 * (jac.Phi * p0).abs().max());
    }
}
