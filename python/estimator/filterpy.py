"""Your own models as Python callables, in the shape FilterPy users know.

:class:`ExtendedKalmanFilter`, :class:`UnscentedKalmanFilter` and :class:`KalmanFilter`
keep FilterPy's attributes (``x``, ``P``, ``Q``, ``R``, ``F``, ``K``, ``y``, ``S``,
``SI``, ``log_likelihood``, ``x_prior``/``P_prior``, ``x_post``/``P_post``) and calls
(``predict``, ``update``, ``predict_x``, ``batch_filter``, ``rts_smoother``), so a
FilterPy run moves over by changing its imports. Your functions — ``fx``, ``hx``, the
Jacobians, ``x_mean_fn``/``z_mean_fn``, ``residual_x``/``residual_z`` — are evaluated
in Python; the prediction and the update run in the library (``estimator._native``), so
what FilterPy does not have comes with them:

- ``strategy=``: every adaptive noise strategy by name (``estimator.STRATEGIES``), the
  gross-error gate among them (``"chi2-gate"``);
- ``verdict`` after each update (``accepted``, ``inflated``, ``deflated``,
  ``rejected``), ``nis`` and ``nis_adapted``; a refused measurement leaves ``x`` and
  ``P`` as they were;
- ``smooth=True``: the library's RTS smoother over every prediction made
  (:meth:`smoothed`), for the extended and unscented filters too; ``lag=k``: its
  fixed-lag smoother over the last ``k`` predictions, in bounded memory.

Any size: states of 1 to ``estimator._native.CALLABLE_MAX_N`` (9) with measurements of
up to ``CALLABLE_MAX_M`` (8) rows run on the library's compiled instances; a filter made
with more (``dim_x`` > 9 or ``dim_z`` > 8, or ``dynamic=True``) runs on a heap core of
dynamic dimensions with the same equations — the noise ``fixed`` or ``chi2-gate`` only
(an adaptive strategy there is refused by name), the smoothers as on the compiled sizes
(``python/src/dynamic.rs``; the two cores agree to 1e-9 in the tests).

Filters copy and pickle (``copy.deepcopy``, ``pickle``: the state, covariance, the
strategy's state and the smoothing history, bit for bit) and FilterPy's ``Saver`` works
on them, as does :class:`estimator.common.Saver`.

The unscented update is the library's statistical linear regression of the sigma
points (``H̃ = P_xzᵀ P⁻¹``, noise ``R + Ω``): its ``S`` and ``K`` are FilterPy's
(``S = P_zz + R``, ``K = P_xz S⁻¹``) to rounding, and a strategy sees ``R + Ω`` as the
measurement noise. The unscented prediction goes to the library as its statistical
transition ``F̃ = P_yx P⁻¹`` and ``Q + Ω_f`` (``P⁻ = F̃ P F̃ᵀ + Q + Ω_f``, FilterPy's to
rounding), which the smoother records.
"""

from __future__ import annotations

import sys
from copy import deepcopy
from math import exp, log, sqrt
from typing import Callable, Optional

import numpy as np

from . import _native

__all__ = [
    "KalmanFilter",
    "ExtendedKalmanFilter",
    "UnscentedKalmanFilter",
    "MerweScaledSigmaPoints",
    "unscented_transform",
]

#: The fixed (strategy-free) noise strategies: everything else adapts Q, R or P⁻.
_PLAIN = ("fixed", "kf", "chi2-gate")


def _matrix(v, n: int) -> np.ndarray:
    """A scalar as ``v·I``, anything else as a float array."""
    if np.isscalar(v):
        return np.eye(n) * float(v)
    return np.asarray(v, dtype=float)


def _square(name: str, v, n: int) -> np.ndarray:
    """``v`` as an ``n × n`` matrix (a scalar is ``v·I``), or a ValueError naming it."""
    if type(v) is np.ndarray and v.shape == (n, n) and v.dtype == np.float64:
        return v
    m = _matrix(v, n)
    if m.size == 1 and n == 1:
        return m.reshape(1, 1)
    if m.shape != (n, n):
        raise ValueError(f"{name} has shape {m.shape}; ({n}, {n}) expected")
    return m


def _process_noise(v, n: int) -> np.ndarray:
    """``Q`` as an ``n × n`` matrix: a scalar is added to every entry of ``P⁻``, as
    FilterPy's ``P = F P Fᵀ + Q`` broadcasts it (``q·1 1ᵀ``, not ``q·I``)."""
    if type(v) is not np.ndarray and np.isscalar(v):
        return np.full((n, n), float(v))
    return _square("Q", v, n)


def _psd(Q: np.ndarray) -> np.ndarray:
    """A symmetric matrix that is positive semi-definite to rounding, with its negative
    eigenvalues (rounding, ~1e-16 of its scale) set to zero: a difference of two
    covariances (``P⁻ − F̃ P F̃ᵀ``) is one."""
    Q = (Q + Q.T) / 2
    w, V = np.linalg.eigh(Q)
    if w.min() >= 0:
        return Q
    return (V * np.maximum(w, 0.0)) @ V.T


