//! The rate path: an IMU log of instantaneous rate samples (`ω(t_k)`, `f(t_k)`), turned
//! into increments by the reader, against the exact integrals of the simulator — on
//! constant-rate coning, constant specific force and the simulated car (turns with
//! changing rate) — and the filter on the rate-type car against the same car given as
//! increments, with the same sensor errors.

use crate::common;

use estimator_core::{FixedNoise, NoObserver};
use ins_gnss_core::imu::ImuSample;
use ins_gnss_core::{GnssConfig, InitialState, InsModel, InsState, Navigator};
use ins_gnss_io::{BadLinePolicy, ImuFormat, ImuReader};
use ins_gnss_sim::simulate_from;
use manifolds::Manifold;
use nalgebra::Vector3;

/// A rate-type IMU reader over `text` at `rate` Hz.
fn rate_reader(text: String, rate: f64) -> ImuReader<std::io::Cursor<Vec<u8>>> {
    ImuReader::new(
        std::io::Cursor::new(text.into_bytes()),
        std::path::Path::new("rates.csv"),
        ImuFormat::Rates,
        rate,
        5.0,
        BadLinePolicy::Error,
    )
}

/// The reader's conversion of a rate log: the samples written as the rate-type text
/// format (`t,gx,gy,gz,ax,ay,az`, full precision) and read back by `ImuReader`.
fn from_rates(t: &[f64], w: &[Vector3<f64>], f: &[Vector3<f64>]) -> Vec<ImuSample> {
    let mut text = String::from("t,gx,gy,gz,ax,ay,az\n");
    for k in 0..t.len() {
        text += &format!(
            "{:.17e},{:.17e},{:.17e},{:.17e},{:.17e},{:.17e},{:.17e}\n",
            t[k], w[k].x, w[k].y, w[k].z, f[k].x, f[k].y, f[k].z
        );
    }
    let rate = 1.0 / (t[1] - t[0]);
    let mut r = rate_reader(text, rate);
    let mut out = Vec::new();
    while let Some(s) = r.next_sample().unwrap() {
        out.push(s);
    }
    // the first record starts the log: the intervals are those after it
    assert_eq!(out.len(), t.len());
    out.remove(0);
    out
}

#[test]
fn increments_from_instantaneous_rates_match_the_exact_integrals() {
    let setup = common::drive_setup(100.0, None);
    let ex = &setup.exact;
    let t: Vec<f64> = ex.kinematics.iter().map(|k| k.t).collect();
    let w: Vec<Vector3<f64>> = ex.kinematics.iter().map(|k| k.w_ib_b).collect();
    let f: Vec<Vector3<f64>> = ex.kinematics.iter().map(|k| k.f_b).collect();
    let conv = from_rates(&t, &w, &f);
    let (mut dth, mut dv) = (0.0f64, 0.0f64);
    for (c, e) in conv.iter().zip(&ex.samples) {
        dth = dth.max((c.dtheta - e.dtheta).norm());
        dv = dv.max((c.dvel - e.dvel).norm());
    }
    // the car's rates jump at its segment boundaries (a turn starts at once): there the
    // interval holding the jump is off by half the step; elsewhere the trapezoid is exact
    // for rates linear over an interval
    let (mut dth_in, mut dv_in) = (0.0f64, 0.0f64);
    for (k, (c, e)) in conv.iter().zip(&ex.samples).enumerate() {
        let smooth = (k.saturating_sub(1)..(k + 2).min(w.len() - 1))
            .all(|i| (w[i + 1] - w[i]).norm() < 1e-3 && (f[i + 1] - f[i]).norm() < 1e-2);
        if smooth {
            dth_in = dth_in.max((c.dtheta - e.dtheta).norm());
            dv_in = dv_in.max((c.dvel - e.dvel).norm());
        }
    }
    println!(
        "drive_600s at 100 Hz: largest increment error from rates {dth:.3e} rad, {dv:.3e} m/s \
         (at a rate step); away from the steps {dth_in:.3e} rad, {dv_in:.3e} m/s"
    );
    assert!(dth < 1e-3 && dv < 2e-2, "{dth} {dv}");
    assert!(dth_in < 1e-9 && dv_in < 1e-7, "{dth_in} {dv_in}");
}

/// Coning: `ω(t) = Ω [−(1 − cos β), −sin β sin Ωt, sin β cos Ωt]` (body), the classic
/// motion whose attitude a first-order integration gets wrong by a drift.
fn coning_rate(t: f64, beta: f64, big_omega: f64) -> Vector3<f64> {
    let (s, c) = (beta.sin(), beta.cos());
    Vector3::new(
        -big_omega * (1.0 - c),
        -big_omega * s * (big_omega * t).sin(),
        big_omega * s * (big_omega * t).cos(),
    )
}

