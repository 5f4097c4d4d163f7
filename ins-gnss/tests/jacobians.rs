//! F, G and H against numerical Jacobians through ⊕/⊖ (the core harness), at states that
//! exercise every term: turning, accelerating, climbing, high latitude, lever arm.

#![allow(non_snake_case)]

use estimator_core::harness::{
    check_combined_calls, check_measurement_model_with_step, compare, numerical_jacobian,
};
use estimator_core::ProcessModel;
use ins_gnss_core::earth::{earth_rate_ned, gravity_ned, radii, transport_rate};
use ins_gnss_core::imu::ImuSample;
use ins_gnss_core::model::{ImuInput, InsModel, M15};
use ins_gnss_core::{GeoPos, GnssPosVel, GnssPosition, GnssVelocity, InsState, Mechanization};
use ins_gnss_sim::scenarios;
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
        let cur = ImuSample { t: 1.0, dt, dtheta: w * dt, dvel: f * dt, odometer: None };
        let prev = ImuSample {
            t: 1.0 - dt,
            dt,
            dtheta: w * dt * 0.98,
            dvel: f * dt * 1.01,
            odometer: None,
        };
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
                    assert!(
                        err <= tol,
                        "{mech:?} state {i}: block ({bi},{bj}) |Δ| {err:.3e} > {tol:.3e}\nanalytic {a}\nnumeric {n}"
                    );
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
fn scale_factor_columns_match_one_step_of_the_21_state_model() {
    // The 21-state Φ against the Jacobian of one real step: first order, like the
    // 15-state one; its scale-factor columns are the ones added here.
    use ins_gnss_core::scale::{InsModel21, InsState21, ScaleFactorNoise};
    let base = InsModel::wgs84(scenarios::mems_imu().noise);
    let scale = ScaleFactorNoise { gyro: Vector3::repeat(1e-4), accel: Vector3::repeat(1e-4) };
    let model = InsModel21 { base, scale };
    for (x, u) in states() {
        let x = InsState21 {
            nav: x,
            sg: Vector3::new(2e-3, -1e-3, 3e-3),
            sa: Vector3::new(-2e-3, 1e-3, 1.5e-3),
        };
        let dt = u.cur.dt;
        let numeric = numerical_jacobian(&x, |xp| model.propagate(xp, &u, dt), 1e-4);
        let phi = model.jacobians(&x, &u, dt).Phi;
        let cols = |m: &SMatrix<f64, 21, 21>| m.columns(15, 6).into_owned();
        let err = (cols(&phi) - cols(&numeric)).abs().max();
        let size = cols(&numeric).rows(0, 15).abs().max().max(1e-12);
        assert!(
            err <= 0.05 * size + 1e-9,
            "scale-factor columns: |Φ − Φ_num| {err:.3e} vs {size:.3e}\n{}\n{}",
            cols(&phi),
            cols(&numeric)
        );
        check_combined_calls(&model, &x, &u, dt).unwrap();
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
fn vehicle_aiding_h_matches_numerical_jacobians() {
    use ins_gnss_core::vehicle::{mounting_matrix, Nhc, Zaru, Zupt};
    let deg = core::f64::consts::PI / 180.0;
    let lever = Vector3::new(-1.4, 0.2, 0.9);
    for (x, u) in states() {
        let rate = u.cur.rate();
        let c_vb = mounting_matrix(&Vector3::new(0.5 * deg, -1.5 * deg, 2.0 * deg));
        let nhc = Nhc { c_vb, lever_arm: lever, gyro_rate: rate };
        check_measurement_model_with_step(&nhc, &x, 1e-6, 1e-4).unwrap();
        check_measurement_model_with_step(&Zupt, &x, 1e-6, 1e-4).unwrap();
        check_measurement_model_with_step(&Zaru, &x, 1e-5, 1e-3).unwrap();
    }
}

#[test]
fn baseline_heading_h_matches_numerical_jacobians() {
    use ins_gnss_core::heading::{BaselineAttitude, BaselineHeading};
    // forward, oblique with a vertical part, backward-left (every state's attitude)
    let baselines =
        [Vector3::new(1.0, 0.0, 0.0), Vector3::new(0.3, -1.1, 0.2), Vector3::new(-0.8, 0.4, -0.1)];
    for (x, _) in states() {
        for b in baselines {
            check_measurement_model_with_step(&BaselineHeading { baseline: b }, &x, 1e-6, 1e-5)
                .unwrap_or_else(|e| panic!("heading {b:?}: {e:?}"));
            check_measurement_model_with_step(&BaselineAttitude { baseline: b }, &x, 1e-6, 1e-5)
                .unwrap_or_else(|e| panic!("heading and pitch {b:?}: {e:?}"));
        }
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
        ins_gnss_core::model::phi_sandwich_portable(&jac.Phi, &p0, &jac.Q, &mut portable);
        assert!((portable - dense).abs().max() <= 1e-12 * dense.abs().max());
        // Q_d is the trapezoid (Φ D Φᵀ + D) dt/2 with D = G Q_c Gᵀ built densely here
        let G = InsModel::noise_input(&x.att);
        let D = G * SMatrix::<f64, 12, 12>::from_diagonal(&model.noise_psd()) * G.transpose();
        let q_ref = (jac.Phi * D * jac.Phi.transpose() + D) * (0.5 * u.cur.dt);
        assert!((jac.Q - q_ref).abs().max() <= 1e-12 * q_ref.abs().max(), "Q_d");
        assert!((model.noise_density(&x.att) - D).abs().max() <= 1e-12 * D.abs().max());
        // the fused epoch and `step` against the separate calls, on both mechanizations
        check_combined_calls(&model, &x, &u, u.cur.dt).unwrap();
        let flat = InsModel {
            mechanization: Mechanization::FlatEarth { reference: x.pos },
            ..model.clone()
        };
        check_combined_calls(&flat, &x, &u, u.cur.dt).unwrap();
        let product = ins_gnss_core::model::phi_times(&jac.Phi, &p0);
        assert!((product - jac.Phi * p0).abs().max() <= 1e-12 * (jac.Phi * p0).abs().max());
        let portable = ins_gnss_core::model::phi_times_portable(&jac.Phi, &p0);
        assert!((portable - jac.Phi * p0).abs().max() <= 1e-12 * (jac.Phi * p0).abs().max());
    }
}

#[test]
fn local_earth_matches_the_separate_earth_functions() {
    use ins_gnss_core::earth::{
        normal_gravity, normal_gravity_gradient, prime_vertical_radius, LocalEarth,
    };
    for lat_deg in [-89.0, -62.0, -10.0, 0.0, 0.3, 30.5, 45.0, 75.0, 89.5] {
        for h in [-400.0, 0.0, 350.0, 9000.0] {
            let lat = f64::to_radians(lat_deg);
            let (s, c) = lat.sin_cos();
            let e = LocalEarth::new(s, c, h);
            let (rm, rn) = radii(lat);
            let rel = |a: f64, b: f64| (a - b).abs() / b.abs().max(1e-300);
            assert!(rel(e.rm, rm) < 1e-14 && rel(e.rn, rn) < 1e-14, "radii at {lat_deg}°");
            assert!(rel(1.0 / e.inv_rmh, rm + h) < 1e-14 && rel(1.0 / e.inv_rnh, rn + h) < 1e-14);
            assert!(rel(e.gravity(), normal_gravity(lat, h)) < 1e-14, "gravity at {lat_deg}°");
            let v = Vector3::new(12.0, -30.0, 1.5);
            assert!((e.transport_rate(&v) - transport_rate(lat, h, &v)).norm() < 1e-18);
            assert!((e.earth_rate() - earth_rate_ned(lat)).norm() < 1e-20);
            // derivatives against central differences (1e-6 rad, 1 m)
            let (dg_dlat, dg_dh) = e.gravity_gradient();
            assert_eq!((dg_dlat, dg_dh), normal_gravity_gradient(lat, h));
            let d = 1e-6;
            let num_lat = (normal_gravity(lat + d, h) - normal_gravity(lat - d, h)) / (2.0 * d);
            let num_h = (normal_gravity(lat, h + 1.0) - normal_gravity(lat, h - 1.0)) / 2.0;
            assert!(
                (dg_dlat - num_lat).abs() < 1e-8,
                "∂g/∂φ at {lat_deg}°: {dg_dlat} vs {num_lat}"
            );
            assert!((dg_dh - num_h).abs() < 1e-12, "∂g/∂h at {lat_deg}°: {dg_dh} vs {num_h}");
            let num_rn =
                (prime_vertical_radius(lat + d) - prime_vertical_radius(lat - d)) / (2.0 * d);
            assert!((e.rn_prime() - num_rn).abs() < 1e-3, "dR_N/dφ at {lat_deg}°");
        }
    }
}

#[test]
fn nearby_latitude_sine_and_cosine_match_the_library() {
    use ins_gnss_core::earth::sin_cos_near;
    for lat0_deg in [-89.9, -45.0, -1.0, 0.0, 0.5, 30.5, 60.0, 89.9] {
        let lat0 = f64::to_radians(lat0_deg);
        let (s0, c0) = lat0.sin_cos();
        // within the series' range, at its edge, and beyond it (the library's values)
        for d in [0.0, 1e-12, -3e-9, 2.3e-7, -5e-6, 1e-4, -9.9e-4, 1e-3, 2e-3, -0.4] {
            let (s, c) = sin_cos_near(lat0 + d, lat0, s0, c0);
            let (s_ref, c_ref) = (lat0 + d).sin_cos();
            assert!((s - s_ref).abs() < 4e-16, "sin at {lat0_deg}° + {d}: {s} vs {s_ref}");
            assert!((c - c_ref).abs() < 4e-16, "cos at {lat0_deg}° + {d}: {c} vs {c_ref}");
        }
    }
    // NaN falls through to the library (NaN out)
    let (s, c) = sin_cos_near(f64::NAN, 0.5, 0.5_f64.sin(), 0.5_f64.cos());
    assert!(s.is_nan() && c.is_nan());
}

/// The filter on the static back-end takes the INS model's fused epoch (structured kernel,
/// `Q_d` never formed); the dynamic and faer back-ends take `jacobians` and their own dense
/// propagation. A drive with GNSS updates ends at the same state and covariance.
#[test]
fn fused_ins_epoch_agrees_with_the_dense_path_on_every_backend() {
    use estimator_core::{CovBackend, DynamicCov, ErrorStateFilter, FaerCov, FixedNoise};
    use ins_gnss_sim::{simulate, Trajectory};
    let (start, segs) = scenarios::drive_600s();
    let traj = Trajectory::new(start, &segs[..3]).unwrap();
    let gnss = scenarios::gnss_1hz(Vector3::zeros());
    let data = simulate(&traj, 200.0, &scenarios::mems_imu(), &gnss, 3);
    let model = InsModel::wgs84(scenarios::mems_imu().noise);
    let P0 = M15::from_fn(|i, j| if i == j { [1e-4, 1e-2, 4.0, 1e-7, 1e-4][i / 3] } else { 0.0 });
    let R = SMatrix::<f64, 6, 6>::from_diagonal(&SVector::<f64, 6>::new(
        1.0, 1.0, 4.0, 2.5e-3, 2.5e-3, 2.5e-3,
    ));
    fn run<B: CovBackend<nalgebra::Const<15>>>(
        backend: B,
        data: &ins_gnss_sim::SimDataset,
        model: &InsModel,
        P0: &M15,
        R: &SMatrix<f64, 6, 6>,
    ) -> (InsState, M15) {
        let x0 = data.truth[0].state.clone();
        let mut f = ErrorStateFilter::with_backend(x0, *P0, FixedNoise, backend).unwrap();
        let mut prev = None;
        let mut fixes = data.gnss.iter().peekable();
        let mut updates = 0;
        for s in data.imu.iter().take(4000) {
            f.predict(model, &ImuInput { prev, cur: *s }, s.dt).unwrap();
            prev = Some(*s);
            if let Some(fix) = fixes.next_if(|g| g.t <= s.t + 1e-9) {
                let m = GnssPosVel { lever_arm: Vector3::zeros(), gyro_rate: s.rate() };
                f.update(&m, &(fix.pos, fix.vel.unwrap().0), R).unwrap();
                updates += 1;
            }
        }
        assert!(updates >= 19, "{updates} GNSS updates in 20 s");
        (f.state().clone(), f.covariance().into_owned())
    }
    let (xs, ps) = run(estimator_core::StaticCov, &data, &model, &P0, &R);
    for (name, (x, p)) in [
        ("dynamic", run(DynamicCov::default(), &data, &model, &P0, &R)),
        ("faer", run(FaerCov::default(), &data, &model, &P0, &R)),
    ] {
        let scale = ps.abs().max();
        let gap = (p - ps).abs().max();
        assert!(gap <= 1e-12 * scale, "{name}: covariance differs by {gap:e} (scale {scale:e})");
        let dx = x.ominus(&xs);
        assert!(dx.norm() < 1e-9, "{name}: state differs by {dx}");
    }
}

/// NaN or infinity in an IMU sample (increments or interval) through the fused epoch: a
/// typed error naming the non-finite quantity, the filter unchanged.
#[test]
fn bad_imu_input_is_a_typed_error_through_the_fused_epoch() {
    use estimator_core::{ErrorStateFilter, FilterError, FixedNoise};
    let model = InsModel::wgs84(scenarios::mems_imu().noise);
    let (x, u) = states().remove(0);
    let P0 = M15::identity() * 1e-2;
    let mut bad = [u; 3];
    bad[0].cur.dvel.y = f64::NAN;
    bad[1].cur.dtheta.x = f64::INFINITY;
    bad[2].cur.dt = f64::NAN;
    for input in bad {
        let x0 = x.clone();
        let mut f = ErrorStateFilter::new(x0.clone(), P0, FixedNoise).unwrap();
        let err = f.predict(&model, &input, 0.005).unwrap_err();
        assert!(matches!(err, FilterError::NonFinite { .. }), "{err}");
        // unchanged, component by component
        let s = f.state();
        let gaps = [
            s.pos.lat - x0.pos.lat,
            s.pos.lon - x0.pos.lon,
            s.pos.h - x0.pos.h,
            (s.vel - x0.vel).norm(),
            (s.att.matrix() - x0.att.matrix()).norm(),
            (s.bg - x0.bg).norm() + (s.ba - x0.ba).norm(),
            (*f.covariance() - P0).abs().max(),
        ];
        assert!(gaps.iter().all(|g| g.abs() < 1e-300), "{gaps:?}");
    }
}

/// The fixes' persisting error as states (18 and 24): Φ of the fix block against central
/// differences (its decay), the fused step and `step` against the separate calls, and the
/// fix model's H (the identity on the fix block's position rows) against numerical
/// differences, for a position and a position + velocity fix.
#[test]
fn fix_error_states_match_numerical_jacobians() {
    use ins_gnss_core::fix_error::{
        FixErrorModel, InsModel21Fe, InsModelFe, InsState21Fe, InsStateFe,
    };
    use ins_gnss_core::navigator::OnFixError;
    use ins_gnss_core::scale::{InsModel21, InsState21, ScaleFactorNoise};
    let fix = FixErrorModel { sigma: Vector3::new(1.5, 1.5, 3.0), tau: 100.0 };
    let model = InsModelFe { base: InsModel::wgs84(scenarios::mems_imu().noise), fix };
    let lever = Vector3::new(0.8, -0.3, -1.2);
    for (x, u) in states() {
        let dt = u.cur.dt;
        let x = InsStateFe { nav: x, fix: Vector3::new(0.7, -1.1, 2.3) };
        let numeric = numerical_jacobian(&x, |xp| model.propagate(xp, &u, dt), 1e-4);
        let phi = model.jacobians(&x, &u, dt).Phi;
        let block = |m: &SMatrix<f64, 18, 18>| m.fixed_view::<3, 3>(15, 15).into_owned();
        compare("Φ fix block", &block(&phi), &block(&numeric), 1e-6).unwrap();
        check_combined_calls(&model, &x, &u, dt).unwrap();
        let rate = u.cur.rate();
        let pos = GnssPosition { lever_arm: lever };
        let pv = GnssPosVel { lever_arm: lever, gyro_rate: rate };
        check_measurement_model_with_step(&OnFixError::<InsStateFe, _>::new(&pos), &x, 1e-6, 1e-3)
            .unwrap();
        check_measurement_model_with_step(&OnFixError::<InsStateFe, _>::new(&pv), &x, 1e-6, 1e-3)
            .unwrap();
    }
    let scale = ScaleFactorNoise { gyro: Vector3::repeat(1e-4), accel: Vector3::repeat(1e-4) };
    let base = InsModel21 { base: InsModel::wgs84(scenarios::mems_imu().noise), scale };
    let model = InsModel21Fe { base, fix };
    for (x, u) in states() {
        let nav = InsState21 { nav: x, sg: Vector3::new(2e-3, -1e-3, 3e-3), sa: Vector3::zeros() };
        let x = InsState21Fe { nav, fix: Vector3::new(-0.4, 0.9, -1.6) };
        check_combined_calls(&model, &x, &u, u.cur.dt).unwrap();
        let pos = GnssPosition { lever_arm: lever };
        check_measurement_model_with_step(
            &OnFixError::<InsState21Fe, _>::new(&pos),
            &x,
            1e-6,
            1e-3,
        )
        .unwrap();
    }
}

/// The calibration states (22): the fused step and `step` against the separate calls, the
/// random walks' Φ block the identity against central differences, the fix models on
/// them (the state's lever arm, the prediction moved by the time offset along its rate)
/// and the NHC and odometer on them (`C_vb` corrected by the mounting state; the roll's
/// column zero, the others) against numerical differences, every item estimated; an item
/// switched off has zero columns.
#[test]
fn calibration_states_match_numerical_jacobians() {
    use estimator_core::MeasurementModel;
    use ins_gnss_core::calibration::{
        Calibration, InsModelCal, InsStateCal, OnCalibration, OnMounting,
    };
    use ins_gnss_core::vehicle::{mounting_matrix, Nhc, Odometer};
    use manifolds::Rn;
    let calibration = Calibration::default();
    let model = InsModelCal { base: InsModel::wgs84(scenarios::mems_imu().noise), calibration };
    let lever = Vector3::new(0.1, 0.2, -0.3);
    let c0 = mounting_matrix(&Vector3::new(0.01, -0.02, 0.03));
    for (x, u) in states() {
        let dt = u.cur.dt;
        let cal = Rn::<11>::from([0.8, -0.3, -1.2, 0.04, 0.02, -0.03, 0.05, 0.02, -1.1, 0.3, 0.6]);
        let x = InsStateCal { nav: x, cal };
        let numeric = numerical_jacobian(&x, |xp| model.propagate(xp, &u, dt), 1e-4);
        let phi = model.jacobians(&x, &u, dt).Phi;
        let block = |m: &SMatrix<f64, 26, 26>| m.fixed_view::<11, 11>(15, 15).into_owned();
        compare("Φ calibration block", &block(&phi), &block(&numeric), 1e-9).unwrap();
        check_combined_calls(&model, &x, &u, dt).unwrap();
        let (rate, force) = (u.cur.rate(), u.cur.specific_force());
        let pos = GnssPosition { lever_arm: lever };
        let pv = GnssPosVel { lever_arm: lever, gyro_rate: rate };
        let on_pos = OnCalibration::new(&pos, force, calibration);
        let on_pv = OnCalibration::new(&pv, force, calibration);
        check_measurement_model_with_step(&on_pos, &x, 1e-6, 1e-3).unwrap();
        check_measurement_model_with_step(&on_pv, &x, 1e-6, 1e-3).unwrap();
        let wheel = Vector3::new(-1.2, 0.1, 0.4);
        let nhc = Nhc { c_vb: c0, lever_arm: wheel, gyro_rate: rate };
        let odo = Odometer { c_vb: c0, lever_arm: wheel, gyro_rate: rate };
        // (central differences on every column but the roll's, which is zero by design)
        let h_nhc = OnMounting::new(&nhc, calibration).jacobian(&x).H;
        let h_odo = OnMounting::new(&odo, calibration).jacobian(&x).H;
        for k in 0..26 {
            let mut d = SVector::<f64, 26>::zeros();
            d[k] = 1e-6;
            let (xp, xm) = (x.oplus(&d), x.oplus(&(-d)));
            let on = OnMounting::new(&nhc, calibration);
            let num = (on.predict(&xp) - on.predict(&xm)) / 2e-6;
            let on = OnMounting::new(&odo, calibration);
            let num_odo = (on.predict(&xp) - on.predict(&xm)) / 2e-6;
            if k == 19 {
                assert_eq!(h_nhc.column(k).abs().max() + h_odo.column(k).abs().max(), 0.0);
                continue;
            }
            let scale = 1.0 + num.abs().max().max(num_odo.abs().max());
            let err =
                (h_nhc.column(k) - num).abs().max().max((h_odo.column(k) - num_odo).abs().max());
            assert!(err <= 1e-5 * scale, "column {k}: {err}");
        }
        // the odometer's scale and wheel point are seen by the odometer only
        assert_eq!(h_nhc.fixed_columns::<4>(22).abs().max(), 0.0);
        assert!(h_odo.fixed_columns::<4>(22).abs().max() > 0.0);
        let off = Calibration {
            lever_arm: false,
            time_offset: false,
            mounting: false,
            odometer: false,
            ..calibration
        };
        let h = OnCalibration::new(&pv, force, off).jacobian(&x).H;
        assert_eq!(h.fixed_columns::<11>(15).abs().max(), 0.0);
        let h = OnMounting::new(&nhc, off).jacobian(&x).H;
        assert_eq!(h.fixed_columns::<11>(15).abs().max(), 0.0);
        let h = OnMounting::new(&odo, off).jacobian(&x).H;
        assert_eq!(h.fixed_columns::<11>(15).abs().max(), 0.0);
    }
}