def _log_normal(y, S) -> float:
    """ln N(y; 0, S)."""
    y = np.ravel(y)
    _, logdet = np.linalg.slogdet(S)
    return float(-0.5 * (y.size * log(2 * np.pi) + logdet + y @ np.linalg.solve(S, y)))


def _z(z, rows: int, ndim: int, what: str = "dim_z") -> np.ndarray:
    """A measurement as ``rows`` values, a column when ``x`` is one (FilterPy's
    ``reshape_z``), or a ValueError naming ``z``."""
    a = np.asarray(z, dtype=float)
    if a.ndim > 2 or a.size != rows or (a.ndim == 2 and 1 not in a.shape):
        raise ValueError(f"z has shape {a.shape}; {rows} values expected ({what})")
    return a.reshape(rows, 1) if ndim == 2 else a.reshape(rows)


def _none_z(dim_z: int) -> np.ndarray:
    return np.array([[None] * dim_z]).T


class _Core:
    """What the three filters share: the native core, the attributes FilterPy gives after
    an update, fading memory (``alpha``), the smoother and copying.

    The native core lives in a slot, outside ``__dict__``: ``copy.deepcopy`` and
    ``pickle`` carry it (state, covariance, the strategy's state, the smoothing history),
    and FilterPy's ``Saver``, which deep-copies ``__dict__`` at every save, does not."""

    __slots__ = ("_core", "__dict__", "__weakref__")

    def __init__(self, dim_x: int, dim_z: int, strategy: str, smooth: bool,
                 lag: Optional[int] = None, dynamic: bool = False):
        if int(dim_x) < 1 or int(dim_z) < 1:
            raise ValueError(f"dim_x and dim_z must be at least 1 (dim_x={dim_x}, dim_z={dim_z})")
        self.dim_x, self.dim_z = int(dim_x), int(dim_z)
        self._core = _native.CallableCore(self.dim_x, strategy, smooth, lag, self.dim_z, dynamic)
        self.x = np.zeros((dim_x, 1))
        self._P = np.eye(dim_x)
        self._new_run = False
        self.Q = np.eye(dim_x)
        self.R = np.eye(dim_z)
        self.K = np.zeros((dim_x, dim_z))
        self.y = np.zeros((dim_z, 1))
        self.S = np.zeros((dim_z, dim_z))
        self._SI = np.zeros((dim_z, dim_z))
        self.inv = np.linalg.inv
        self.z = _none_z(dim_z)
        self._alpha_sq = 1.0
        self.nis = float("nan")
        self.nis_adapted = float("nan")
        self.verdict = None
        self._log_likelihood = log(sys.float_info.min)
        self._q_log = None
        self._save_prior()
        self._save_post()

    # the covariance: assigning it starts a new run (a new smoothing history)
    @property
    def P(self) -> np.ndarray:
        """The covariance. Assigning it (``kf.P = …``, as a new run starts) begins a new
        smoothing history: :meth:`smoothed` then covers the predictions made since."""
        return self._P

    @P.setter
    def P(self, value):
        self._P = value
        self._new_run = True

    @property
    def SI(self) -> np.ndarray:
        """``S⁻¹`` of the last update, by ``self.inv`` (computed when first asked for;
        zeros before an update, as FilterPy's)."""
        if self._SI is None:
            self._SI = self.inv(self.S)
        return self._SI

    @SI.setter
    def SI(self, value):
        self._SI = value

    @property
    def alpha(self) -> float:
        """FilterPy's fading memory: ``P⁻ = α² F P Fᵀ + Q`` (1: none)."""
        return sqrt(self._alpha_sq)

    @alpha.setter
    def alpha(self, value):
        if not np.isscalar(value) or value <= 0:
            raise ValueError(f"alpha must be a positive number, not {value!r}")
        self._alpha_sq = float(value) ** 2

    # FilterPy's read-only statistics of the last update
    @property
    def log_likelihood(self) -> float:
        """ln N(y; 0, S) of the last update (with the strategy's adapted S)."""
        return self._log_likelihood

    @property
    def likelihood(self) -> float:
        return max(exp(self._log_likelihood), sys.float_info.min)

    @property
    def mahalanobis(self) -> float:
        """√(yᵀ S⁻¹ y) of the last update (nominal S; 0 before one)."""
        return sqrt(self.nis) if self.nis == self.nis else 0.0

    @property
    def strategy(self) -> str:
        return self._core.strategy

    @property
    def dynamic(self) -> bool:
        """True when the filter runs on the dynamic-dimension core (more than
        ``CALLABLE_MAX_N`` states or ``CALLABLE_MAX_M`` measurement rows)."""
        return self._core.dynamic

    def reset_smoother(self):
        """Forget the recorded predictions: the next one starts a new smoothing history."""
        self._core.reset_history()
        self._new_run = False

    def _shape(self, v: np.ndarray) -> np.ndarray:
        """`v` in the shape the user keeps ``x`` in (FilterPy's EKF uses a column)."""
        return v.reshape(np.shape(self.x)) if np.size(self.x) == v.size else v

    def _save_prior(self):
        self.x_prior, self.P_prior = np.copy(self.x), np.copy(self._P)

    def _save_post(self):
        self.x_post, self.P_post = np.copy(self.x), np.copy(self._P)

    def _no_update(self):
        """``update(None)``: FilterPy's attributes of a step without a measurement."""
        self.z = _none_z(self.dim_z)
        keep = np.size(self.y) == self.dim_z
        self.y = np.zeros_like(self.y) if keep else np.zeros((self.dim_z, 1))
        self._save_post()

    def _native_predict(self, x_new, F, Q, dt):
        """P⁻ = λ α² F P Fᵀ + Q from the library (the strategy's fading and Q), recorded
        for the smoother."""
        if self._new_run:
            self._core.reset_history()
            self._new_run = False
        n = self.dim_x
        F = _square("F", F, n)
        Q = _process_noise(Q, n)
        P = np.asarray(self._P, dtype=float)
        if P.shape != (n, n):
            raise ValueError(f"P has shape {P.shape}; ({n}, {n}) expected")
        if self._alpha_sq > 1.0:  # fading memory as added process noise: F stays F
            Q = Q + (self._alpha_sq - 1.0) * (F @ P @ F.T)
        elif self._alpha_sq < 1.0:
            F = F * sqrt(self._alpha_sq)
        x_new = np.asarray(x_new, dtype=float)
        self._P = self._core.predict(np.ravel(self.x).astype(float), P, np.ravel(x_new),
                                     F, Q, float(dt))
        if self._q_log is not None:
            self._q_log.append(self._P - F @ P @ F.T)
        self.x = self._shape(np.ravel(x_new).copy()) if np.ndim(self.x) else x_new
        self._save_prior()

    def _native_update(self, y, H, R, Pzz=None):
        """The library's update on innovation `y`; sets FilterPy's attributes and ours."""
        y = np.ravel(np.asarray(y, dtype=float))
        R = _square("R", R, y.size)
        out = self._core.update(np.ravel(self.x).astype(float), np.asarray(self._P, dtype=float),
                                y, np.asarray(H, dtype=float), R,
                                None if Pzz is None else np.asarray(Pzz, dtype=float))
        self.verdict = out["verdict"]
        self.nis, self.nis_adapted = out["nis"], out["nis_adapted"]
        self._log_likelihood = out["log_likelihood"]
        self.S = out["S"]
        self._SI = None
        self.y = y.reshape(np.shape(self.y)) if np.size(self.y) == y.size else y
        if self.verdict != "rejected":
            self.K = out["K"]
            self.x = self._shape(out["x"])
            self._P = out["P"]
        self._save_post()
        return out

    def smoothed(self):
        """The smoother's estimates ``(xs, Ps)``: with ``smooth=True`` the RTS smoother's
        at the start and after every prediction since (with the updates that followed
        it); with ``lag=k`` the fixed-lag smoother's over the last ``k`` predictions (the
        first is ``x(t − k steps | t)``), in bounded memory. A new run (``P`` assigned, or
        :meth:`reset_smoother`) starts a new history. The process noise is the one each
        prediction used: the strategy's adapted ``Q`` (and fading), not the nominal."""
        return self._core.smooth()

    def __repr__(self) -> str:
        return (f"{type(self).__name__}(dim_x={self.dim_x}, dim_z={self.dim_z}, "
                f"strategy={self.strategy!r}, x={np.ravel(self.x)!r})")


