"""FilterPy's surface on ``estimator`` (issue 76), each call against FilterPy 2.0.0 from
PyPI on the same scenario, to 1e-9. The scenarios are those FilterPy's own test suite
exercises its classes with (``filterpy/kalman/tests/test_kf.py``, ``test_ukf.py``,
``test_ekf.py``: a noisy constant-velocity track filtered update-first and by
``batch_filter`` with missing measurements, a univariate filter with a control input,
shape checks, the UKF's batch filter and smoother), written here anew; then what
FilterPy users met on ``estimator`` before: ``alpha`` ignored, a second run smoothed
with the first, the two smoothing paths disagreeing, sizes above the compiled ones,
filters that could not be copied, and errors Python does not recognise."""

import copy
import pickle

import numpy as np
import pytest
from filterpy import common as fp_common
from filterpy.kalman import KalmanFilter as FpKF
from filterpy.kalman import MerweScaledSigmaPoints as FpPoints
from filterpy.kalman import UnscentedKalmanFilter as FpUKF

import estimator
from estimator import common
from estimator.filterpy import (ExtendedKalmanFilter, KalmanFilter, MerweScaledSigmaPoints,
                                UnscentedKalmanFilter)

TOL = 1e-9


def assert_close(a, b, tol=TOL, what=""):
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape, f"{what}: shape {a.shape} against {b.shape}"
    scale = max(1.0, float(np.abs(b).max()) if b.size else 1.0)
    err = float(np.abs(a - b).max()) if a.size else 0.0
    assert err <= tol * scale, f"{what}: differs by {err:.3g} (scale {scale:.3g})"


def cv_filter(cls, x_ndim=2, **kw):
    """A constant-velocity filter as FilterPy's tests build it (P 1000, R 5, Q 1e-4)."""
    f = cls(dim_x=2, dim_z=1, **kw)
    f.x = np.array([[2.0], [0.0]]) if x_ndim == 2 else np.array([2.0, 0.0])
    f.F = np.array([[1.0, 1.0], [0.0, 1.0]])
    f.H = np.array([[1.0, 0.0]])
    f.P *= 1000.0
    f.R = 5
    f.Q = 0.0001
    return f


def track(seed=3, n=100):
    rng = np.random.default_rng(seed)
    return [t + rng.normal() * 20 for t in range(n)]


# --- FilterPy's scenarios -------------------------------------------------------------

@pytest.mark.parametrize("x_ndim", [1, 2])
def test_noisy_track_update_first_then_batch_with_gaps(x_ndim):
    ours, theirs = cv_filter(KalmanFilter, x_ndim), cv_filter(FpKF, x_ndim)
    for z in track():
        for f in (ours, theirs):
            f.update(z)
            f.predict()
        assert_close(ours.x, theirs.x, what="x")
        assert_close(ours.P, theirs.P, what="P")
        assert_close(ours.y, theirs.y, what="y")
        assert_close(ours.K, theirs.K, what="K")
        assert_close(ours.SI, theirs.SI, what="SI")
        assert_close(ours.log_likelihood, theirs.log_likelihood, what="log_likelihood")
    zs = [13.0, None, 1.0, 2.0] * 10
    for update_first in (False, True):
        for f in (ours, theirs):
            f.x = np.array([[2.0, 0.0]]).T
            f.P = np.eye(2) * 100.0
        a, b = ours.batch_filter(zs, update_first=update_first), theirs.batch_filter(
            zs, update_first=update_first)
        for k in range(4):
            assert_close(a[k], b[k], what=f"batch_filter[{k}]")
        s1, s2 = ours.rts_smoother(a[0], a[1]), theirs.rts_smoother(b[0], b[1])
        for k in range(4):
            assert_close(s1[k], s2[k], what=f"rts_smoother[{k}]")


