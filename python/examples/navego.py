"""A notebook-style tour: the shipped navego sample (a real trajectory, simulated
ADIS16488 IMU and GNSS, with truth) run forward and smoothed from Python, evaluated
against the truth, and plotted with matplotlib.

    pip install "./python[examples]"
    python python/examples/navego.py            # writes navego.png here
"""

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import estimator  # noqa: E402

DATA = Path(__file__).resolve().parents[2] / "data" / "navego"

# %% The shipped KF-GINS configuration as it is, the forward filter and the smoother.
run = estimator.navigate(DATA / "kf-gins-ADIS16488.yaml", smooth=True)
print(run)

# %% Errors against the truth (as `ins-gnss eval`), forward and smoothed.
for label, smoothed in [("forward", False), ("smoothed", True)]:
    o = run.evaluate(DATA / "truth.nav.zst", smoothed=smoothed)["overall"]
    print(f"{label:9}: horizontal RMS {o['horizontal']['rms']:.3f} m, "
          f"3-D {o['position_3d']['rms']:.3f} m, yaw RMS {o['yaw']['rms']:.4f}°")

# %% The trajectory, the position σ and the innovations' consistency.
fig, ax = plt.subplots(1, 3, figsize=(15, 4.5))
lat0 = np.radians(run.nav.lat.iloc[0])
east = lambda df: np.radians(df.lon - run.nav.lon.iloc[0]) * 6.378e6 * np.cos(lat0)  # noqa: E731
north = lambda df: np.radians(df.lat - run.nav.lat.iloc[0]) * 6.378e6  # noqa: E731
ax[0].plot(east(run.nav), north(run.nav), lw=0.8, label="forward")
ax[0].plot(east(run.smoothed), north(run.smoothed), lw=0.8, label="smoothed")
ax[0].set(xlabel="east (m)", ylabel="north (m)", title="trajectory", aspect="equal")
ax[0].legend()
t0 = run.nav.time.iloc[0]
ax[1].plot(run.std.time - t0, run.std.sigma_n, label="forward σN")
ax[1].plot(run.smoothed_std.time - t0, run.smoothed_std.sigma_n, label="smoothed σN")
ax[1].set(xlabel="time (s)", ylabel="m", title="position 1σ (north)")
ax[1].legend()
u = run.updates
ax[2].plot(u.time - t0, u.nis / u.dim, ".", ms=2)
ax[2].axhline(1.0, color="k", lw=0.8)
ax[2].set(xlabel="time (s)", ylabel="NIS / dim", yscale="log",
          title=f"innovations (mean {run.summary['mean_nis']:.3f})")
fig.tight_layout()
fig.savefig("navego.png", dpi=110)
print("wrote navego.png")
