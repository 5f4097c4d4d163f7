"""State estimation from Python: the INS/GNSS navigator and its smoother, and the
Kalman filter with adaptive noise, running in Rust.

- :func:`navigate` runs the navigator of ``ins-gnss run`` (the same options, start,
  checks and numbers) on numpy arrays or pandas DataFrames, or on the files a
  configuration names, and returns a :class:`Navigation` of DataFrames; no file is
  written.
- :func:`kalman` runs the Kalman filter and the RTS smoother on a Euclidean state with
  ``F, Q, H, R`` given as arrays (constant or per step), with any adaptive strategy.
- :class:`ExtendedKalmanFilter`, :class:`UnscentedKalmanFilter` and
  :class:`KalmanFilter` take your models as Python callables in FilterPy's shape, with
  every strategy, the gate, the verdict and the RTS smoother (``estimator.filterpy``).
- :func:`fleet` runs many logs or seeds on a Dask cluster (a local one by default) and
  returns one table: errors, verdict, refused share, time, failures.
- :func:`kinematic` gives ``F, Q`` of the built-in kinematic models (CV, CA, Singer).
- :func:`ahrs` runs the attitude and heading reference system of the third paper
  (conventional, modified, CS-MAEKF) on gyro, accelerometer and magnetometer arrays;
  :func:`ahrs_flight` gives the paper's simulated flight.

The runs release the GIL, so threads, ``multiprocessing`` or Dask run many at once.
A refused input or failed run raises :class:`EstimatorError` with the program's
message, naming the file and line (or the array and row).
"""

from __future__ import annotations

import json
import os
from typing import Any, Mapping, Optional, Sequence, Union

import numpy as np
import pandas as pd

from . import _native
from . import common
from ._native import EstimatorError
from .filterpy import (ExtendedKalmanFilter, KalmanFilter, MerweScaledSigmaPoints,
                       UnscentedKalmanFilter, unscented_transform)
from .fleet import Job, fleet

__all__ = [
    "fleet",
    "Job",
    "KalmanFilter",
    "ExtendedKalmanFilter",
    "UnscentedKalmanFilter",
    "MerweScaledSigmaPoints",
    "unscented_transform",
    "navigate",
    "Navigation",
    "kalman",
    "kinematic",
    "ahrs",
    "ahrs_flight",
    "EstimatorError",
    "EstimatorFileNotFoundError",
    "read_truth",
    "rtk",
    "RTK_COLUMNS",
    "plot",
    "common",
    "NAV_COLUMNS",
    "STRATEGIES",
]

#: Columns of the navigation results (degrees for angles, m, m/s).
NAV_COLUMNS = ["time", "lat", "lon", "height", "vn", "ve", "vd", "roll", "pitch", "yaw"]

#: 1σ columns of ``std`` (m, m/s, deg, deg/h, mGal; with 21 states ppm).
STD_COLUMNS = ["time"] + [
    "sigma_" + c
    for c in ["n", "e", "d", "vn", "ve", "vd", "roll", "pitch", "yaw",
              "bgx", "bgy", "bgz", "bax", "bay", "baz",
              "sgx", "sgy", "sgz", "sax", "say", "saz"]
]

#: Columns of ``imu_errors``: biases (deg/h, mGal), with 21 states scale factors (ppm).
IMU_ERROR_COLUMNS = ["time", "bgx", "bgy", "bgz", "bax", "bay", "baz",
                     "sgx", "sgy", "sgz", "sax", "say", "saz"]

#: The adaptive strategies by name (``fixed`` is the plain Kalman filter).
#: A ``-faithful`` name is the paper's algorithm as written, without the fading guard
#: of the default (``docs/history/results.md``: it runs away on models it does not suit).
STRATEGIES = ["fixed", "iae", "iae-qr", "iae-qr-faithful", "afkf", "afkf-xia",
              "afkf-faithful", "afkf-xia-faithful", "fused", "fused-faithful",
              "fused-nominal", "fused-window-test", "fused-uncensored",
              "fused-nominal-uncensored", "iakf", "iakf-raw", "sage-husa", "chi2-gate"]

