"""The chi2-gate of the FilterPy-shaped EKF over 50 seeds of the robot drive, an outlier
of 25 m on landmark 0 at step 20 of each: detection rate and false refusals."""
import numpy as np, sys
sys.path.insert(0, 'python/tests')
import test_callables as t, estimator
det = false = good = 0
err_g, err_p = [], []
for seed in range(100, 150):
    u, truth, zs = t.drive(seed, outlier_at=20)
    g = t.ekf_robot(estimator.ExtendedKalmanFilter, strategy="chi2-gate")
    p = t.ekf_robot(estimator.ExtendedKalmanFilter)
    for k, obs in enumerate(zs):
        g.predict(u); p.predict(u)
        for j, (lm, z) in enumerate(obs):
            for f in (g, p):
                f.update(z, HJacobian=t.range_bearing_jacobian, Hx=t.range_bearing, residual=t.residual_rb, args=(lm,), hx_args=(lm,))
            if k == 20 and j == 0:
                det += g.verdict == "rejected"
            else:
                good += 1; false += g.verdict == "rejected"
        if k == 20:
            err_g.append(np.hypot(*(np.ravel(g.x)[:2] - truth[k][:2]))); err_p.append(np.hypot(*(np.ravel(p.x)[:2] - truth[k][:2])))
print(f"50 seeds: outlier refused {det}/50; good updates refused {false}/{good} ({100*false/good:.2f} %, the gate's alpha 1 %);"
      f" position error just after the outlier: median {np.median(err_g):.3f} m gated, {np.median(err_p):.3f} m ungated")
