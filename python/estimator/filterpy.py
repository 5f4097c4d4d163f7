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

The state is a vector of ``dim_x`` ≤ ``estimator._native.CALLABLE_MAX_N`` (9) entries and a
measurement has at most ``CALLABLE_MAX_M`` (8): the library's dimensions are fixed when
it is compiled, and these are the instances built.

The unscented update is the library's statistical linear regression of the sigma
points (``H̃ = P_xzᵀ P⁻¹``, noise ``R + Ω``): its ``S`` and ``K`` are FilterPy's
(``S = P_zz + R``, ``K = P_xz S⁻¹``) to rounding, and a strategy sees ``R + Ω`` as the
measurement noise. The unscented prediction goes to the library as its statistical
transition ``F̃ = P_yx P⁻¹`` and ``Q + Ω_f`` (``P⁻ = F̃ P F̃ᵀ + Q + Ω_f``, FilterPy's to
rounding), which the smoother records.
"""

from __future__ import annotations

from copy import deepcopy
from math import exp, sqrt
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


def _matrix(v, n: int) -> np.ndarray:
    """A scalar as ``v·I``, anything else as a float array."""
    if np.isscalar(v):
        return np.eye(n) * float(v)
    return np.asarray(v, dtype=float)


class _Core:
    """What the three filters share: the native core, the attributes FilterPy gives after
    an update, and the smoother."""

    def __init__(self, dim_x: int, dim_z: int, strategy: str, smooth: bool,
                 lag: Optional[int] = None):
        self.dim_x, self.dim_z = dim_x, dim_z
        self._core = _native.CallableCore(dim_x, strategy, smooth, lag)
        self.x = np.zeros(dim_x)
        self.P = np.eye(dim_x)
        self.Q = np.eye(dim_x)
        self.R = np.eye(dim_z)
        self.K = np.zeros((dim_x, dim_z))
        self.y = np.zeros(dim_z)
        self.S = np.zeros((dim_z, dim_z))
        self._SI = None
        self.z = None
        self.nis = float("nan")
        self.nis_adapted = float("nan")
        self.verdict = None
        self._log_likelihood = float("nan")
        self._predicted = False
        self._save_prior()
        self._save_post()

    # FilterPy's read-only statistics of the last update
    @property
    def log_likelihood(self) -> float:
        """ln N(y; 0, S) of the last update (with the strategy's adapted S)."""
        return self._log_likelihood

    @property
    def likelihood(self) -> float:
        return max(exp(self._log_likelihood), np.finfo(float).tiny)

    @property
    def mahalanobis(self) -> float:
        """√(yᵀ S⁻¹ y) of the last update (nominal S)."""
        return sqrt(self.nis)

    @property
    def SI(self) -> np.ndarray:
        """S⁻¹ of the last update (computed when asked for)."""
        if self._SI is None:
            self._SI = np.linalg.inv(self.S)
        return self._SI

    @property
    def strategy(self) -> str:
        return self._core.strategy

    def _shape(self, v: np.ndarray) -> np.ndarray:
        """`v` in the shape the user keeps ``x`` in (FilterPy's EKF uses a column)."""
        return v.reshape(np.shape(self.x)) if np.size(self.x) == v.size else v

    def _save_prior(self):
        self.x_prior, self.P_prior = np.copy(self.x), np.copy(self.P)

    def _save_post(self):
        self.x_post, self.P_post = np.copy(self.x), np.copy(self.P)

    def _native_predict(self, x_new, F, Q, dt):
        """P⁻ = λ F P Fᵀ + Q from the library (the strategy's fading and Q), recorded for
        the smoother."""
        x_new = np.asarray(x_new, dtype=float)
        self.P = self._core.predict(np.ravel(self.x).astype(float),
                                    np.asarray(self.P, dtype=float), np.ravel(x_new),
                                    _matrix(F, self.dim_x), _matrix(Q, self.dim_x), float(dt))
        self.x = self._shape(np.ravel(x_new).copy()) if np.ndim(self.x) else x_new
        self._predicted = True
        self._save_prior()

    def _native_update(self, y, H, R, Pzz=None):
        """The library's update on innovation `y`; sets FilterPy's attributes and ours."""
        y = np.ravel(np.asarray(y, dtype=float))
        R = _matrix(R, y.size)
        out = self._core.update(np.ravel(self.x).astype(float), np.asarray(self.P, dtype=float),
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
            self.P = out["P"]
        self._save_post()
        return out

    def smoothed(self):
        """The smoother's estimates ``(xs, Ps)``: with ``smooth=True`` the RTS smoother's
        at the start and after every prediction since (with the updates that followed
        it); with ``lag=k`` the fixed-lag smoother's over the last ``k`` predictions (the
        first is ``x(t − k steps | t)``), in bounded memory."""
        return self._core.smooth()


class KalmanFilter(_Core):
    """FilterPy's ``KalmanFilter`` (linear ``F``, ``B``, ``H``) on the library's filter.

    ``predict(u)``: ``x = F x + B u``, ``P = λ F P Fᵀ + Q``; ``update(z)``:
    ``y = z − H x`` and the library's update (Joseph form, the strategy, the gate).
    ``batch_filter`` and ``rts_smoother`` return what FilterPy's do.
    """

    def __init__(self, dim_x: int, dim_z: int, dim_u: int = 0, strategy: str = "fixed",
                 smooth: bool = False, lag: Optional[int] = None):
        super().__init__(dim_x, dim_z, strategy, smooth, lag)
        self.dim_u = dim_u
        self.F = np.eye(dim_x)
        self.H = np.zeros((dim_z, dim_x))
        self.B = None
        self._dt = 1.0

    def predict(self, u=None, B=None, F=None, Q=None):
        F = self.F if F is None else F
        Q = self.Q if Q is None else Q
        B = self.B if B is None else B
        x = _matrix(F, self.dim_x) @ self.x
        if B is not None and u is not None:
            x = x + np.dot(B, u)
        self._native_predict(x, F, Q, self._dt)

    def update(self, z, R=None, H=None):
        if z is None:
            self.z = None
            self._save_post()
            return
        R = self.R if R is None else R
        H = self.H if H is None else np.asarray(H, dtype=float)
        z = np.asarray(z, dtype=float)
        self._native_update(np.ravel(z) - np.ravel(H @ self.x), H, R)
        self.z = deepcopy(z)

    def batch_filter(self, zs, Fs=None, Qs=None, Hs=None, Rs=None, Bs=None, us=None,
                     update_first=False, saver=None):
        """Predict then update at every measurement (``None``: predict only). Returns
        ``(means, covariances, means_predictions, covariances_predictions)``."""
        n = len(zs)
        Fs = [self.F] * n if Fs is None else Fs
        Qs = [self.Q] * n if Qs is None else Qs
        Hs = [self.H] * n if Hs is None else Hs
        Rs = [self.R] * n if Rs is None else Rs
        Bs = [self.B] * n if Bs is None else Bs
        us = [None] * n if us is None else us
        means, covs, means_p, covs_p = [], [], [], []
        for z, F, Q, H, R, B, u in zip(zs, Fs, Qs, Hs, Rs, Bs, us):
            if update_first:
                self.update(z, R=R, H=H)
                means.append(np.copy(self.x)), covs.append(np.copy(self.P))
                self.predict(u=u, B=B, F=F, Q=Q)
                means_p.append(np.copy(self.x)), covs_p.append(np.copy(self.P))
            else:
                self.predict(u=u, B=B, F=F, Q=Q)
                means_p.append(np.copy(self.x)), covs_p.append(np.copy(self.P))
                self.update(z, R=R, H=H)
                means.append(np.copy(self.x)), covs.append(np.copy(self.P))
            if saver is not None:
                saver.save()
        return np.array(means), np.array(covs), np.array(means_p), np.array(covs_p)

    def rts_smoother(self, Xs, Ps, Fs=None, Qs=None, inv=np.linalg.inv):
        """The RTS smoother over a run's posteriors ``Xs``, ``Ps`` (``batch_filter``'s),
        by the library's smoother: returns ``(x, P, K, Pp)`` as FilterPy does — the
        smoothed states and covariances, the smoother gains and the predicted
        covariances."""
        n = len(Xs)
        Fs = [self.F] * n if Fs is None else Fs
        Qs = [self.Q] * n if Qs is None else Qs
        Xs, Ps = np.asarray(Xs, dtype=float), np.asarray(Ps, dtype=float)
        shape = Xs.shape
        core = _native.CallableCore(self.dim_x, "fixed", True)
        Pp = np.copy(Ps)  # (the last one is the last posterior's, as FilterPy returns it)
        for k in range(n - 1):
            F, Q = _matrix(Fs[k + 1], self.dim_x), _matrix(Qs[k + 1], self.dim_x)
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
    ``P = λ F P Fᵀ + Q`` with the ``F`` and ``Q`` you set (the Jacobian and noise at this
    step); ``update(z, HJacobian, Hx, …)`` evaluates your functions and runs the
    library's update. ``x`` may be a column, as in FilterPy."""

    def __init__(self, dim_x: int, dim_z: int, dim_u: int = 0, strategy: str = "fixed",
                 smooth: bool = False, dt: float = 1.0, lag: Optional[int] = None):
        super().__init__(dim_x, dim_z, strategy, smooth, lag)
        self.dim_u = dim_u
        self.x = np.zeros((dim_x, 1))
        self.F = np.eye(dim_x)
        self.B = 0
        self._dt = dt
        self._save_prior()
        self._save_post()

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
            self.z = None
            self._save_post()
            return
        if not isinstance(args, tuple):
            args = (args,)
        if not isinstance(hx_args, tuple):
            hx_args = (hx_args,)
        R = self.R if R is None else R
        if np.isscalar(z) and self.dim_z == 1:
            z = np.asarray([z], float)
        H = np.asarray(HJacobian(self.x, *args), dtype=float)
        hx = Hx(self.x, *hx_args)
        y = residual(z, hx)
        self._native_update(y, H, R)
        self.z = deepcopy(z)

    def predict_update(self, z, HJacobian, Hx, args=(), hx_args=(), u=0):
        self.predict(u)
        self.update(z, HJacobian, Hx, args=args, hx_args=hx_args)


class MerweScaledSigmaPoints:
    """Van der Merwe's scaled sigma points (``2n + 1``): ``λ = α² (n + κ) − n``, the
    points ``x``, ``x ± row k of U`` with ``Uᵀ U = (n + λ) P``; ``Wm₀ = λ/(n + λ)``,
    ``Wc₀ = Wm₀ + 1 − α² + β``, the others ``1/(2 (n + λ))``. ``subtract(x, y)`` adds a
    row to ``x`` as ``subtract(x, −row)`` (for angles)."""

    def __init__(self, n: int, alpha: float, beta: float, kappa: float,
                 sqrt_method: Optional[Callable] = None, subtract: Optional[Callable] = None):
        self.n, self.alpha, self.beta, self.kappa = n, alpha, beta, kappa
        self.sqrt = sqrt_method if sqrt_method is not None else (
            lambda a: np.linalg.cholesky(a).T)
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
    ``state_add`` as FilterPy takes them. The sigma-point statistics are computed here;
    the library predicts and updates with them (see the module)."""

    def __init__(self, dim_x: int, dim_z: int, dt: float, hx: Callable, fx: Callable,
                 points, sqrt_fn=None, x_mean_fn=None, z_mean_fn=None, residual_x=None,
                 residual_z=None, state_add=None, strategy: str = "fixed",
                 smooth: bool = False, lag: Optional[int] = None):
        super().__init__(dim_x, dim_z, strategy, smooth, lag)
        self._dt, self.hx, self.fx = dt, hx, fx
        self.points_fn = points
        self.x_mean, self.z_mean = x_mean_fn, z_mean_fn
        self.residual_x = residual_x if residual_x is not None else np.subtract
        self.residual_z = residual_z if residual_z is not None else np.subtract
        self.state_add = state_add if state_add is not None else np.add
        self.Wm, self.Wc = points.Wm, points.Wc
        self.sigmas_f = np.zeros((points.num_sigmas(), dim_x))
        self.sigmas_h = np.zeros((points.num_sigmas(), dim_z))

    def predict(self, dt=None, UT=None, fx=None, **fx_args):
        dt = self._dt if dt is None else dt
        UT = unscented_transform if UT is None else UT
        fx = self.fx if fx is None else fx
        sigmas = self.points_fn.sigma_points(self.x, self.P)
        self.sigmas_f = np.array([fx(s, dt, **fx_args) for s in sigmas], dtype=float)
        x, P = UT(self.sigmas_f, self.Wm, self.Wc, self.Q, self.x_mean, self.residual_x)
        # to the library as its statistical transition F̃ = P_yx P⁻¹ and Q + Ω_f
        Pyx = np.zeros((self.dim_x, self.dim_x))
        for k in range(sigmas.shape[0]):
            Pyx += self.Wc[k] * np.outer(self.residual_x(self.sigmas_f[k], x),
                                         self.residual_x(sigmas[k], self.x))
        F = np.linalg.solve(self.P, Pyx.T).T
        Q = P - F @ self.P @ F.T
        Q = (Q + Q.T) / 2
        self._native_predict(x, F, Q, dt)
        self.sigmas_f = self.points_fn.sigma_points(self.x, self.P)

    def update(self, z, R=None, UT=None, hx=None, **hx_args):
        if z is None:
            self.z = None
            self._save_post()
            return
        hx = self.hx if hx is None else hx
        UT = unscented_transform if UT is None else UT
        R = self.R if R is None else _matrix(R, self.dim_z)
        self.sigmas_h = np.atleast_2d(np.array([hx(s, **hx_args) for s in self.sigmas_f],
                                               dtype=float))
        zp, Pzz = UT(self.sigmas_h, self.Wm, self.Wc, None, self.z_mean, self.residual_z)
        Pxz = np.zeros((self.dim_x, zp.size))
        for k in range(self.sigmas_f.shape[0]):
            Pxz += self.Wc[k] * np.outer(self.residual_x(self.sigmas_f[k], self.x),
                                         self.residual_z(self.sigmas_h[k], zp))
        y = self.residual_z(np.asarray(z, dtype=float), zp)
        x0 = np.copy(self.x)
        out = self._native_update(y, Pxz, R, Pzz=Pzz)
        if self.verdict != "rejected" and self.state_add is not np.add:
            self.x = self.state_add(x0, self.K @ np.ravel(y))
            self._save_post()
        self.z = deepcopy(z)
        return out