PathLike = Union[str, "os.PathLike[str]"]


class EstimatorFileNotFoundError(EstimatorError, FileNotFoundError):
    """A file the run needs (the configuration, an input it names, a truth) is missing:
    both an :class:`EstimatorError` (a ``ValueError``) and a ``FileNotFoundError``."""

    def __init__(self, message: str, filename: Optional[str] = None):
        super().__init__(message)
        self.errno, self.strerror, self.filename = 2, message, filename

    def __str__(self) -> str:
        return f"{self.strerror}: {self.filename}" if self.filename else str(self.strerror)


def _missing(path: PathLike, what: str):
    if not os.path.exists(os.fspath(path)):
        raise EstimatorFileNotFoundError(f"{what} not found", os.fspath(path))


def _native_call(f, *args, **kwargs):
    """Call the library; a missing file it names becomes a ``FileNotFoundError``."""
    try:
        return f(*args, **kwargs)
    except EstimatorFileNotFoundError:
        raise
    except EstimatorError as e:
        text = str(e)
        if "No such file or directory" in text or "os error 2" in text:
            raise EstimatorFileNotFoundError(text) from e
        raise

# pyins-style column names: increments or rates, and the GNSS fields
_INCREMENTS = ["theta_x", "theta_y", "theta_z", "dv_x", "dv_y", "dv_z"]
_RATES = ["gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z"]
_GNSS_POS = [("lat",), ("lon",), ("height", "alt", "h")]
_GNSS_SIGMA = ["sigma_n", "sigma_e", "sigma_d"]
_GNSS_VEL = ["vn", "ve", "vd", "sigma_vn", "sigma_ve", "sigma_vd"]


def _times(df: pd.DataFrame) -> np.ndarray:
    for name in ("time", "t"):
        if name in df.columns:
            return df[name].to_numpy(dtype=float)
    if not np.issubdtype(df.index.dtype, np.number):
        raise ValueError("the DataFrame needs a `time` column or a numeric index (s)")
    return df.index.to_numpy(dtype=float)


def _imu_array(imu: Any) -> "tuple[np.ndarray, Optional[str]]":
    """The IMU rows (t, 6 values[, odometer]) and the format the names say, if any."""
    if isinstance(imu, pd.DataFrame):
        for names, kind in ((_INCREMENTS, "increments"), (_RATES, "rates")):
            if all(c in imu.columns for c in names):
                cols = [_times(imu)] + [imu[c].to_numpy(dtype=float) for c in names]
                if "odometer" in imu.columns:
                    cols.append(imu["odometer"].to_numpy(dtype=float))
                return np.column_stack(cols), kind
        return np.ascontiguousarray(imu.to_numpy(dtype=float)), None
    return np.ascontiguousarray(np.asarray(imu, dtype=float)), None


def _gnss_array(gnss: Any) -> np.ndarray:
    """The GNSS rows: t, lat, lon (deg), height, σ N E D (m)[, velocity N E D and σ]."""
    if isinstance(gnss, pd.DataFrame):
        if "lat" in gnss.columns:
            cols = [_times(gnss)]
            for names in _GNSS_POS:
                found = [n for n in names if n in gnss.columns]
                if not found:
                    raise ValueError(f"the GNSS DataFrame needs a column {' or '.join(names)}")
                cols.append(gnss[found[0]].to_numpy(dtype=float))
            missing = [c for c in _GNSS_SIGMA if c not in gnss.columns]
            if missing:
                raise ValueError(f"the GNSS DataFrame needs the 1σ columns {missing} (m)")
            cols += [gnss[c].to_numpy(dtype=float) for c in _GNSS_SIGMA]
            if all(c in gnss.columns for c in _GNSS_VEL):
                cols += [gnss[c].to_numpy(dtype=float) for c in _GNSS_VEL]
            return np.column_stack(cols)
        return np.ascontiguousarray(gnss.to_numpy(dtype=float))
    return np.ascontiguousarray(np.asarray(gnss, dtype=float))