def test_univariate_with_a_control_input():
    fs = []
    for cls in (KalmanFilter, FpKF):
        f = cls(dim_x=1, dim_z=1, dim_u=1)
        f.x = np.array([[0.0]])
        f.P *= 50
        f.H, f.F, f.B = np.array([[1.0]]), np.array([[1.0]]), np.array([[1.0]])
        f.Q, f.R = 0.02, f.R * 0.1
        fs.append(f)
    for i in range(50):
        for f in fs:
            f.predict(u=np.array([[0.5]]))
            f.update(i)
        assert_close(fs[0].x, fs[1].x, what="x")
        assert_close(fs[0].P, fs[1].P, what="P")


def test_alpha_is_fading_memory_as_filterpy_defines_it():
    """``alpha = 1.05`` was accepted and ignored (P[0,0] 0.273 against 0.313)."""
    fs = [cv_filter(KalmanFilter), cv_filter(FpKF)]
    for f in fs:
        f.alpha = 1.05
        f.P = np.eye(2)
        f.Q = np.diag([1e-3, 1e-3])
    for z in track(7, 40):
        for f in fs:
            f.predict()
            f.update(z)
    assert fs[0].alpha == fs[1].alpha == 1.05
    assert_close(fs[0].P, fs[1].P, what="P")
    assert_close(fs[0].x, fs[1].x, what="x")
    plain = cv_filter(KalmanFilter)
    plain.P, plain.Q = np.eye(2), np.diag([1e-3, 1e-3])
    for z in track(7, 40):
        plain.predict()
        plain.update(z)
    assert fs[0].P[0, 0] > 1.1 * plain.P[0, 0], "alpha changed nothing"
    with pytest.raises(ValueError, match="alpha"):
        fs[0].alpha = -1.0


def test_steady_state_prediction_update_and_the_what_if_calls():
    fs = [cv_filter(KalmanFilter), cv_filter(FpKF)]
    for z in track(5, 30):
        for f in fs:
            f.predict()
            f.update(z)
    for f in fs:
        f.K = np.copy(fs[1].K)
    for z in track(6, 20):
        outs = []
        for f in fs:
            outs.append((f.get_prediction(), f.get_update(z), f.log_likelihood_of(z)))
            f.predict_steadystate()
            outs.append((f.residual_of(z), f.measurement_of_state(f.x)))
            f.update_steadystate(z)
        for a, b in zip(outs[0] + outs[1], outs[2] + outs[3]):
            for u, v in zip(a, b) if isinstance(a, tuple) else ((a, b),):
                assert_close(u, v, what="what-if")
        assert_close(fs[0].x, fs[1].x, what="steady-state x")
        assert_close(fs[0].P, fs[1].P, what="steady-state P")


def test_sequential_and_correlated_updates():
    def make(cls):
        f = cls(dim_x=4, dim_z=2)
        f.x = np.array([[0.0, 1.0, 0.0, 0.5]]).T
        f.F = np.array([[1, 1, 0, 0], [0, 1, 0, 0], [0, 0, 1, 1], [0, 0, 0, 1.0]])
        f.H = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
        f.R = np.diag([2.0, 3.0])
        q = fp_common.Q_discrete_white_noise(2, 1.0, 0.1)
        f.Q = np.block([[q, np.zeros((2, 2))], [np.zeros((2, 2)), q]])
        f.P *= 10
        f.M = np.full((4, 2), 0.05)
        return f

    fs = [make(KalmanFilter), make(FpKF)]
    rng = np.random.default_rng(11)
    for k in range(30):
        z = np.array([[k + rng.normal()], [0.5 * k + rng.normal()]])
        for f in fs:
            f.predict()
            if k % 2:
                f.update_sequential(0, z[0, 0])
                f.update_sequential(1, z[1, 0])
            else:
                f.update_correlated(z)
        for name in ("x", "P", "y", "K"):
            assert_close(getattr(fs[0], name), getattr(fs[1], name), what=f"{name} at {k}")


