"""The generic Kalman filter and RTS smoother from Python against FilterPy (installed
from PyPI): KalmanFilter.batch_filter and rts_smoother on a linear case, per-step and
constant matrices, to 1e-9; the adaptive strategies by name; the kinematic models."""

import numpy as np
import pytest

import estimator


from filterpy.kalman import KalmanFilter  # noqa: E402


def spd(rng, n, scale):
    a = rng.standard_normal((n, n))
    return a @ a.T * scale / n + np.eye(n) * scale


def case(seed=3, steps=150, per_step=True):
    rng = np.random.default_rng(seed)
    dt = 0.1
    F, Q = estimator.kinematic("cv", dt, 0.5, axes=2)
    H = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0]])
    R = np.array([spd(rng, 2, 0.3) * (0.5 + (k % 7) * 0.2) for k in range(steps)])
    x = np.array([0.0, 0.0, 1.0, -0.5])
    z = np.empty((steps, 2))
    for k in range(steps):
        x = F @ x + rng.multivariate_normal(np.zeros(4), Q)
        z[k] = H @ x + rng.multivariate_normal(np.zeros(2), R[k])
    z[17] = np.nan  # a step without a measurement
    return dict(x0=rng.standard_normal(4), P0=spd(rng, 4, 1.0), F=F, Q=Q, H=H,
                R=R if per_step else R[0], z=z)


def filterpy_run(c):
    kf = KalmanFilter(dim_x=4, dim_z=2)
    kf.x, kf.P, kf.F, kf.Q, kf.H = c["x0"].copy(), c["P0"].copy(), c["F"], c["Q"], c["H"]
    steps = len(c["z"])
    Rs = c["R"] if c["R"].ndim == 3 else [c["R"]] * steps
    zs = [None if np.isnan(z).any() else z for z in c["z"]]
    xs, Ps, _, _ = kf.batch_filter(zs, Rs=list(Rs))
    lls, nis = [], []
    kf2 = KalmanFilter(dim_x=4, dim_z=2)
    kf2.x, kf2.P, kf2.F, kf2.Q, kf2.H = c["x0"].copy(), c["P0"].copy(), c["F"], c["Q"], c["H"]
    for z, R in zip(zs, Rs):
        kf2.predict()
        if z is None:
            lls.append(np.nan), nis.append(np.nan)
            continue
        kf2.update(z, R=R)
        lls.append(kf2.log_likelihood)
        nis.append(float(kf2.y @ np.linalg.solve(kf2.S, kf2.y)))
    sx, sP, _, _ = kf.rts_smoother(xs, Ps, Fs=[c["F"]] * steps, Qs=[c["Q"]] * steps)
    return xs.reshape(steps, 4), Ps, np.array(lls), np.array(nis), sx.reshape(steps, 4), sP


@pytest.mark.parametrize("per_step", [True, False])
def test_filter_and_smoother_equal_filterpy(per_step):
    c = case(per_step=per_step)
    ours = estimator.kalman(c["x0"], c["P0"], c["F"], c["Q"], c["H"], c["R"], c["z"],
                            smooth=True)
    xs, Ps, lls, nis, sx, sP = filterpy_run(c)
    scale = lambda a: max(1.0, np.abs(a).max())  # noqa: E731
    for name, a, b in [("x", ours["x"], xs), ("P", ours["P"], Ps), ("xs", ours["xs"], sx),
                       ("Ps", ours["Ps"], sP)]:
        err = np.abs(a - b).max() / scale(b)
        print(f"{name}: {err:.2e}")
        assert err <= 1e-9, f"{name} differs by {err:.2e}"
    finite = ~np.isnan(nis)
    assert np.array_equal(finite, ~np.isnan(ours["nis"]))
    assert np.abs(ours["nis"][finite] - nis[finite]).max() <= 1e-9 * nis[finite].max()
    assert np.abs(ours["log_likelihood"][finite] - lls[finite]).max() <= 1e-9
    assert ours["verdict"][17] == "none" and ours["verdict"][16] == "accepted"


