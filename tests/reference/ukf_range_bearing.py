"""FilterPy reference for the unscented filter on the planar range-bearing robot.

Runs FilterPy's UnscentedKalmanFilter (Merwe points alpha=0.5, beta=2, kappa=0) on the
unicycle with range-bearing landmarks -- the same models as `models::planar` -- and
writes the inputs and FilterPy's state and covariance after every prediction and update
to `ukf_range_bearing.json`, which `tests/ukf_filterpy.rs` replays with
`ErrorStateFilter::predict_unscented` / `update_unscented`.

Two mean rules are run:
- "iterated": heading and bearing means by the fixed-point iteration on the circle
  (x <- x + sum w_i wrap(x_i - x) until the step is below 1e-12), as the Rust filter
  does on every manifold;
- "atan2": the extrinsic circular mean atan2(sum w sin, sum w cos), the common FilterPy
  recipe.

After each predict the sigma points are drawn afresh from (x, P) (`ukf.sigmas_f`), as
the Rust update does; FilterPy otherwise reuses the propagated points, which do not
carry Q.

Regenerate (writes next to this file):
    python -m venv /tmp/fp && /tmp/fp/bin/pip install numpy filterpy
    /tmp/fp/bin/python tests/reference/ukf_range_bearing.py
"""

import json
import math
import os

import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

PI = math.pi


def wrap(a):
    """The Rust `manifolds::wrap_angle`: into (-pi, pi]."""
    if -PI < a <= PI:
        return a
    w = (a + PI) % (2.0 * PI) - PI
    return w + 2.0 * PI if w <= -PI else w


def residual_x(a, b):
    y = np.subtract(a, b)
    y[2] = wrap(y[2])
    return y


def residual_z(a, b):
    y = np.subtract(a, b)
    y[1] = wrap(y[1])
    return y


def iterated_mean(residual, angle_index):
    def mean(sigmas, wm):
        x = np.array(sigmas[0], dtype=float)
        for _ in range(50):
            step = np.zeros_like(x)
            for w, s in zip(wm, sigmas):
                step += w * residual(s, x)
            x = x + step
            x[angle_index] = wrap(x[angle_index])
            if np.max(np.abs(step)) <= 1e-12:
                return x
        raise RuntimeError("mean did not converge")

    return mean


def atan2_mean(angle_index):
    def mean(sigmas, wm):
        sigmas = np.asarray(sigmas)
        x = wm @ sigmas
        s = wm @ np.sin(sigmas[:, angle_index])
        c = wm @ np.cos(sigmas[:, angle_index])
        x[angle_index] = math.atan2(s, c)
        return x

    return mean


SIGMA_V, SIGMA_W = 0.1, 0.02


def fx(x, dt, u):
    th = x[2]
    return np.array([x[0] + math.cos(th) * u[0] * dt, x[1] + math.sin(th) * u[0] * dt,
                     wrap(th + u[1] * dt)])


def q_of(x, dt):
    s, c = math.sin(x[2]), math.cos(x[2])
    g = np.array([[c * dt, 0.0], [s * dt, 0.0], [0.0, dt]])
    return g @ np.diag([SIGMA_V ** 2, SIGMA_W ** 2]) @ g.T + np.eye(3) * 1e-12


def hx(x, landmark):
    d = np.asarray(landmark) - x[:2]
    return np.array([math.hypot(d[0], d[1]), wrap(math.atan2(d[1], d[0]) - x[2])])


def main():
    rng = np.random.default_rng(20261125)
    landmarks = [[-30.0, 0.05], [-25.0, -5.0], [5.0, 40.0]]
    dt, steps = 0.1, 80
    x0 = np.array([0.0, -20.0, 3.0])
    p0 = np.diag([1.0, 1.0, 0.01])
    r = np.diag([0.25, 4e-4])
    truth = x0 + rng.standard_normal(3) * np.sqrt(np.diag(p0))
    inputs = []
    for k in range(steps):
        u = [5.0, 0.3 + 0.2 * math.sin(0.05 * k)]
        noisy = [u[0] + SIGMA_V * rng.standard_normal(), u[1] + SIGMA_W * rng.standard_normal()]
        truth = fx(truth, dt, noisy)
        lm = landmarks[k % 3]
        z = hx(truth, lm) + rng.standard_normal(2) * np.sqrt(np.diag(r))
        z[1] = wrap(z[1])
        inputs.append({"u": u, "landmark": lm, "z": list(z)})

    runs = {}
    for name, (xm, zm) in {
        "iterated": (iterated_mean(residual_x, 2), iterated_mean(residual_z, 1)),
        "atan2": (atan2_mean(2), atan2_mean(1)),
    }.items():
        points = MerweScaledSigmaPoints(3, alpha=0.5, beta=2.0, kappa=0.0, subtract=residual_x)
        ukf = UnscentedKalmanFilter(dim_x=3, dim_z=2, dt=dt, hx=hx, fx=fx, points=points,
                                    x_mean_fn=xm, z_mean_fn=zm, residual_x=residual_x,
                                    residual_z=residual_z)
        ukf.x = x0.copy()
        ukf.P = p0.copy()
        ukf.R = r
        out = []
        for step in inputs:
            ukf.Q = q_of(ukf.x, dt)
            ukf.predict(u=step["u"])
            predicted = {"x": list(ukf.x), "P": ukf.P.flatten().tolist()}
            ukf.sigmas_f = ukf.points_fn.sigma_points(ukf.x, ukf.P)
            ukf.update(np.array(step["z"]), landmark=step["landmark"])
            out.append({"predicted": predicted,
                        "updated": {"x": list(ukf.x), "P": ukf.P.flatten().tolist()}})
        runs[name] = out

    doc = {"filterpy": __import__("filterpy").__version__, "numpy": np.__version__,
           "dt": dt, "x0": list(x0), "P0": p0.flatten().tolist(), "R": r.flatten().tolist(),
           "sigma_v": SIGMA_V, "sigma_w": SIGMA_W, "alpha": 0.5, "beta": 2.0, "kappa": 0.0,
           "steps": inputs, "runs": runs}
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "ukf_range_bearing.json")
    with open(path, "w") as f:
        json.dump(doc, f, indent=1)
    print("wrote", path)


if __name__ == "__main__":
    main()
