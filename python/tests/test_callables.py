"""Models as Python callables in FilterPy's shape (``estimator.filterpy``) against FilterPy
2.0.0 from PyPI: the extended filter on the robot of FilterPy's book (bicycle motion,
range and bearing to landmarks, one update per landmark), the unscented filter on the
same robot with angle-aware means and residuals (all landmarks in one update), and the
linear filter's ``batch_filter`` and ``rts_smoother`` — each to 1e-9. Then what FilterPy
does not have: a gate that refuses an outlier, and the RTS smoother of the extended and
unscented filters."""

from math import atan2, cos, sin, sqrt, tan

import numpy as np
import pytest

import estimator
from filterpy.kalman import ExtendedKalmanFilter as FpEKF
from filterpy.kalman import KalmanFilter as FpKF
from filterpy.kalman import MerweScaledSigmaPoints as FpPoints
from filterpy.kalman import UnscentedKalmanFilter as FpUKF

LANDMARKS = np.array([[5.0, 10.0], [10.0, 5.0], [15.0, 15.0]])
WHEELBASE = 0.5
DT = 1.0
STD_VEL, STD_STEER = 0.1, np.radians(1.0)
STD_RANGE, STD_BEARING = 0.3, 0.1


def close(a, b, tol=1e-9):
    a, b = np.asarray(a, float), np.asarray(b, float)
    scale = max(1.0, float(np.abs(b).max()))
    return float(np.abs(a - b).max()) <= tol * scale, float(np.abs(a - b).max())


def wrap(a):
    a = a % (2 * np.pi)
    return a - 2 * np.pi if a > np.pi else a


def bicycle(x, u, dt):
    """The robot's motion: a bicycle of wheelbase WHEELBASE (x, y, heading)."""
    x = np.asarray(x, float).ravel()
    heading, (vel, steer) = x[2], u
    dist = vel * dt
    if abs(steer) > 0.001:
        beta = dist / WHEELBASE * tan(steer)
        r = WHEELBASE / tan(steer)
        dx = np.array([-r * sin(heading) + r * sin(heading + beta),
                       r * cos(heading) - r * cos(heading + beta), beta])
    else:
        dx = np.array([dist * cos(heading), dist * sin(heading), 0.0])
    return x + dx


def bicycle_jacobians(x, u, dt):
    """∂motion/∂x and ∂motion/∂(vel, steer), analytic."""
    x = np.asarray(x, float).ravel()
    h, (v, a) = x[2], u
    r = WHEELBASE / tan(a)
    beta = v * dt / WHEELBASE * tan(a)
    F = np.array([[1.0, 0.0, -r * cos(h) + r * cos(h + beta)],
                  [0.0, 1.0, -r * sin(h) + r * sin(h + beta)],
                  [0.0, 0.0, 1.0]])
    dbeta_dv = dt / WHEELBASE * tan(a)
    dbeta_da = v * dt / WHEELBASE / cos(a) ** 2
    dr_da = -WHEELBASE / sin(a) ** 2
    V = np.array([
        [r * cos(h + beta) * dbeta_dv,
         dr_da * (-sin(h) + sin(h + beta)) + r * cos(h + beta) * dbeta_da],
        [r * sin(h + beta) * dbeta_dv,
         dr_da * (cos(h) - cos(h + beta)) + r * sin(h + beta) * dbeta_da],
        [dbeta_dv, dbeta_da]])
    return F, V


def range_bearing(x, lm):
    x = np.asarray(x, float).ravel()
    dx, dy = lm[0] - x[0], lm[1] - x[1]
    return np.array([[sqrt(dx * dx + dy * dy)], [wrap(atan2(dy, dx) - x[2])]])


def range_bearing_jacobian(x, lm):
    x = np.asarray(x, float).ravel()
    dx, dy = lm[0] - x[0], lm[1] - x[1]
    q = dx * dx + dy * dy
    d = sqrt(q)
    return np.array([[-dx / d, -dy / d, 0.0], [dy / q, -dx / q, -1.0]])


def residual_rb(a, b):
    y = np.asarray(a, float) - np.asarray(b, float)
    y.flat[1] = wrap(float(y.flat[1]))
    return y