@pytest.mark.parametrize("strategy", estimator.STRATEGIES)
def test_every_strategy_runs_by_name_and_keeps_covariances_positive(strategy):
    c = case(seed=9)
    c["z"][40:45] += 30.0  # outliers for the adaptive strategies to meet
    out = estimator.kalman(c["x0"], c["P0"], c["F"], c["Q"], c["H"], c["R"], c["z"],
                           strategy=strategy, smooth=True)
    for P in list(out["P"]) + list(out["Ps"]):
        assert np.allclose(P, P.T, atol=1e-12 * np.abs(P).max())
        assert np.linalg.eigvalsh(P).min() > 0
    assert set(out["verdict"]) <= {"accepted", "inflated", "deflated", "rejected", "none"}


def test_adaptive_strategies_differ_from_the_plain_filter_on_outliers():
    c = case(seed=9)
    c["z"][40:45] += 30.0
    plain = estimator.kalman(**c)
    gated = estimator.kalman(**c, strategy="chi2-gate")
    assert "rejected" in gated["verdict"] and "rejected" not in plain["verdict"]
    # the gate keeps the estimate near the measurements' truth after the outliers
    assert np.abs(gated["x"][44, :2] - plain["x"][44, :2]).max() > 1.0


def test_kinematic_models_are_the_closed_forms():
    dt, q = 0.2, 0.7
    F, Q = estimator.kinematic("cv", dt, q)
    assert np.allclose(F, [[1, dt], [0, 1]], atol=1e-15)
    assert np.allclose(Q, q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]]), atol=1e-15)
    F, Q = estimator.kinematic("ca", dt, q, axes=3)
    assert F.shape == (9, 9) and np.allclose(F[0, [0, 3, 6]], [1, dt, dt * dt / 2])
    F, _ = estimator.kinematic("singer", dt, q, alpha=1e-9)
    assert np.allclose(F, estimator.kinematic("ca", dt, q)[0], atol=1e-9)
    with pytest.raises(ValueError, match="alpha"):
        estimator.kinematic("singer", dt, q)
    with pytest.raises(ValueError, match="dt = NaN"):
        estimator.kinematic("cv", float("nan"), q)
    with pytest.raises(ValueError, match="q = -1"):
        estimator.kinematic("ca", dt, -1.0)
    with pytest.raises(ValueError, match="alpha = 0"):
        estimator.kinematic("singer", dt, q, alpha=0.0)


def test_bad_shapes_and_dimensions_are_refused():
    c = case()
    with pytest.raises(ValueError, match="F has shape"):
        estimator.kalman(c["x0"], c["P0"], np.eye(3), c["Q"], c["H"], c["R"], c["z"])
    n = estimator.MAX_N + 1
    with pytest.raises(estimator.EstimatorError, match="iae"):
        estimator.kalman(np.zeros(n), np.eye(n), np.eye(n), np.eye(n), np.ones((1, n)),
                         np.eye(1), np.zeros((3, 1)), strategy="iae")
    with pytest.raises(estimator.EstimatorError, match="P0|positive"):
        estimator.kalman(c["x0"], -np.eye(4), c["F"], c["Q"], c["H"], c["R"], c["z"])


def test_beyond_the_compiled_sizes_kalman_runs_on_the_dynamic_core_and_equals_filterpy():
    """12 states and 10 rows (compiled: 9 and 8): FilterPy's batch_filter and
    rts_smoother to 1e-9."""
    from filterpy.kalman import KalmanFilter as FpKF

    n, m, steps = 12, 10, 40
    rng = np.random.default_rng(8)
    F = np.eye(n) + 0.05 * rng.normal(size=(n, n))
    A = rng.normal(size=(n, n)) * 0.1
    Q = A @ A.T + 1e-3 * np.eye(n)
    H = rng.normal(size=(m, n))
    R = np.eye(m) * 0.5
    z = rng.normal(size=(steps, m))
    z[7] = np.nan
    out = estimator.kalman(np.zeros(n), np.eye(n), F, Q, H, R, z, smooth=True)
    fp = FpKF(n, m)
    fp.x, fp.P, fp.F, fp.Q, fp.H, fp.R = np.zeros(n), np.eye(n), F, Q, H, R
    zs = [None if np.isnan(row).any() else row for row in z]
    mu, cov, _, _ = fp.batch_filter(zs)
    xs, Ps, _, _ = fp.rts_smoother(mu, cov)
    for a, b in ((out["x"], mu), (out["P"], cov), (out["xs"], xs), (out["Ps"], Ps)):
        assert np.abs(a - b).max() <= 1e-9 * max(1.0, np.abs(b).max())