class KalmanFilter(_Core):
    """FilterPy's ``KalmanFilter`` (linear ``F``, ``B``, ``H``) on the library's filter.

    ``predict(u)``: ``x = F x + B u``, ``P = λ α² F P Fᵀ + Q``; ``update(z)``:
    ``y = z − H x`` and the library's update (Joseph form, the strategy, the gate).
    ``batch_filter`` and ``rts_smoother`` return what FilterPy's do; so do
    ``predict_steadystate``, ``update_steadystate``, ``update_sequential``,
    ``update_correlated`` (with ``M``), ``get_prediction``, ``get_update``,
    ``residual_of``, ``measurement_of_state``, ``log_likelihood_of`` and
    ``test_matrix_dimensions``. ``x`` is a column by default, as in FilterPy; a 1-D ``x``
    you assign stays 1-D.
    """

    def __init__(self, dim_x: int, dim_z: int, dim_u: int = 0, strategy: str = "fixed",
                 smooth: bool = False, lag: Optional[int] = None, dynamic: bool = False):
        super().__init__(dim_x, dim_z, strategy, smooth, lag, dynamic)
        self.dim_u = dim_u
        self.F = np.eye(dim_x)
        self.H = np.zeros((dim_z, dim_x))
        self.B = None
        self.M = np.zeros((dim_x, dim_z))
        self._I = np.eye(dim_x)
        self._dt = 1.0

    def _control(self, x, u, B):
        if B is not None and u is not None:
            return x + np.dot(B, u)
        return x

    def _Q(self, Q):
        """FilterPy's rule: ``self.Q`` as a scalar is added to every entry, a scalar
        passed to the call is ``q·I``."""
        if Q is None:
            return self.Q
        return np.eye(self.dim_x) * Q if np.isscalar(Q) else Q

    def predict(self, u=None, B=None, F=None, Q=None):
        F = self.F if F is None else F
        Q = self._Q(Q)
        B = self.B if B is None else B
        x = self._control(_matrix(F, self.dim_x) @ self.x, u, B)
        self._native_predict(x, F, Q, self._dt)

    def _H(self, H):
        H = self.H if H is None else H
        H = np.atleast_2d(np.asarray(H, dtype=float))
        if H.shape[1] != self.dim_x:
            raise ValueError(f"H has shape {H.shape}; {self.dim_x} columns expected (dim_x)")
        return H

    def update(self, z, R=None, H=None):
        if z is None:
            self._no_update()
            return
        H = self._H(H)
        R = self.R if R is None else R
        zz = _z(z, H.shape[0], np.ndim(self.x), "the rows of H")
        self._native_update(np.ravel(zz) - np.ravel(H @ np.ravel(self.x)), H, R)
        self.y = np.reshape(self.y, zz.shape)
        self.z = deepcopy(z)

    def predict_steadystate(self, u=0, B=None):
        """``x = F x + B u`` with ``P`` left as it is (a steady-state gain ``K``)."""
        B = self.B if B is None else B
        self.x = self._control(np.dot(self.F, self.x), u, B)
        self._save_prior()

    def update_steadystate(self, z):
        """``x = x + K (z − H x)`` with the ``K`` you set, ``P`` left as it is."""
        if z is None:
            self._no_update()
            return
        zz = _z(z, self.H.shape[0], np.ndim(self.x), "the rows of H")
        self.y = zz - np.reshape(self.H @ np.ravel(self.x), zz.shape)
        self.x = self.x + np.reshape(self.K @ np.ravel(self.y), np.shape(self.x))
        self.z = deepcopy(z)
        self._save_post()

    def update_sequential(self, start, z_i, R_i=None, H_i=None):
        """The rows ``start …`` of the measurement alone (FilterPy's sequential update):
        ``R_i`` and ``H_i`` default to those rows of ``R`` and ``H``; ``y`` and ``K``
        get those rows and columns."""
        z_i = np.atleast_1d(np.asarray(z_i, dtype=float)).ravel()
        stop = start + z_i.size
        if R_i is None:
            R_i = np.asarray(self.R, dtype=float)[start:stop, start:stop]
        H_i = self.H[start:stop] if H_i is None else H_i
        H_i = np.reshape(np.asarray(H_i, dtype=float), (z_i.size, self.dim_x))
        if np.ndim(self.y) != 2 or np.size(self.y) != self.dim_z:
            self.y = np.zeros((self.dim_z, 1))
        y_i = z_i - H_i @ np.ravel(self.x)
        y = np.array(self.y, dtype=float).reshape(self.dim_z, 1)
        S, SI, K = self.S, self._SI, np.copy(self.K)
        self._native_update(y_i, H_i, R_i)
        K[:, start:stop] = self.K
        self.K, self.S, self._SI = K, S, SI
        y[start:stop, 0] = y_i
        self.y = y

    def update_correlated(self, z, R=None, H=None):
        """The update with measurement noise correlated with the process noise by ``M``
        (FilterPy's): ``S = H P Hᵀ + H M + Mᵀ Hᵀ + R``, ``K = (P Hᵀ + M) S⁻¹``,
        ``P = P − K (H P + Mᵀ)``. Its equations are FilterPy's, outside the library's
        update: a strategy other than ``fixed`` is refused here."""
        if self.strategy not in _PLAIN[:2]:
            raise ValueError(f"update_correlated runs with the fixed noise only, not "
                             f"strategy {self.strategy!r}")
        if z is None:
            self._no_update()
            return
        H = self._H(H)
        R = _square("R", self.R if R is None else R, H.shape[0])
        zz = _z(z, H.shape[0], np.ndim(self.x), "the rows of H")
        x = np.ravel(self.x)
        y = np.ravel(zz) - H @ x
        P = np.asarray(self._P, dtype=float)
        M = np.asarray(self.M, dtype=float).reshape(self.dim_x, H.shape[0])
        S = H @ P @ H.T + H @ M + M.T @ H.T + R
        SI = self.inv(S)
        K = (P @ H.T + M) @ SI
        self.x = self._shape(x + K @ y)
        self._P = P - K @ (H @ P + M.T)
        self.S, self.SI, self.K = S, SI, K
        self.y = np.reshape(y, zz.shape)
        self.nis = self.nis_adapted = float(y @ SI @ y)
        self._log_likelihood = _log_normal(y, S)
        self.verdict = "accepted"
        self.z = deepcopy(z)
        self._save_post()

    def log_likelihood_of(self, z) -> float:
        """ln N(z − H x; 0, S) of a measurement with the last update's ``S`` (as
        FilterPy's: call it after an update), the filter unchanged."""
        if z is None:
            return log(sys.float_info.min)
        y = np.ravel(z) - self.H @ np.ravel(self.x)
        return _log_normal(y, self.S)

    def get_prediction(self, u=None, B=None, F=None, Q=None):
        """``(x, P)`` of a prediction (with ``alpha``), the filter unchanged."""
        F = _square("F", self.F if F is None else F, self.dim_x)
        Q = _process_noise(self._Q(Q), self.dim_x)
        B = self.B if B is None else B
        x = self._control(F @ self.x, u, B)
        return x, self._alpha_sq * (F @ self._P @ F.T) + Q

    def get_update(self, z=None):
        """``(x, P)`` of an update with ``z`` (Joseph form), the filter unchanged."""
        if z is None:
            return np.copy(self.x), np.copy(self._P)
        H = self._H(None)
        R = _square("R", self.R, H.shape[0])
        zz = _z(z, H.shape[0], np.ndim(self.x), "the rows of H")
        y = np.ravel(zz) - H @ np.ravel(self.x)
        P = np.asarray(self._P, dtype=float)
        S = H @ P @ H.T + R
        K = P @ H.T @ self.inv(S)
        I_KH = np.eye(self.dim_x) - K @ H
        return self._shape(np.ravel(self.x) + K @ y), I_KH @ P @ I_KH.T + K @ R @ K.T

    def residual_of(self, z):
        """``z − H x⁻`` (against the prior)."""
        zz = _z(z, self.H.shape[0], np.ndim(self.x_prior), "the rows of H")
        return zz - np.reshape(self.H @ np.ravel(self.x_prior), zz.shape)

    def measurement_of_state(self, x):
        """``H x``."""
        return np.dot(self.H, x)

    def test_matrix_dimensions(self, z=None, H=None, R=None, F=None, Q=None):
        """Raise a ValueError naming the first matrix whose shape does not fit
        ``dim_x``, ``dim_z`` (FilterPy's check, with its messages' meaning)."""
        n, m = self.dim_x, self.dim_z
        H = self.H if H is None else H
        R = self.R if R is None else R
        F = self.F if F is None else F
        Q = self.Q if Q is None else Q
        for name, v, shape in (("x", self.x, None), ("P", self._P, (n, n)), ("Q", Q, (n, n)),
                               ("F", F, (n, n)), ("H", H, (m, n)), ("R", R, (m, m))):
            a = np.asarray(v)
            if name == "x":
                if a.shape not in ((n,), (n, 1)):
                    raise ValueError(f"x has shape {a.shape}; ({n},) or ({n}, 1) expected")
            elif name in ("Q", "R") and np.isscalar(v):
                continue
            elif a.shape != shape and not (a.size == 1 and shape == (1, 1)):
                raise ValueError(f"{name} has shape {a.shape}; {shape} expected")
        if z is not None:
            a = np.asarray(z)
            if np.ndim(self.x) == 2 and m > 1 and a.shape != (m, 1):
                raise ValueError(f"z has shape {a.shape}; ({m}, 1) expected")
            if np.ndim(self.x) == 1 and m > 1 and a.shape != (m,):
                raise ValueError(f"z has shape {a.shape}; ({m},) expected")
            if m == 1 and a.ndim > 1 and a.shape != (1, 1) or m == 1 and a.size != 1:
                raise ValueError(f"z has shape {a.shape}; one value expected")
            if m == 1 and np.ndim(self.x) == 1 and a.ndim == 2:
                raise ValueError(f"z has shape {a.shape}; a scalar or (1,) expected")

    def batch_filter(self, zs, Fs=None, Qs=None, Hs=None, Rs=None, Bs=None, us=None,
                     update_first=False, saver=None):
        """Predict then update at every measurement (``None``: predict only). Returns
        ``(means, covariances, means_predictions, covariances_predictions)``. The process
        noise each prediction used (the strategy's, with fading) is kept for
        :meth:`rts_smoother`."""
        n = len(zs)
        Fs = [self.F] * n if Fs is None else Fs
        Qs = [self.Q] * n if Qs is None else Qs
        Hs = [self.H] * n if Hs is None else Hs
        Rs = [self.R] * n if Rs is None else Rs
        Bs = [self.B] * n if Bs is None else Bs
        us = [None] * n if us is None else us
        means, covs, means_p, covs_p = [], [], [], []
        self._q_log = []
        try:
            for z, F, Q, H, R, B, u in zip(zs, Fs, Qs, Hs, Rs, Bs, us):
                if update_first:
                    self.update(z, R=R, H=H)
                    means.append(np.copy(self.x)), covs.append(np.copy(self._P))
                    self.predict(u=u, B=B, F=F, Q=Q)
                    means_p.append(np.copy(self.x)), covs_p.append(np.copy(self._P))
                else:
                    self.predict(u=u, B=B, F=F, Q=Q)
                    means_p.append(np.copy(self.x)), covs_p.append(np.copy(self._P))
                    self.update(z, R=R, H=H)
                    means.append(np.copy(self.x)), covs.append(np.copy(self._P))
                if saver is not None:
                    saver.save()
            self._q_used = self._q_log
        finally:
            self._q_log = None
        return np.array(means), np.array(covs), np.array(means_p), np.array(covs_p)

    def rts_smoother(self, Xs, Ps, Fs=None, Qs=None, inv=np.linalg.inv):
        """The RTS smoother over a run's posteriors ``Xs``, ``Ps`` (``batch_filter``'s),
        by the library's smoother: returns ``(x, P, K, Pp)`` as FilterPy does — the
        smoothed states and covariances, the smoother gains and the predicted
        covariances. Without ``Qs``, after a ``batch_filter`` of the same length by a
        strategy that adapts the noise, the process noise each of its predictions used
        (so this agrees with :meth:`smoothed`); otherwise ``Q``."""
        n = len(Xs)
        Fs = [self.F] * n if Fs is None else Fs
        if Qs is None:
            used = getattr(self, "_q_used", None)
            adapted = self.strategy not in _PLAIN or self._alpha_sq != 1.0
            if adapted and used is not None and len(used) == n:
                Qs = used
            else:
                Qs = [self.Q] * n
        Xs, Ps = np.asarray(Xs, dtype=float), np.asarray(Ps, dtype=float)
        shape = Xs.shape
        core = _native.CallableCore(self.dim_x, "fixed", True, None, self.dim_z, self.dynamic)
        Pp = np.copy(Ps)  # (the last one is the last posterior's, as FilterPy returns it)
        for k in range(n - 1):
            F, Q = _matrix(Fs[k + 1], self.dim_x), _process_noise(Qs[k + 1], self.dim_x)
            Q = _psd(Q)
            Pp[k] = core.predict(np.ravel(Xs[k]), Ps[k], F @ np.ravel(Xs[k]), F, Q, 1.0)
        core.set(np.ravel(Xs[-1]), Ps[-1])
        xs, ps = core.smooth()
        K = np.zeros_like(Ps)
        for k in range(n - 1):
            F = _matrix(Fs[k + 1], self.dim_x)
            K[k] = Ps[k] @ F.T @ inv(Pp[k])
        return xs.reshape(shape), ps, K, Pp