def drive(seed, steps=60, outlier_at=None):
    """The simulated robot and its measurements: commands, and per step a list of
    (landmark, z) with z a 2×1 column."""
    rng = np.random.default_rng(seed)
    x = np.array([2.0, 6.0, 0.3])
    u = (1.1, 0.01)
    truth, zs = [], []
    for k in range(steps):
        x = bicycle(x, u, DT)
        truth.append(x.copy())
        obs = []
        for lm in LANDMARKS:
            z = range_bearing(x, lm) + np.array([[rng.normal() * STD_RANGE],
                                                 [rng.normal() * STD_BEARING]])
            obs.append((lm, z))
        if k == outlier_at:
            obs[0] = (LANDMARKS[0], obs[0][1] + np.array([[25.0], [0.0]]))
        zs.append(obs)
    return u, np.array(truth), zs


def ekf_robot(base, **kw):
    """The book's robot EKF on `base` (FilterPy's class or ours): predict_x moves the
    robot and sets F and Q = V M Vᵀ at the moved state, as the book does."""

    class Robot(base):
        def predict_x(self, u=0):
            moved = bicycle(self.x, u, DT).reshape(3, 1)
            F, V = bicycle_jacobians(moved, u, DT)
            M = np.array([[STD_VEL * u[0] ** 2, 0.0], [0.0, STD_STEER ** 2]])
            self.F, self.Q = F, V @ M @ V.T
            self.x = moved

    f = Robot(3, 2, 2, **kw)
    f.x = np.array([[2.0, 6.0, 0.3]]).T
    f.P = np.diag([0.1, 0.1, 0.1])
    f.R = np.diag([STD_RANGE ** 2, STD_BEARING ** 2])
    return f


def run_ekf(f, u, zs):
    xs, ps = [], []
    for obs in zs:
        f.predict(u)
        for lm, z in obs:
            f.update(z, HJacobian=range_bearing_jacobian, Hx=range_bearing,
                     residual=residual_rb, args=(lm,), hx_args=(lm,))
        xs.append(np.asarray(f.x, float).ravel().copy())
        ps.append(np.asarray(f.P, float).copy())
    return np.array(xs), np.array(ps)


def test_ekf_robot_equals_filterpy():
    u, _, zs = drive(7)
    fp = ekf_robot(FpEKF)
    ours = ekf_robot(estimator.ExtendedKalmanFilter)
    xa, pa = run_ekf(fp, u, zs)
    xb, pb = run_ekf(ours, u, zs)
    ok, err = close(xb, xa)
    assert ok, f"state differs by {err}"
    ok, err = close(pb, pa)
    assert ok, f"covariance differs by {err}"
    # the last update's statistics, as FilterPy names them
    for name in ("K", "S", "SI"):
        ok, err = close(getattr(ours, name), getattr(fp, name))
        assert ok, f"{name} differs by {err}"
    ok, err = close(np.ravel(ours.y), np.ravel(fp.y))
    assert ok, f"y differs by {err}"
    assert abs(ours.log_likelihood - fp.log_likelihood) < 1e-9 * abs(fp.log_likelihood)
    assert ours.verdict == "accepted"


# -- the unscented robot: every landmark in one update, angle-aware means and residuals

def ukf_move(x, dt, u):
    return bicycle(x, u, dt)


def ukf_hx(x, landmarks):
    return np.concatenate([range_bearing(x, lm).ravel() for lm in landmarks])


def residual_x(a, b):
    y = np.asarray(a, float) - np.asarray(b, float)
    y[2] = wrap(float(y[2]))
    return y


def residual_h(a, b):
    y = np.asarray(a, float) - np.asarray(b, float)
    for i in range(0, len(y), 2):
        y[i + 1] = wrap(float(y[i + 1]))
    return y


def state_mean(sigmas, Wm):
    x = np.zeros(3)
    x[0] = np.sum(sigmas[:, 0] * Wm)
    x[1] = np.sum(sigmas[:, 1] * Wm)
    x[2] = atan2(np.sum(np.sin(sigmas[:, 2]) * Wm), np.sum(np.cos(sigmas[:, 2]) * Wm))
    return x