#[test]
fn coning_attitude_from_rates_drifts_no_more_than_from_exact_increments() {
    use ins_gnss_core::mechanization::{coning, Increments};
    use manifolds::So3;
    let (beta, big_omega, rate, secs): (f64, f64, f64, f64) =
        (1f64.to_radians(), 2.0 * std::f64::consts::PI * 2.0, 100.0, 10.0);
    let dt = 1.0 / rate;
    let n = (secs * rate) as usize;
    // the reference: Ṙ = R [ω×] by RK4 on the quaternion at 10 µs
    let h = 1e-5;
    let mut q = nalgebra::UnitQuaternion::identity();
    let deriv = |q: &nalgebra::Quaternion<f64>, t: f64| {
        let w = coning_rate(t, beta, big_omega);
        q * nalgebra::Quaternion::new(0.0, w.x, w.y, w.z) * 0.5
    };
    let steps = (secs / h).round() as usize;
    for i in 0..steps {
        let t = i as f64 * h;
        let y = q.into_inner();
        let k1 = deriv(&y, t);
        let k2 = deriv(&(y + k1 * (h / 2.0)), t + h / 2.0);
        let k3 = deriv(&(y + k2 * (h / 2.0)), t + h / 2.0);
        let k4 = deriv(&(y + k3 * h), t + h);
        q = nalgebra::UnitQuaternion::new_normalize(
            y + (k1 + k2 * 2.0 + k3 * 2.0 + k4) * (h / 6.0),
        );
    }
    let truth = So3::from_quaternion(q);
    // exact increments (closed form) and the reader's increments from rate samples
    let exact_inc = |k: usize| {
        let (ta, tb) = ((k - 1) as f64 * dt, k as f64 * dt);
        let (s, c) = (beta.sin(), beta.cos());
        Vector3::new(
            -big_omega * (1.0 - c) * dt,
            s * ((big_omega * tb).cos() - (big_omega * ta).cos()),
            s * ((big_omega * tb).sin() - (big_omega * ta).sin()),
        )
    };
    let zero = Vector3::zeros();
    let times: Vec<f64> = (0..=n + 1).map(|k| k as f64 * dt).collect();
    let rates: Vec<Vector3<f64>> = times.iter().map(|t| coning_rate(*t, beta, big_omega)).collect();
    // (a specific force well above zero: the reader refuses a first |f| far below gravity)
    let force = vec![Vector3::new(0.0, 0.0, -9.8); times.len()];
    let read = from_rates(&times, &rates, &force);
    let from_rates = |k: usize| read[k - 1].dtheta;
    let integrate = |inc: &dyn Fn(usize) -> Vector3<f64>| {
        let mut att = So3::identity();
        let mut prev = Vector3::zeros();
        for k in 1..=n {
            let d = inc(k);
            let i = Increments { dtheta_prev: prev, dvel_prev: zero, dtheta: d, dvel: zero, dt };
            att = att * So3::exp(&coning(&i));
            prev = d;
        }
        truth.ominus(&att).norm()
    };
    let (e_exact, e_rates) = (integrate(&exact_inc), integrate(&from_rates));
    println!(
        "coning β = 1°, 2 Hz, sampled at 100 Hz, 10 s: attitude error from exact increments \
         {:.3e} rad, from instantaneous rates {:.3e} rad",
        e_exact, e_rates
    );
    assert!(e_exact < 1e-6, "{e_exact}");
    assert!(e_rates <= 2.0 * e_exact.max(1e-7), "{e_rates} vs {e_exact}");
}

/// Roll and pitch RMS (deg) after 30 s of the filter over `imu`.
fn roll_pitch_rms(
    setup: &common::Setup,
    data: &ins_gnss_sim::SimDataset,
    imu: &[ImuSample],
) -> (f64, f64) {
    let truth0 = &data.truth[0].state;
    let std = common::initial_std();
    let start = InsState { bg: Vector3::zeros(), ba: Vector3::zeros(), ..truth0.clone() };
    let init = InitialState { time: data.truth[0].t, state: start, std };
    let cfg = GnssConfig { lever_arm: setup.gnss.lever_arm, ..GnssConfig::default() };
    let mut nav =
        Navigator::new(&init, InsModel::wgs84(common::imu_errors().noise), FixedNoise, cfg)
            .unwrap();
    let (mut r, mut p, mut n) = (0.0, 0.0, 0.0);
    let mut g = 0;
    let mut out = Vec::new();
    for (k, s) in imu.iter().enumerate() {
        let first = g;
        while g < data.gnss.len() && data.gnss[g].t <= s.t + 1e-9 {
            g += 1;
        }
        out.clear();
        nav.process_into(s, &data.gnss[first..g], &mut NoObserver, &mut out).unwrap();
        if s.t > 30.0 {
            let e = data.truth[k + 1].state.ominus(nav.state());
            r += e[0] * e[0];
            p += e[1] * e[1];
            n += 1.0;
        }
    }
    ((r / n).sqrt().to_degrees(), (p / n).sqrt().to_degrees())
}