def test_shapes_none_updates_and_dimension_checks():
    ours, theirs = KalmanFilter(3, 2), FpKF(3, 2)
    for name in ("x", "P", "Q", "R", "F", "H", "K", "y", "S", "SI", "M", "z"):
        assert np.shape(getattr(ours, name)) == np.shape(getattr(theirs, name)), name
    assert ours.mahalanobis == 0.0 and np.all(ours.SI == 0)
    f = cv_filter(KalmanFilter)
    f.predict()
    f.update(3.0)
    assert f.y.shape == (1, 1)
    f.update(None)
    assert f.y.shape == (1, 1) and f.y[0, 0] == 0.0
    with pytest.raises(ValueError, match="^z has shape"):
        f.update([1.0, 2.0])
    with pytest.raises(ValueError, match="^z has shape"):
        f.update(np.array([[[3.0]]]))
    f.test_matrix_dimensions()
    f.test_matrix_dimensions(z=[[3.0]])
    f.H = np.array([[1.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match="^H"):
        f.test_matrix_dimensions()
    two = KalmanFilter(4, 2)
    two.H = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0]])
    with pytest.raises(ValueError, match="^z"):
        two.test_matrix_dimensions(z=[3.0])
    two.test_matrix_dimensions(z=[[3.0], [3.0]])
    with pytest.raises(ValueError, match="^z has shape"):
        two.update(3.0)


def test_the_books_radar_ekf_with_a_flat_state_and_a_range_dependent_r():
    """Chapter 11's radar (FilterPy's ``test_ekf.py`` scenario): a 1-D ``x`` (position,
    velocity, altitude), a scalar range, ``R`` passed per update."""
    from filterpy.kalman import ExtendedKalmanFilter as FpEKF

    def h_jac(x):
        d = np.hypot(x[0], x[2])
        return np.array([[x[0] / d, 0.0, x[2] / d]])

    def h(x):
        return np.hypot(x[0], x[2])

    dt = 0.05
    fs = []
    for cls in (ExtendedKalmanFilter, FpEKF):
        f = cls(dim_x=3, dim_z=1)
        f.x = np.array([-10.0, 90.0, 1100.0])
        f.F = np.eye(3) + np.array([[0, 1, 0], [0, 0, 0], [0, 0, 0.0]]) * dt
        f.Q = np.diag([0.1, 0.1, 0.1]) * dt
        f.P *= 50
        fs.append(f)
    rng = np.random.default_rng(21)
    pos, alt = 0.0, 1000.0
    for k in range(300):
        pos += 100 * dt
        z = np.hypot(pos, alt) + rng.normal() * 5
        for f in fs:
            f.update(np.array([z]), h_jac, h, R=h(f.x) * 0.05)
            f.predict()
        assert_close(fs[0].x, fs[1].x, what=f"x at {k}")
        assert_close(fs[0].P, fs[1].P, what=f"P at {k}")


# --- the unscented filter ------------------------------------------------------------

def cv2_fx(x, dt):
    F = np.array([[1, dt, 0, 0], [0, 1, 0, 0], [0, 0, 1, dt], [0, 0, 0, 1.0]])
    return F @ x


def radar_hx(x):
    return np.array([np.hypot(x[0], x[2]), np.arctan2(x[2], x[0])])


def make_ukf(cls, points_cls, **kw):
    points = points_cls(4, alpha=0.3, beta=2.0, kappa=0.0)
    f = cls(dim_x=4, dim_z=2, dt=1.0, hx=radar_hx, fx=cv2_fx, points=points, **kw)
    f.x = np.array([100.0, 2.0, 50.0, -1.0])
    f.P = np.diag([25.0, 4.0, 25.0, 4.0])
    f.R = np.diag([0.5 ** 2, 0.01 ** 2])
    f.Q = fp_common.Q_discrete_white_noise(2, 1.0, 0.05, block_size=2)
    return f


def radar_zs(n=40, seed=2):
    rng = np.random.default_rng(seed)
    x = np.array([100.0, 2.0, 50.0, -1.0])
    zs = []
    for _ in range(n):
        x = cv2_fx(x, 1.0)
        zs.append(radar_hx(x) + rng.normal(size=2) * [0.5, 0.01])
    return zs