class Navigation:
    """The results of :func:`navigate`, in the units of the program's files.

    Attributes:
        nav: ``NAV_COLUMNS`` at every IMU epoch (``nav.txt`` without the week).
        std: 1σ of the error states after every update and at least once a second
            (``std.txt``).
        imu_errors: estimated IMU biases (and scale factors) at the same epochs.
        updates: one row per update (``updates.csv``): time, stream, dim, nis,
            nis_adapted, decision, reason, dom, lambda_p, lambda_r, scaling_fallback,
            not_helping (the strategy held its adaptation off: it was not helping).
        smoothed, smoothed_std: the smoother's ``nav`` (every IMU epoch) and ``std``
            (at the epochs of ``std``; ``None`` unless ``smooth=True``).
        summary: the run's summary (counts, span, mean NIS and its band, the lines the
            program prints, and the warning of an accepted inconsistent run).
    """

    def __init__(self, raw: Mapping[str, Any]):
        nav_cols = NAV_COLUMNS
        self.nav = pd.DataFrame(raw["nav"], columns=nav_cols)
        std = raw["std"]
        self.std = pd.DataFrame(std, columns=STD_COLUMNS[: std.shape[1]])
        errs = raw["imu_errors"]
        self.imu_errors = pd.DataFrame(errs, columns=IMU_ERROR_COLUMNS[: errs.shape[1]])
        self.updates = pd.DataFrame(raw["updates"])
        self.smoothed = None
        self.smoothed_std = None
        if "smoothed_nav" in raw:
            self.smoothed = pd.DataFrame(raw["smoothed_nav"], columns=nav_cols)
            s = raw["smoothed_std"]
            self.smoothed_std = pd.DataFrame(s, columns=STD_COLUMNS[: s.shape[1]])
        self.summary = dict(raw["summary"])

    def evaluate(self, truth: PathLike, skip: float = 0.0, smoothed: bool = False) -> dict:
        """Errors against a truth file (11-column navigation or ``t lat lon h``, plain or
        compressed), as ``ins-gnss eval``: a dict of statistics (``overall``: RMS, max,
        mean of N, E, D, horizontal, 3-D, velocity and attitude errors), after ``skip``
        seconds, and ``epochs``: a DataFrame of every compared epoch — ``time``, the
        errors ``north``, ``east``, ``down``, ``horizontal`` (m), ``vn``, ``ve``, ``vd``
        (m/s), ``roll``, ``pitch``, ``yaw`` (deg; result minus truth), the run's 1σ at
        that epoch (``sigma_n`` …, the last ``std`` row at or before it) and
        ``nees_pos``, the position NEES (χ² with 3 degrees of freedom when the σ is
        honest), and ``nees_att`` (attitude, 3)."""
        nav = self.smoothed if smoothed else self.nav
        std = self.smoothed_std if smoothed else self.std
        if nav is None:
            raise ValueError("the run did not smooth (smooth=True)")
        _missing(truth, "the truth file")
        rows = np.ascontiguousarray(nav[NAV_COLUMNS].to_numpy(dtype=float))
        text, per = _native_call(_native.evaluate, rows, os.fspath(truth), float(skip))
        out = json.loads(text)
        cols = ["time", "north", "east", "down", "vn", "ve", "vd", "roll", "pitch", "yaw"]
        ep = pd.DataFrame(per, columns=cols)
        ep.insert(4, "horizontal", np.hypot(ep["north"], ep["east"]))
        sig = ["sigma_n", "sigma_e", "sigma_d", "sigma_vn", "sigma_ve", "sigma_vd",
               "sigma_roll", "sigma_pitch", "sigma_yaw"]
        if std is not None and len(std) and len(ep):
            s = std[["time"] + sig].sort_values("time")
            ep = pd.merge_asof(ep.sort_values("time"), s, on="time", direction="backward")
        else:
            for c in sig:
                ep[c] = np.nan
        ep["nees_pos"] = sum((ep[a] / ep[b]) ** 2 for a, b in
                             (("north", "sigma_n"), ("east", "sigma_e"), ("down", "sigma_d")))
        ep["nees_att"] = sum((ep[a] / ep[b]) ** 2 for a, b in
                             (("roll", "sigma_roll"), ("pitch", "sigma_pitch"),
                              ("yaw", "sigma_yaw")))
        out["epochs"] = ep
        return out

    def plot(self, truth: Optional[PathLike] = None, smoothed: bool = False):
        """The usual three figures (:func:`plot`): track, errors with ±3σ, NIS."""
        return plot(self, truth, smoothed=smoothed)

    def __repr__(self) -> str:
        return "Navigation(\n  " + "\n  ".join(self.summary.get("lines", [])) + "\n)"


