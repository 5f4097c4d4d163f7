"""Cost of one extended-filter step (predict + update) with trivial callbacks, ours
against FilterPy 2.0.0: `python python/benches/callables.py` (10 alternating rounds of
2,000 steps, medians)."""
import numpy as np, time, statistics
import estimator
from filterpy.kalman import ExtendedKalmanFilter as FE
H = np.array([[1.,0,0],[0,1.,0]]); hj = lambda x: H; hx = lambda x: H @ x
z = np.array([[0.1],[0.2]])
def make(cls, **kw):
    f = cls(3, 2, **kw); f.x = np.zeros((3,1)); f.P = np.eye(3); f.R = np.eye(2)*0.1; f.Q=np.eye(3)*0.01; f.F=np.eye(3)
    return f
def run(f, n=2000):
    t0=time.perf_counter()
    for k in range(n):
        f.predict(); f.update(z, hj, hx)
    return (time.perf_counter()-t0)/n*1e6
def cbs(n=2000):
    x = np.zeros((3,1)); t0=time.perf_counter()
    for k in range(n):
        hj(x); y = np.subtract(z, hx(x))
    return (time.perf_counter()-t0)/n*1e6
r = {"filterpy": [], "ours": [], "ours chi2-gate": [], "callbacks": []}
for rep in range(10):
    r["filterpy"].append(run(make(FE))); r["ours"].append(run(make(estimator.ExtendedKalmanFilter)))
    r["ours chi2-gate"].append(run(make(estimator.ExtendedKalmanFilter, strategy="chi2-gate"))); r["callbacks"].append(cbs())
for k, v in r.items(): print("%-16s median %.1f us per predict+update (10 alternating rounds of 2000)" % (k, statistics.median(v)))

# The unscented filter: FilterPy's 3-state example size and 20 states × 12 rows (beyond
# the compiled sizes: the dynamic core), one predict + update per step.
from filterpy.kalman import UnscentedKalmanFilter as FU, MerweScaledSigmaPoints as FP
def ukf(cls, pcls, n, m):
    fx = lambda x, dt: x
    hx = lambda x: x[:m] if m <= n else np.concatenate([x, x[:m - n]])
    f = cls(dim_x=n, dim_z=m, dt=1.0, hx=hx, fx=fx, points=pcls(n, 0.5, 2.0, 0.0))
    f.x = np.zeros(n); f.P = np.eye(n); f.Q = np.eye(n) * 0.01; f.R = np.eye(m) * 0.1
    return f
def run_ukf(f, m, n=500):
    z = np.full(m, 0.1); t0 = time.perf_counter()
    for k in range(n):
        f.predict(); f.update(z)
    return (time.perf_counter() - t0) / n * 1e6
for n, m in ((3, 2), (20, 12)):
    r = {"filterpy": [], "ours": []}
    for rep in range(10):
        r["filterpy"].append(run_ukf(ukf(FU, FP, n, m), m))
        r["ours"].append(run_ukf(ukf(estimator.UnscentedKalmanFilter, estimator.MerweScaledSigmaPoints, n, m), m))
    for k, v in r.items():
        print("UKF %2d states %2d rows %-9s median %.1f us per predict+update" % (n, m, k, statistics.median(v)))