def test_ukf_batch_filter_and_rts_smoother_equal_filterpy():
    ours, theirs = make_ukf(UnscentedKalmanFilter, MerweScaledSigmaPoints), make_ukf(
        FpUKF, FpPoints)
    zs = radar_zs()
    zs[5] = None
    a, b = ours.batch_filter(zs), theirs.batch_filter(zs)
    assert_close(a[0], b[0], what="means")
    assert_close(a[1], b[1], what="covariances")
    s1, s2 = ours.rts_smoother(a[0], a[1]), theirs.rts_smoother(b[0], b[1])
    for k, name in enumerate(("xs", "Ps", "Ks")):
        assert_close(s1[k], s2[k], what=name)
    assert np.trace(s1[1][0]) < np.trace(a[1][0]), "the smoother did not reduce P"


def test_ukf_two_updates_between_predictions_and_cross_variance():
    fs = [make_ukf(UnscentedKalmanFilter, MerweScaledSigmaPoints), make_ukf(FpUKF, FpPoints)]
    for z in radar_zs(15, 4):
        for f in fs:
            f.predict()
            f.update(z)
            f.compute_process_sigmas(0.0)
            f.update(z * [1.0, 1.0] + [0.2, 0.0])
        assert_close(fs[0].x, fs[1].x, what="x")
        assert_close(fs[0].P, fs[1].P, what="P")
    zp = radar_hx(fs[1].x)
    sh = np.array([radar_hx(s) for s in fs[1].sigmas_f])
    assert_close(fs[0].cross_variance(fs[1].x, zp, fs[1].sigmas_f, sh),
                 fs[1].cross_variance(fs[1].x, zp, fs[1].sigmas_f, sh), what="P_xz")


def big_fx(x, dt):
    """Ten 1-D constant-velocity axes (20 states), positions then velocities by axis."""
    out = np.copy(x)
    out[0::2] = x[0::2] + dt * x[1::2]
    return out


def big_hx(x):
    """Twelve rows: ten positions, the sum of squares of two, a product."""
    p = x[0::2]
    return np.concatenate([p, [0.01 * (p[0] ** 2 + p[1] ** 2), 0.01 * p[2] * p[3]]])


def test_a_ukf_of_20_states_and_12_rows_equals_filterpy():
    """Beyond the compiled sizes (9 states, 8 rows): the dynamic core, chosen alone."""
    fs = []
    for cls, pcls in ((UnscentedKalmanFilter, MerweScaledSigmaPoints), (FpUKF, FpPoints)):
        f = cls(dim_x=20, dim_z=12, dt=0.5, hx=big_hx, fx=big_fx,
                points=pcls(20, alpha=0.5, beta=2.0, kappa=0.0))
        f.x = np.tile([1.0, 0.3], 10)
        f.P = np.eye(20) * 2.0
        f.Q = np.eye(20) * 1e-3
        f.R = np.eye(12) * 0.25
        fs.append(f)
    assert fs[0].dynamic
    rng = np.random.default_rng(5)
    for k in range(30):
        z = big_hx(np.tile([1.0 + 0.15 * k, 0.3], 10)) + rng.normal(size=12) * 0.5
        for f in fs:
            f.predict()
            f.update(z)
        assert_close(fs[0].x, fs[1].x, what=f"x at {k}")
        assert_close(fs[0].P, fs[1].P, what=f"P at {k}")
        assert_close(fs[0].log_likelihood, fs[1].log_likelihood, what="log_likelihood")
    assert np.all(np.linalg.eigvalsh(fs[0].P) > 0)


@pytest.mark.parametrize("strategy", ["fixed", "chi2-gate"])
@pytest.mark.parametrize("smoother", [{"smooth": True}, {"lag": 5}])
def test_the_dynamic_core_equals_the_compiled_one(strategy, smoother):
    """Two independent paths, one model: the compiled core and the heap core."""
    fs = [make_ukf(UnscentedKalmanFilter, MerweScaledSigmaPoints, strategy=strategy,
                   dynamic=d, **smoother) for d in (False, True)]
    assert [f.dynamic for f in fs] == [False, True]
    zs = radar_zs(30, 9)
    zs[12] = zs[12] + [40.0, 0.3]  # an outlier the gate refuses
    for z in zs:
        for f in fs:
            f.predict()
            f.update(z)
        assert fs[0].verdict == fs[1].verdict
        assert_close(fs[0].x, fs[1].x, what="x")
        assert_close(fs[0].P, fs[1].P, what="P")
    xs = [f.smoothed() for f in fs]
    assert_close(xs[0][0], xs[1][0], what="smoothed x")
    assert_close(xs[0][1], xs[1][1], what="smoothed P")
    with pytest.raises(estimator.EstimatorError, match="iae"):
        KalmanFilter(12, 2, strategy="iae")