def navigate(
    config: Union[PathLike, Mapping[str, Any]],
    imu: Any = None,
    gnss: Any = None,
    *,
    imu_format: Optional[str] = None,
    strategy: Optional[str] = None,
    states: Optional[int] = None,
    smooth: bool = False,
    gate: bool = True,
    nhc: bool = False,
    zupt: bool = False,
    odometer: bool = False,
    vehicle: bool = True,
    bias_model: Optional[str] = None,
    accept_inconsistent: bool = False,
    base: Optional[PathLike] = None,
) -> Navigation:
    """Run the INS/GNSS navigator, as ``ins-gnss run`` with the same options.

    Args:
        config: a TOML or KF-GINS YAML file, or a dict of our TOML's tables
            (``{"data": {"imu_rate": 100.0}, "imu_noise": {...}}``); relative paths in a
            dict are read from ``base`` (default: the working directory).
        imu, gnss: arrays or DataFrames (both, or neither: the configuration's files).
            IMU: rows ``t, x, y, z, x, y, z[, odometer]`` in the configuration's format
            (increments in rad and m/s, or rates in rad/s and m/s²), or a DataFrame with
            pyins-style columns ``theta_x … dv_z`` (increments) or ``gyro_x … accel_z``
            (rates), time in a ``time`` column or the index. GNSS: rows
            ``t, lat, lon (deg), height (m), σN, σE, σD (m)[, vN, vE, vD, σvN, σvE, σvD]``,
            or a DataFrame with those names (``lat, lon, height``, ``sigma_n`` …).
        imu_format: ``"increments"`` or ``"rates"`` (default: the DataFrame's column
            names, else the configuration's ``data.imu_format``).
        strategy: an adaptive strategy (``STRATEGIES``; default the configuration's).
        states: 15 or 21 (with scale factors).
        smooth: also run the smoother (``smoothed``, ``smoothed_std``).
        gate: the gross-error gate (``gate=False`` is ``--no-gate``).
        nhc, zupt, odometer: turn on that vehicle aiding; ``vehicle=False`` turns all off.
        bias_model: ``random-walk``, ``gauss-markov`` or ``gauss-markov-held``.
        accept_inconsistent: keep a run the health check judges quietly wrong (its
            message is ``summary["warning"]``) instead of raising.

    Raises:
        EstimatorError: the configuration, an input or the run refused, with the
            program's message (file and line, or array and row).
    """
    kind_from_names = None
    imu_rows = gnss_rows = None
    if (imu is None) != (gnss is None):
        raise ValueError("give both imu and gnss, or neither (the configuration's files)")
    if imu is not None:
        imu_rows, kind_from_names = _imu_array(imu)
        gnss_rows = _gnss_array(gnss)
        for name, rows in (("imu", imu_rows), ("gnss", gnss_rows)):
            if rows.ndim != 2:
                raise ValueError(f"{name} must be 2-D (rows of samples), not {rows.shape}")
    if isinstance(config, Mapping):
        text, kind = json.dumps(config), "json"
    else:
        _missing(config, "the configuration")
        text, kind = os.fspath(config), "path"
    raw = _native_call(
        _native.navigate,
        text,
        kind=kind,
        base=os.fspath(base) if base is not None else os.getcwd(),
        imu=imu_rows,
        gnss=gnss_rows,
        imu_format=imu_format or kind_from_names,
        strategy=strategy,
        bias_model=bias_model,
        states=states,
        smooth=smooth,
        no_gate=not gate,
        nhc=nhc,
        zupt=zupt,
        odometer=odometer,
        no_vehicle=not vehicle,
        accept_inconsistent=accept_inconsistent,
    )
    return Navigation(raw)