def z_mean(sigmas, Wm):
    z = np.zeros(sigmas.shape[1])
    for i in range(0, sigmas.shape[1], 2):
        z[i] = np.sum(sigmas[:, i] * Wm)
        z[i + 1] = atan2(np.sum(np.sin(sigmas[:, i + 1]) * Wm),
                         np.sum(np.cos(sigmas[:, i + 1]) * Wm))
    return z


def ukf_robot(cls, points_cls, alpha, **kw):
    points = points_cls(n=3, alpha=alpha, beta=2, kappa=0, subtract=residual_x)
    f = cls(dim_x=3, dim_z=2 * len(LANDMARKS), fx=ukf_move, hx=ukf_hx, dt=DT,
            points=points, x_mean_fn=state_mean, z_mean_fn=z_mean,
            residual_x=residual_x, residual_z=residual_h, **kw)
    f.x = np.array([2.0, 6.0, 0.3])
    f.P = np.diag([0.1, 0.1, 0.05])
    f.R = np.diag([STD_RANGE ** 2, STD_BEARING ** 2] * len(LANDMARKS))
    f.Q = np.eye(3) * 0.0001
    return f


def run_ukf(f, u, zs):
    xs, ps = [], []
    for obs in zs:
        f.predict(u=u)
        f.update(np.concatenate([z.ravel() for _, z in obs]), landmarks=LANDMARKS)
        xs.append(np.array(f.x, float))
        ps.append(np.array(f.P, float))
    return np.array(xs), np.array(ps)


@pytest.mark.parametrize("alpha", [0.1, 0.3, 1.0])
def test_ukf_robot_with_mean_and_residual_functions_equals_filterpy(alpha):
    """(The book's α = 1e-5 makes W₀ = −1e10: FilterPy against itself with the start moved
    by one rounding step, 4.4e-16 m, ends 6.9e-4 m apart on this drive (1.4e-7 m at
    α = 1e-3), so no other arithmetic can agree with it to 1e-9 there.)"""
    u, _, zs = drive(11)
    fp = ukf_robot(FpUKF, FpPoints, alpha)
    ours = ukf_robot(estimator.UnscentedKalmanFilter, estimator.MerweScaledSigmaPoints, alpha)
    xa, pa = run_ukf(fp, u, zs)
    xb, pb = run_ukf(ours, u, zs)
    ok, err = close(xb, xa)
    assert ok, f"alpha {alpha}: state differs by {err}"
    ok, err = close(pb, pa)
    assert ok, f"alpha {alpha}: covariance differs by {err}"
    for name in ("K", "S"):
        ok, err = close(getattr(ours, name), getattr(fp, name))
        assert ok, f"alpha {alpha}: {name} differs by {err}"
    assert abs(ours.log_likelihood - fp.log_likelihood) < 1e-9 * abs(fp.log_likelihood)


def test_kalman_batch_filter_and_rts_smoother_equal_filterpy():
    """FilterPy's smoothing example: a constant-velocity track measured in position."""
    rng = np.random.default_rng(123)
    noise = 4.0
    zs = np.array([t + rng.normal() * noise for t in range(40)])
    q = 0.001
    Q = np.array([[0.25, 0.5], [0.5, 1.0]]) * q

    def setup(cls):
        f = cls(dim_x=2, dim_z=1)
        f.x = np.array([0.0, 1.0])
        f.F = np.array([[1.0, 1.0], [0.0, 1.0]])
        f.H = np.array([[1.0, 0.0]])
        f.P = np.eye(2) * 10.0
        f.R = np.array([[noise ** 2]])
        f.Q = Q
        return f

    fp, ours = setup(FpKF), setup(estimator.KalmanFilter)
    ma, ca, _, _ = fp.batch_filter(zs)
    mb, cb, _, _ = ours.batch_filter(zs)
    assert close(mb, ma)[0] and close(cb, ca)[0]
    xa, pa, ka, ppa = fp.rts_smoother(ma, ca)
    xb, pb, kb, ppb = ours.rts_smoother(mb, cb)
    for name, a, b in (("x", xa, xb), ("P", pa, pb), ("K", ka, kb), ("Pp", ppa, ppb)):
        ok, err = close(b, a)
        assert ok, f"smoothed {name} differs by {err}"