class ExtendedKalmanFilter(_Core):
    """FilterPy's ``ExtendedKalmanFilter``: ``predict(u)`` runs ``predict_x(u)``
    (override it for a nonlinear motion; by default ``x = F x + B u``) and
    ``P = λ α² F P Fᵀ + Q`` with the ``F`` and ``Q`` you set (the Jacobian and noise at
    this step); ``update(z, HJacobian, Hx, …)`` evaluates your functions and runs the
    library's update. ``x`` is a column, as in FilterPy."""

    def __init__(self, dim_x: int, dim_z: int, dim_u: int = 0, strategy: str = "fixed",
                 smooth: bool = False, dt: float = 1.0, lag: Optional[int] = None,
                 dynamic: bool = False):
        super().__init__(dim_x, dim_z, strategy, smooth, lag, dynamic)
        self.dim_u = dim_u
        self.F = np.eye(dim_x)
        self.B = 0
        self._I = np.eye(dim_x)
        self._dt = dt

    def predict_x(self, u=0):
        """The state's prediction, ``x = F x + B u``; override for your motion model."""
        self.x = np.dot(self.F, self.x) + np.dot(self.B, u)

    def predict(self, u=0):
        x0 = np.copy(self.x)
        self.predict_x(u)
        x_new = np.copy(self.x)
        self.x = x0  # the library predicts from the posterior
        self._native_predict(x_new, self.F, self.Q, self._dt)

    def update(self, z, HJacobian: Callable, Hx: Callable, R=None, args=(), hx_args=(),
               residual: Callable = np.subtract):
        if z is None:
            self._no_update()
            return
        if not isinstance(args, tuple):
            args = (args,)
        if not isinstance(hx_args, tuple):
            hx_args = (hx_args,)
        R = self.R if R is None else R
        if np.isscalar(z) and self.dim_z == 1:
            z = np.asarray([z], float)
        H = np.atleast_2d(np.asarray(HJacobian(self.x, *args), dtype=float))
        if H.shape[1] != self.dim_x:
            raise ValueError(f"HJacobian gave shape {H.shape}; {self.dim_x} columns expected")
        if np.size(z) != H.shape[0]:
            raise ValueError(f"z has {np.size(z)} values; HJacobian gave {H.shape[0]} rows")
        hx = Hx(self.x, *hx_args)
        y = residual(z, hx)
        self._native_update(y, H, R)
        self.z = deepcopy(z)

    def predict_update(self, z, HJacobian, Hx, args=(), hx_args=(), u=0):
        self.predict(u)
        self.update(z, HJacobian, Hx, args=args, hx_args=hx_args)