def read_truth(path: PathLike) -> pd.DataFrame:
    """A truth or reference file (11-column navigation, or ``t lat lon h``; plain,
    ``.gz``, ``.zst`` or ``.xz``, read by the library: no extra package) as a DataFrame
    with ``NAV_COLUMNS`` (NaN where the file has no velocity or attitude)."""
    _missing(path, "the truth file")
    return pd.DataFrame(_native_call(_native.read_truth, os.fspath(path)), columns=NAV_COLUMNS)


RTK_COLUMNS = list(_native.RTK_COLUMNS)


def rtk(rover: PathLike, base: PathLike, nav: Union[PathLike, Sequence[PathLike]] = (),
        base_position: Optional[Sequence[float]] = None, static: bool = False,
        frequencies: int = 2, mask: float = 15.0, ratio: float = 3.0, max_age: float = 1.0,
        min_success_rate: Optional[float] = None, partial: bool = False,
        code_bias_sigma: float = 0.3, code_bias_tau: float = 60.0, hold: int = 5,
        against: Optional[PathLike] = None) -> dict:
    """RTK positions of ``rover`` against ``base`` (RINEX observations or u-blox logs,
    plain or compressed), as ``ins-gnss rtk``, with its options and defaults: ``nav`` the
    navigation files, ``base_position`` the base's ECEF X, Y, Z (m; default: the base
    file's ``APPROX POSITION XYZ``), ``static`` a rover standing still, ``against`` an
    RTKLIB ``.pos`` to compare with. Returns a dict: ``solutions``, a DataFrame with
    ``RTK_COLUMNS`` (week, time of week, latitude, longitude in degrees, height and the σ
    north, east, down in m, ``q`` 1 fixed and 2 float, the ratio (NaN: not searched), the
    satellites, the ambiguities fixed); ``metrics``: ``epochs``, ``solved``, ``fixed``,
    ``fix_rate``, ``time_to_first_fix`` (s; None: never), ``refix_times`` (s, one per
    outage of the fix), ``ratio_fixed`` and ``ratio_other`` (minimum, median),
    ``failures`` (epochs without a solution, by reason); ``base`` (latitude, longitude,
    height used); with ``against``: ``common`` epochs, ``rms`` (3-D, m), ``offset_ned``,
    ``fixed_compared`` and ``wrong_fixes`` (fixed epochs more than ``wrong_fix_limit`` m
    from it: wrong fixes, when it is the truth). A setting out of range raises
    ``EstimatorError`` naming it."""
    navs = [nav] if isinstance(nav, (str, os.PathLike)) else list(nav)
    for path, what in [(rover, "the rover's observations"), (base, "the base's observations")] + [
            (n, "the navigation file") for n in navs]:
        _missing(path, what)
    if against is not None:
        _missing(against, "the solution to compare with")
    raw = _native_call(
        _native.rtk, os.fspath(rover), os.fspath(base), [os.fspath(n) for n in navs],
        base_position=None if base_position is None else [float(v) for v in base_position],
        static_rover=bool(static), frequencies=int(frequencies), mask=float(mask),
        ratio=float(ratio), max_age=float(max_age),
        min_success_rate=None if min_success_rate is None else float(min_success_rate),
        partial=bool(partial), code_bias_sigma=float(code_bias_sigma),
        code_bias_tau=float(code_bias_tau), hold=int(hold),
        against=None if against is None else os.fspath(against))
    raw["solutions"] = pd.DataFrame(raw["solutions"], columns=RTK_COLUMNS)
    raw["solutions"]["q"] = raw["solutions"]["q"].astype(int)
    del raw["columns"]
    return raw