def test_a_gate_refuses_an_outlier_and_the_smoother_runs():
    """What FilterPy does not have: the gross-error gate by name (an outlier of 25 m on
    one landmark is refused, the others taken), and the RTS smoother of the extended and
    unscented filters (smoothed errors below the forward ones)."""
    u, truth, zs = drive(5, outlier_at=20)
    gated = ekf_robot(estimator.ExtendedKalmanFilter, strategy="chi2-gate")
    plain = ekf_robot(estimator.ExtendedKalmanFilter)
    verdicts = []
    for k, obs in enumerate(zs):
        for f in (gated, plain):
            f.predict(u)
        for lm, z in obs:
            for f in (gated, plain):
                f.update(z, HJacobian=range_bearing_jacobian, Hx=range_bearing,
                         residual=residual_rb, args=(lm,), hx_args=(lm,))
            verdicts.append((k, gated.verdict))
        if k == 20:
            at_outlier = [np.hypot(*(np.ravel(f.x)[:2] - truth[k][:2])) for f in (gated, plain)]
    refused = [k for k, v in verdicts if v == "rejected"]
    # the outlier, and at most a few of the 180 good ones (the gate's α is 1 %)
    assert 20 in refused and len(refused) <= 4, refused
    assert at_outlier[0] < 0.5 * at_outlier[1], at_outlier

    for make, run in ((lambda: ekf_robot(estimator.ExtendedKalmanFilter, smooth=True),
                       run_ekf),
                      (lambda: ukf_robot(estimator.UnscentedKalmanFilter,
                                         estimator.MerweScaledSigmaPoints, 0.3, smooth=True),
                       run_ukf)):
        f = make()
        xs, _ = run(f, u, zs)
        sx, sp = f.smoothed()
        assert sx.shape == (len(zs) + 1, 3) and sp.shape == (len(zs) + 1, 3, 3)
        fwd = np.sqrt(np.mean(np.sum((xs[:, :2] - truth[:, :2]) ** 2, axis=1)))
        smo = np.sqrt(np.mean(np.sum((sx[1:, :2] - truth[:, :2]) ** 2, axis=1)))
        assert smo < fwd, (smo, fwd)
        # the last smoothed estimate is the last filtered one
        assert np.allclose(sx[-1], xs[-1], atol=1e-12)
        assert all(np.all(np.linalg.eigvalsh(p) > 0) for p in sp)

    # the fixed-lag smoother over the last 10 predictions: the RTS smoother's estimates
    # over that window (the same recursion, restricted to it)
    rts = ekf_robot(estimator.ExtendedKalmanFilter, smooth=True)
    lagged = ekf_robot(estimator.ExtendedKalmanFilter, lag=10)
    run_ekf(rts, u, zs)
    run_ekf(lagged, u, zs)
    (ax, ap), (bx, bp) = rts.smoothed(), lagged.smoothed()
    assert bx.shape == (11, 3)
    assert np.allclose(bx, ax[-11:], rtol=0, atol=1e-12)
    assert np.allclose(bp, ap[-11:], rtol=0, atol=1e-12)


def test_the_gate_over_fifty_seeds():
    """The gate's decisions as rates over 50 seeds of the drive (a 25 m outlier on one
    landmark at step 20 of each): every outlier refused, good updates refused at most at
    the gate's α of 1 %."""
    detected = refused_good = good = 0
    for seed in range(100, 150):
        u, _, zs = drive(seed, outlier_at=20)
        f = ekf_robot(estimator.ExtendedKalmanFilter, strategy="chi2-gate")
        for k, obs in enumerate(zs):
            f.predict(u)
            for j, (lm, z) in enumerate(obs):
                f.update(z, HJacobian=range_bearing_jacobian, Hx=range_bearing,
                         residual=residual_rb, args=(lm,), hx_args=(lm,))
                if (k, j) == (20, 0):
                    detected += f.verdict == "rejected"
                else:
                    good += 1
                    refused_good += f.verdict == "rejected"
    assert detected == 50, detected
    assert refused_good <= 0.01 * good, (refused_good, good)