# --- smoothing histories and paths ----------------------------------------------------

def test_a_second_run_on_the_same_filter_starts_a_new_smoothing_history():
    """Resetting x and P and running again joined the runs (5, 6, 7 → 1.78, 1.96, 1.83)."""
    def run(f, zs):
        f.x = np.array([[0.0], [0.0]])
        f.P = np.eye(2) * 100.0
        for z in zs:
            f.predict()
            f.update(z)
        return f.smoothed()

    reused = cv_filter(KalmanFilter, smooth=True)
    run(reused, [50.0, 60.0, 70.0])
    second = run(reused, [5.0, 6.0, 7.0])
    fresh = run(cv_filter(KalmanFilter, smooth=True), [5.0, 6.0, 7.0])
    assert len(second[0]) == len(fresh[0]) == 4
    assert_close(second[0], fresh[0], what="smoothed x of the second run")
    assert_close(second[1], fresh[1], what="smoothed P of the second run")


@pytest.mark.parametrize("strategy", ["iae-qr", "sage-husa", "fused"])
def test_both_smoothing_paths_agree_under_an_adaptive_strategy(strategy):
    """``rts_smoother`` used the nominal Q and ``smoothed()`` the adapted one (1.16 m
    against 3.77 m); now both use the Q each prediction used."""
    f = KalmanFilter(2, 1, strategy=strategy, smooth=True)
    f.x, f.P = np.array([[0.0], [1.0]]), np.eye(2) * 10.0
    f.F, f.H = np.array([[1.0, 1.0], [0.0, 1.0]]), np.array([[1.0, 0.0]])
    f.R, f.Q = np.eye(1) * 1.0, fp_common.Q_discrete_white_noise(2, 1.0, 1e-4)
    rng = np.random.default_rng(1)
    truth = np.cumsum(1.0 + np.cumsum(rng.normal(size=80) * 0.3))  # more motion than Q says
    means, covs, _, _ = f.batch_filter(list(truth + rng.normal(size=80)))
    xs, Ps, _, _ = f.rts_smoother(means, covs)
    sx, sP = f.smoothed()
    assert_close(xs[:, :, 0], sx[1:], tol=1e-7, what="smoothed x")
    assert_close(Ps, sP[1:], tol=1e-7, what="smoothed P")


# --- copy, pickle, Saver -------------------------------------------------------------

def everyday_filters():
    kf = cv_filter(KalmanFilter, strategy="iae-qr", smooth=True)
    ekf = ExtendedKalmanFilter(2, 1, strategy="sage-husa", lag=4)
    ekf.F, ekf.P, ekf.R, ekf.Q = np.array([[1.0, 1.0], [0, 1]]), np.eye(2) * 10, 2.0, \
        np.eye(2) * 0.01
    ukf = make_ukf(UnscentedKalmanFilter, MerweScaledSigmaPoints, smooth=True,
                   strategy="chi2-gate")
    big = make_ukf(UnscentedKalmanFilter, MerweScaledSigmaPoints, smooth=True, dynamic=True)
    return [kf, ekf, ukf, big]


def step(f, k):
    if isinstance(f, UnscentedKalmanFilter):
        f.predict()
        f.update(radar_zs(k + 1, 3)[-1])
    elif isinstance(f, ExtendedKalmanFilter):
        f.predict()
        f.update(np.array([[k * 1.1]]), lambda x: np.array([[1.0, 0.0]]),
                 lambda x: x[:1])
    else:
        f.predict()
        f.update(k * 1.1)