def _cholesky_upper(a):
    """The upper Cholesky factor ``U`` (``Uᵀ U = a``), FilterPy's default square root."""
    return np.linalg.cholesky(a).T


class MerweScaledSigmaPoints:
    """Van der Merwe's scaled sigma points (``2n + 1``): ``λ = α² (n + κ) − n``, the
    points ``x``, ``x ± row k of U`` with ``Uᵀ U = (n + λ) P``; ``Wm₀ = λ/(n + λ)``,
    ``Wc₀ = Wm₀ + 1 − α² + β``, the others ``1/(2 (n + λ))``. ``subtract(x, y)`` adds a
    row to ``x`` as ``subtract(x, −row)`` (for angles)."""

    def __init__(self, n: int, alpha: float, beta: float, kappa: float,
                 sqrt_method: Optional[Callable] = None, subtract: Optional[Callable] = None):
        self.n, self.alpha, self.beta, self.kappa = n, alpha, beta, kappa
        self.sqrt = sqrt_method if sqrt_method is not None else _cholesky_upper
        self.subtract = subtract if subtract is not None else np.subtract
        lam = alpha ** 2 * (n + kappa) - n
        c = 0.5 / (n + lam)
        self.Wc = np.full(2 * n + 1, c)
        self.Wm = np.full(2 * n + 1, c)
        self.Wc[0] = lam / (n + lam) + (1 - alpha ** 2 + beta)
        self.Wm[0] = lam / (n + lam)
        self._lam = lam

    def num_sigmas(self) -> int:
        return 2 * self.n + 1

    def sigma_points(self, x, P) -> np.ndarray:
        x = np.atleast_1d(np.asarray(x, dtype=float))
        n = x.size
        P = np.eye(n) * P if np.isscalar(P) else np.atleast_2d(P)
        U = self.sqrt((self._lam + n) * P)
        sigmas = np.zeros((2 * n + 1, n))
        sigmas[0] = x
        for k in range(n):
            sigmas[k + 1] = self.subtract(x, -U[k])
            sigmas[n + k + 1] = self.subtract(x, U[k])
        return sigmas