#[test]
fn a_rate_type_car_navigates_as_well_as_the_same_car_as_increments() {
    let setup = common::drive_setup(100.0, Some((300.0, 330.0)));
    let ex = &setup.exact;
    let (mut inc, mut rate) = ((0.0, 0.0), (0.0, 0.0));
    let seeds = 4;
    for seed in 0..seeds {
        let data = simulate_from(ex, &setup.traj, &common::imu_errors(), &setup.gnss, seed);
        // the same sensor errors on instantaneous samples: the error of each noisy
        // increment, as a rate, added to the exact rate at the interval's end
        let t: Vec<f64> = ex.kinematics.iter().map(|k| k.t).collect();
        let mut w: Vec<Vector3<f64>> = ex.kinematics.iter().map(|k| k.w_ib_b).collect();
        let mut f: Vec<Vector3<f64>> = ex.kinematics.iter().map(|k| k.f_b).collect();
        for (k, (noisy, exact)) in data.imu.iter().zip(&ex.samples).enumerate() {
            w[k + 1] += (noisy.dtheta - exact.dtheta) / exact.dt;
            f[k + 1] += (noisy.dvel - exact.dvel) / exact.dt;
        }
        w[0] += (data.imu[0].dtheta - ex.samples[0].dtheta) / ex.samples[0].dt;
        f[0] += (data.imu[0].dvel - ex.samples[0].dvel) / ex.samples[0].dt;
        let a = roll_pitch_rms(&setup, &data, &data.imu);
        let b = roll_pitch_rms(&setup, &data, &from_rates(&t, &w, &f));
        inc = (inc.0 + a.0 / seeds as f64, inc.1 + a.1 / seeds as f64);
        rate = (rate.0 + b.0 / seeds as f64, rate.1 + b.1 / seeds as f64);
    }
    println!(
        "roll/pitch RMS after 30 s, {seeds} seeds: increments {:.4}°/{:.4}°, rates {:.4}°/{:.4}°",
        inc.0, inc.1, rate.0, rate.1
    );
    assert!(rate.0 <= inc.0 * 1.02 && rate.1 <= inc.1 * 1.02, "{rate:?} vs {inc:?}");
}

#[test]
fn each_rate_sample_reports_its_own_line() {
    // the reader looks one sample ahead; `line()` is still the returned sample's line
    let mut text = String::from("t,gx,gy,gz,ax,ay,az\n");
    for k in 0..5 {
        text += &format!("{},0.01,0.0,0.0,0.0,0.0,-9.8\n", k as f64 * 0.01);
    }
    let mut r = rate_reader(text, 100.0);
    let mut lines = Vec::new();
    while let Some(s) = r.next_sample().unwrap() {
        lines.push((s.t, r.line()));
        assert!((s.dtheta.x - 1e-4).abs() < 1e-15, "a constant rate integrates exactly");
    }
    let expected: Vec<(f64, usize)> = (0..5).map(|k| (k as f64 * 0.01, k + 2)).collect();
    assert_eq!(lines, expected);
}

#[test]
fn a_mapped_rate_log_in_datasheet_units_reads_as_the_native_one() {
    // the same rates as a logger writes them: an index, time in ms, deg/s, g, FLU axes
    let (deg, g) = (std::f64::consts::PI / 180.0, 9.80665);
    let rows: Vec<(f64, Vector3<f64>, Vector3<f64>)> = (0..50)
        .map(|k| {
            let t = k as f64 * 0.01;
            (t, Vector3::new(0.1 * t.sin(), 0.02, -0.3 * t), Vector3::new(0.5, -0.2 * t, -9.8))
        })
        .collect();
    let mut native = String::from("t,gx,gy,gz,ax,ay,az\n");
    let mut logger = String::from("k;t_ms;wx_dps;wy_dps;wz_dps;ax_g;ay_g;az_g;flags\n");
    for (k, (t, w, f)) in rows.iter().enumerate() {
        native += &format!(
            "{t:.17e},{:.17e},{:.17e},{:.17e},{:.17e},{:.17e},{:.17e}\n",
            w.x, w.y, w.z, f.x, f.y, f.z
        );
        logger += &format!(
            "{k};{:.17e};{:.17e};{:.17e};{:.17e};{:.17e};{:.17e};{:.17e};ok\n",
            t * 1e3,
            w.x / deg,
            -w.y / deg,
            -w.z / deg,
            f.x / g,
            -f.y / g,
            -f.z / g
        );
    }
    let columns: ins_gnss::config::ImuColumns = toml::from_str(
        r#"time = "t_ms"
time_unit = "ms"
gyro = ["wx_dps", "wy_dps", "wz_dps"]
gyro_unit = "deg/s"
accel = ["ax_g", "ay_g", "az_g"]
accel_unit = "g"
axes = "flu""#,
    )
    .unwrap();
    let read = |text: String, map: Option<ins_gnss_io::ColumnMap>| {
        let mut r = rate_reader(text, 100.0);
        if let Some(m) = map {
            r = r.with_columns(m);
        }
        let mut out = Vec::new();
        while let Some(s) = r.next_sample().unwrap() {
            out.push(s);
        }
        out
    };
    let a = read(native, None);
    let b = read(logger, Some(columns.map(true).unwrap()));
    assert_eq!(a.len(), rows.len());
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert!((x.t - y.t).abs() < 1e-12);
        assert!(
            (x.dtheta - y.dtheta).norm() < 1e-15 && (x.dvel - y.dvel).norm() < 1e-13,
            "{x:?} {y:?}"
        );
    }
}