@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
def test_every_filter_copies_and_resumes_bit_for_bit(how):
    for f in everyday_filters():
        for k in range(12):
            step(f, k)
        g = copy.deepcopy(f) if how == "deepcopy" else pickle.loads(pickle.dumps(f))
        assert g._core is not f._core
        for k in range(12, 20):
            step(f, k)
            step(g, k)
        name = type(f).__name__
        assert np.array_equal(f.x, g.x) and np.array_equal(f.P, g.P), name
        a, b = f.smoothed(), g.smoothed()
        assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1]), name


def test_savers_ours_and_filterpys_keep_every_step():
    for f in everyday_filters():
        for saver_cls in (common.Saver, fp_common.Saver):
            g = copy.deepcopy(f)
            s = saver_cls(g)
            for k in range(6):
                step(g, k)
                s.save()
            s.to_array()
            assert len(s) == 6 and np.asarray(s["x"]).shape[0] == 6
            assert "x" in s.keys and "P" in s.keys
            assert_close(np.asarray(s["x"])[-1], g.x, what="saved x")


# --- filterpy.common -----------------------------------------------------------------

def test_common_helpers_equal_filterpys():
    for dim in (2, 3, 4):
        for bs in (1, 3):
            for by_dim in (True, False):
                assert_close(common.Q_discrete_white_noise(dim, 0.3, 2.0, bs, by_dim),
                             fp_common.Q_discrete_white_noise(dim, 0.3, 2.0, bs, by_dim))
                assert_close(common.Q_continuous_white_noise(dim, 0.3, 2.0, bs, by_dim),
                             fp_common.Q_continuous_white_noise(dim, 0.3, 2.0, bs, by_dim))
    F = np.array([[0.0, 1.0], [-2.0, -0.4]])
    G = np.array([[0.0], [1.5]])
    for a, b in zip(common.van_loan_discretization(F, G, 0.7),
                    fp_common.van_loan_discretization(F, G, 0.7)):
        assert_close(a, b, what="van Loan")
    for a, b in zip(common.linear_ode_discretation(F, G, np.eye(1) * 0.8, 0.7),
                    fp_common.linear_ode_discretation(F, G, np.eye(1) * 0.8, 0.7)):
        assert_close(a, b, what="matrix fraction")
    assert_close(common.kinematic_state_transition(3, 0.5),
                 fp_common.kinematic_state_transition(3, 0.5))
    for by_dim in (True, False):
        a = common.kinematic_kf(2, 1, 0.5, dim_z=2, order_by_dim=by_dim)
        b = fp_common.kinematic_kf(2, 1, 0.5, dim_z=2, order_by_dim=by_dim)
        assert_close(a.F, b.F, what="kinematic F")
        positions = [0, 2] if by_dim else [0, 1]
        assert_close(a.H, np.eye(4)[positions], what="kinematic H")  # one axis per row
    A = np.random.default_rng(1).normal(size=(7, 3))
    assert_close(common.outer_product_sum(A), fp_common.outer_product_sum(A))
    assert_close(common.inv_diagonal(np.diag([2.0, 4.0])), np.diag([0.5, 0.25]))
    f = lambda y, x: -0.5 * y  # noqa: E731
    assert_close(common.runge_kutta4(1.0, 0.0, 0.1, f), fp_common.runge_kutta4(1.0, 0.0, 0.1, f))


# --- errors Python understands --------------------------------------------------------

def test_errors_python_understands(tmp_path):
    assert issubclass(estimator.EstimatorError, ValueError)
    with pytest.raises(FileNotFoundError):
        estimator.navigate(tmp_path / "missing.toml")
    with pytest.raises(FileNotFoundError):
        estimator.read_truth(tmp_path / "missing.nav")
    with pytest.raises(ValueError, match="^z has"):
        cv_filter(KalmanFilter).update([1.0, 2.0, 3.0])
    with pytest.raises(estimator.EstimatorError, match="rows"):
        f = KalmanFilter(2, 1)
        f.H = np.ones((9, 2))
        f.R = np.eye(9)
        f.update(np.ones(9))