def unscented_transform(sigmas, Wm, Wc, noise_cov=None, mean_fn=None, residual_fn=None):
    """The weighted mean (``mean_fn(sigmas, Wm)`` if given) and covariance
    ``Σ Wcᵢ dᵢ dᵢᵀ (+ noise_cov)`` of sigma points, ``dᵢ = residual_fn(σᵢ, mean)``."""
    x = np.dot(Wm, sigmas) if mean_fn is None else mean_fn(sigmas, Wm)
    if residual_fn is None or residual_fn is np.subtract:
        d = sigmas - x[np.newaxis, :]
        P = np.dot(d.T, np.dot(np.diag(Wc), d))
    else:
        P = np.zeros((sigmas.shape[1], sigmas.shape[1]))
        for k in range(sigmas.shape[0]):
            d = residual_fn(sigmas[k], x)
            P += Wc[k] * np.outer(d, d)
    if noise_cov is not None:
        P = P + noise_cov
    return x, P


class UnscentedKalmanFilter(_Core):
    """FilterPy's ``UnscentedKalmanFilter(dim_x, dim_z, dt, hx, fx, points, …)``:
    ``predict(dt, **fx_args)`` passes the points through ``fx``; ``update(z, **hx_args)``
    through ``hx``; ``x_mean_fn``, ``z_mean_fn``, ``residual_x``, ``residual_z`` and
    ``state_add`` as FilterPy takes them; ``batch_filter``, ``rts_smoother``,
    ``compute_process_sigmas`` and ``cross_variance`` as FilterPy's. The sigma-point
    statistics are computed here; the library predicts and updates with them (see the
    module)."""

    def __init__(self, dim_x: int, dim_z: int, dt: float, hx: Callable, fx: Callable,
                 points, sqrt_fn=None, x_mean_fn=None, z_mean_fn=None, residual_x=None,
                 residual_z=None, state_add=None, strategy: str = "fixed",
                 smooth: bool = False, lag: Optional[int] = None, dynamic: bool = False):
        super().__init__(dim_x, dim_z, strategy, smooth, lag, dynamic)
        self.x = np.zeros(dim_x)
        self.y = np.zeros(dim_z)
        self._save_prior()
        self._save_post()
        self._dt, self.hx, self.fx = dt, hx, fx
        self.points_fn = points
        self.msqrt = sqrt_fn if sqrt_fn is not None else _cholesky_upper
        self.x_mean, self.z_mean = x_mean_fn, z_mean_fn
        self.residual_x = residual_x if residual_x is not None else np.subtract
        self.residual_z = residual_z if residual_z is not None else np.subtract
        self.state_add = state_add if state_add is not None else np.add
        self.Wm, self.Wc = points.Wm, points.Wc
        self.sigmas_f = np.zeros((points.num_sigmas(), dim_x))
        self.sigmas_h = np.zeros((points.num_sigmas(), dim_z))

    def compute_process_sigmas(self, dt, fx=None, **fx_args):
        """``sigmas_f``: the points of ``(x, P)`` through ``fx`` (as FilterPy's, e.g. to
        update twice between predictions)."""
        fx = self.fx if fx is None else fx
        sigmas = self.points_fn.sigma_points(self.x, self._P)
        self.sigmas_f = np.array([fx(s, dt, **fx_args) for s in sigmas], dtype=float)
        return sigmas

    def cross_variance(self, x, z, sigmas_f, sigmas_h):
        """``P_xz = Σ Wcᵢ residual_x(σfᵢ, x) residual_z(σhᵢ, z)ᵀ``."""
        return self._cross(sigmas_f, x, self.residual_x, sigmas_h, z, self.residual_z)

    def _cross(self, a, a_mean, res_a, b, b_mean, res_b):
        """``Σ Wcᵢ res_a(aᵢ, ā) res_b(bᵢ, b̄)ᵀ`` (one product when both are subtractions)."""
        if res_a is np.subtract and res_b is np.subtract:
            da = a - np.reshape(a_mean, (1, -1))
            db = b - np.reshape(b_mean, (1, -1))
            return (da * self.Wc[:, None]).T @ db
        out = np.zeros((a.shape[1], b.shape[1]))
        for k in range(a.shape[0]):
            out += self.Wc[k] * np.outer(res_a(a[k], a_mean), res_b(b[k], b_mean))
        return out

    def predict(self, dt=None, UT=None, fx=None, **fx_args):
        dt = self._dt if dt is None else dt
        UT = unscented_transform if UT is None else UT
        sigmas = self.compute_process_sigmas(dt, fx, **fx_args)
        Q = _process_noise(self.Q, self.dim_x)
        x, P = UT(self.sigmas_f, self.Wm, self.Wc, Q, self.x_mean, self.residual_x)
        # to the library as its statistical transition F̃ = P_yx P⁻¹ and Q + Ω_f
        Pyx = self._cross(self.sigmas_f, x, self.residual_x, sigmas, self.x, self.residual_x)
        F = np.linalg.solve(self._P, Pyx.T).T
        Q = P - F @ self._P @ F.T
        try:
            self._native_predict(x, F, (Q + Q.T) / 2, dt)
        except _native.EstimatorError as e:
            # Q + Ω_f is a difference of covariances: negative to rounding when Q is
            # singular; clipped then (the library refused it and changed nothing)
            if "not positive semi-definite" not in str(e):
                raise
            self._native_predict(x, F, _psd(Q), dt)
        self.sigmas_f = self.points_fn.sigma_points(self.x, self._P)

    def update(self, z, R=None, UT=None, hx=None, **hx_args):
        if z is None:
            self._no_update()  # (FilterPy's UKF leaves y as it was; its KF zeroes it)
            return
        hx = self.hx if hx is None else hx
        UT = unscented_transform if UT is None else UT
        R = self.R if R is None else _matrix(R, self.dim_z)
        self.sigmas_h = np.atleast_2d(np.array([hx(s, **hx_args) for s in self.sigmas_f],
                                               dtype=float))
        if self.sigmas_h.shape[0] != self.sigmas_f.shape[0]:
            self.sigmas_h = self.sigmas_h.reshape(self.sigmas_f.shape[0], -1)
        zp, Pzz = UT(self.sigmas_h, self.Wm, self.Wc, None, self.z_mean, self.residual_z)
        zp = np.atleast_1d(zp)
        if np.size(z) != zp.size:
            raise ValueError(f"z has {np.size(z)} values; hx gives {zp.size}")
        Pxz = self.cross_variance(self.x, zp, self.sigmas_f, self.sigmas_h)
        y = self.residual_z(np.reshape(np.asarray(z, dtype=float), zp.shape), zp)
        x0 = np.copy(self.x)
        out = self._native_update(y, Pxz, R, Pzz=Pzz)
        if self.verdict != "rejected" and self.state_add is not np.add:
            self.x = self.state_add(x0, self.K @ np.ravel(y))
            self._save_post()
        self.z = deepcopy(z)
        return out

    def batch_filter(self, zs, Rs=None, dts=None, UT=None, saver=None):
        """Predict then update at every measurement (``None``: predict only); returns
        ``(means, covariances)`` as FilterPy's."""
        n = len(zs)
        Rs = [self.R] * n if Rs is None else Rs
        dts = [self._dt] * n if dts is None else dts
        means, covs = [], []
        for z, R, dt in zip(zs, Rs, dts):
            self.predict(dt=dt, UT=UT)
            self.update(z, R, UT=UT)
            means.append(np.copy(self.x))
            covs.append(np.copy(self._P))
            if saver is not None:
                saver.save()
        return np.array(means), np.array(covs)

    def rts_smoother(self, Xs, Ps, Qs=None, dts=None, UT=None):
        """The unscented RTS smoother (Särkkä 2008) over a run's posteriors: the points
        of ``(Xs[k], Ps[k])`` through ``fx`` over ``dts[k]`` with ``Qs[k]`` (FilterPy's
        uses ``Q`` whatever ``Qs`` says; here ``Qs`` is honoured), the gain
        ``C = P_x,x⁻ (P⁻)⁻¹``; returns ``(xs, Ps, Ks)`` as FilterPy's."""
        n, dim_x = len(Xs), self.dim_x
        dts = [self._dt] * n if dts is None else dts
        Qs = [self.Q] * n if Qs is None else Qs
        UT = unscented_transform if UT is None else UT
        xs = np.array(Xs, dtype=float)
        ps = np.array(Ps, dtype=float)
        Ks = np.zeros((n, dim_x, dim_x))
        for k in reversed(range(n - 1)):
            sigmas = self.points_fn.sigma_points(xs[k], ps[k])
            f = np.array([self.fx(s, dts[k]) for s in sigmas], dtype=float)
            xb, Pb = UT(f, self.Wm, self.Wc, _process_noise(Qs[k], dim_x), self.x_mean,
                        self.residual_x)
            Pxb = np.zeros((dim_x, dim_x))
            for i in range(sigmas.shape[0]):
                Pxb += self.Wc[i] * np.outer(self.residual_x(sigmas[i], np.asarray(Xs[k], float)),
                                             self.residual_x(f[i], xb))
            C = Pxb @ self.inv(Pb)
            xs[k] = xs[k] + C @ self.residual_x(xs[k + 1], xb)
            ps[k] = ps[k] + C @ (ps[k + 1] - Pb) @ C.T
            Ks[k] = C
        return xs, ps, Ks