def plot(result: "Navigation", truth: Optional[PathLike] = None, smoothed: bool = False):
    """Three figures of a run, with matplotlib (an optional dependency: ``pip install
    matplotlib``): the horizontal track (and the truth's), the position and yaw errors
    against the truth with the run's ±3σ (σ alone without a truth), and the NIS of every
    update with its stream. Returns the three ``Figure`` objects."""
    try:
        import matplotlib.pyplot as plt
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise ImportError("plot needs matplotlib: pip install matplotlib") from e
    nav = result.smoothed if smoothed else result.nav
    if nav is None:
        raise ValueError("the run did not smooth (smooth=True)")
    lat0, lon0 = np.radians(nav["lat"].iloc[0]), np.radians(nav["lon"].iloc[0])
    radius = 6378137.0

    def local(lat, lon):
        return ((np.radians(lon) - lon0) * radius * np.cos(lat0),
                (np.radians(lat) - lat0) * radius)

    track, ax = plt.subplots()
    e, n = local(nav["lat"], nav["lon"])
    ax.plot(e, n, label="estimate")
    ev = None
    if truth is not None:
        tr = read_truth(truth)
        te, tn = local(tr["lat"], tr["lon"])
        ax.plot(te, tn, "--", label="truth")
        ev = result.evaluate(truth, smoothed=smoothed)["epochs"]
    ax.set_xlabel("east (m)"), ax.set_ylabel("north (m)"), ax.axis("equal"), ax.legend()
    errors, axes = plt.subplots(4, 1, sharex=True)
    std = result.smoothed_std if smoothed else result.std
    for a, (err, sig, unit) in zip(axes, (("north", "sigma_n", "m"), ("east", "sigma_e", "m"),
                                          ("down", "sigma_d", "m"),
                                          ("yaw", "sigma_yaw", "deg"))):
        if ev is not None:
            a.plot(ev["time"], ev[err], label="error")
        a.plot(std["time"], 3 * std[sig], "k:", std["time"], -3 * std[sig], "k:")
        a.set_ylabel(f"{err} ({unit})")
    axes[-1].set_xlabel("time (s)")
    nis, ax = plt.subplots()
    for stream, rows in result.updates.groupby("stream"):
        ax.semilogy(rows["time"], rows["nis"] / rows["dim"], ".", label=str(stream))
    ax.set_xlabel("time (s)"), ax.set_ylabel("NIS / dim"), ax.legend()
    return track, errors, nis


def _f64(a: Any) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(a, dtype=float))


def kalman(
    x0: Any,
    P0: Any,
    F: Any,
    Q: Any,
    H: Any,
    R: Any,
    z: Any,
    *,
    strategy: str = "fixed",
    smooth: bool = False,
) -> dict:
    """The Kalman filter over the measurements ``z`` (``steps × m``; a row with a NaN is
    a step without a measurement): at each step predict with ``F, Q`` then update with
    ``H, R`` (FilterPy's ``batch_filter`` order). ``F, Q, H, R`` are one matrix or one per
    step (a leading axis of length ``steps``). ``strategy`` is any of ``STRATEGIES``.

    Returns a dict of arrays: ``x``, ``P`` (posteriors), ``x_prior``, ``P_prior``,
    ``nis``, ``log_likelihood`` (with the covariance the strategy used), ``verdict``
    (accepted, inflated, deflated, rejected, none), and with ``smooth=True`` the RTS
    smoother's ``xs``, ``Ps``. Any size: states of 1 to ``MAX_N`` (9) with 1 to ``MAX_M``
    (8) rows run on the compiled instances, larger ones on the dynamic core (``fixed``
    or ``chi2-gate`` there).
    """
    z = _f64(z)
    if z.ndim == 1:
        z = z.reshape(-1, 1)
    return _native.kalman(_f64(x0).ravel(), _f64(P0), _f64(F), _f64(Q), _f64(H), _f64(R), z,
                          strategy=strategy, smooth=smooth)


def kinematic(name: str, dt: float, q: float, axes: int = 1,
              alpha: Optional[float] = None) -> "tuple[np.ndarray, np.ndarray]":
    """``(F, Q)`` of a built-in model over one step ``dt``: ``cv`` (white acceleration of
    intensity ``q`` m²/s³), ``ca`` (white jerk, m²/s⁵) or ``singer`` (Markov acceleration,
    frequency ``alpha`` 1/s, variance ``q`` (m/s²)²), on 1 to 3 ``axes``. The state is the
    positions of all axes, then the velocities (then the accelerations)."""
    return _native.kinematic(name, float(dt), float(q), axes=axes, alpha=alpha)


def ahrs(
    gyro: Any,
    accel: Any,
    mag: Any,
    rate: float,
    att0: Sequence[float],
    m_n: Sequence[float],
    *,
    g_n: Sequence[float] = (0.0, 0.0, 9.80665),
    variant: str = "cs-maekf",
    gyro_noise: float = 0.005,
    p0: float = 0.01,
    r: float = 0.02,
    strategy: str = "fixed",
    time: Any = None,
) -> pd.DataFrame:
    """The AHRS of the third paper on ``N × 3`` sensor arrays at ``rate`` Hz: gyro (mean
    angular rate over each interval, rad/s), accelerometer (specific force, m/s²) and
    magnetometer (the unit of ``m_n``, the field in NED), all in the body frame (FRD).

    ``variant``: ``conventional`` (no acceleration state), ``modified`` (random-walk
    acceleration), ``modified-tuned`` or ``cs-maekf`` (the adaptive current statistical
    model). Starts from ``att0`` (roll, pitch, yaw, rad) with zero drift and acceleration,
    ``P0 = p0·I``, ``R = r·I``; ``gyro_noise`` is the gyro's white noise per sample
    (rad/s), ``strategy`` any of ``STRATEGIES``.

    Returns a DataFrame: roll, pitch, yaw (deg), drift_x/y/z (rad/s), acc_x/y/z (m/s²),
    the nine 1σ (sigma_att_x … sigma_acc_z; rad, rad/s, m/s²), nis and verdict, indexed
    by ``time`` when given.
    """
    out = _native.ahrs(_f64(gyro), _f64(accel), _f64(mag), float(rate),
                       [float(v) for v in att0], [float(v) for v in m_n],
                       g_n=[float(v) for v in g_n], variant=variant,
                       gyro_noise=float(gyro_noise), p0=float(p0), r=float(r),
                       strategy=strategy)
    axes = ["x", "y", "z"]
    df = pd.DataFrame(np.degrees(out["att"]), columns=["roll", "pitch", "yaw"])
    for name, block in [("drift", out["drift"]), ("acc", out["acc"])]:
        for i, a in enumerate(axes):
            df[f"{name}_{a}"] = block[:, i]
    for j, block in enumerate(["att", "drift", "acc"]):
        for i, a in enumerate(axes):
            df[f"sigma_{block}_{a}"] = out["sigma"][:, 3 * j + i]
    df["nis"] = out["nis"]
    df["verdict"] = out["verdict"]
    if time is not None:
        df.index = pd.Index(np.asarray(time, dtype=float), name="time")
    return df


def ahrs_flight(seed: int = 1) -> dict:
    """The third paper's simulated loitering flight for ``seed`` (100 Hz, 180 s): a
    DataFrame ``samples`` (t, gyro_x … mag_z, true roll, pitch, yaw in rad), ``att0``
    (the true attitude at t = 0, where the paper's filters start), the flight's ``rate``,
    ``g_n``, ``m_n``, and ``experiment``: the library's own run of each variant
    (max and RMS roll, pitch, yaw errors, deg)."""
    f = _native.ahrs_flight(int(seed))
    samples = pd.DataFrame({"t": f["t"]})
    for name in ["gyro", "accel", "mag"]:
        for i, a in enumerate(["x", "y", "z"]):
            samples[f"{name}_{a}"] = f[name][:, i]
    for i, a in enumerate(["roll", "pitch", "yaw"]):
        samples[a] = f["att"][:, i]
    return {"samples": samples, "att0": f["att0"], "rate": f["rate"], "g_n": f["g_n"], "m_n": f["m_n"],
            "experiment": f["experiment"]}


MAX_N = _native.MAX_N
MAX_M = _native.MAX_M
