"""FilterPy's ``filterpy.common`` helpers, so that a FilterPy program needs no FilterPy:
process noise of kinematic models (discrete and continuous white noise), the
discretisation of a linear system (Van Loan's method, the matrix-fraction method), the
kinematic filter builder, small matrix helpers and :class:`Saver`. Each is checked
against FilterPy's in ``python/tests/test_filterpy_surface.py``.

Kinematic states are ordered by dimension (``x, x', y, y'``) unless
``order_by_dim=False`` (``x, y, x', y'``), as FilterPy orders them.
"""

from __future__ import annotations

import copy
from math import factorial
from typing import Callable, Iterable, Optional

import numpy as np

__all__ = [
    "Q_discrete_white_noise",
    "Q_continuous_white_noise",
    "van_loan_discretization",
    "linear_ode_discretation",
    "order_by_derivative",
    "kinematic_state_transition",
    "kinematic_kf",
    "outer_product_sum",
    "inv_diagonal",
    "runge_kutta4",
    "reshape_z",
    "expm",
    "Saver",
]


def _block_diag(block: np.ndarray, count: int) -> np.ndarray:
    n = block.shape[0]
    out = np.zeros((n * count, n * count))
    for k in range(count):
        out[k * n:(k + 1) * n, k * n:(k + 1) * n] = block
    return out


def order_by_derivative(Q, dim: int, block_size: int) -> np.ndarray:
    """A ``dim × dim`` block for one axis spread over ``block_size`` axes ordered by
    derivative (``x, y, x', y'``): entry ``(i, j)`` of ``Q`` at ``(i·b + a, j·b + a)``
    for every axis ``a``."""
    Q = np.asarray(Q, dtype=float)
    out = np.zeros((dim * block_size, dim * block_size))
    for i in range(dim):
        for j in range(dim):
            for a in range(block_size):
                out[i * block_size + a, j * block_size + a] = Q[i, j]
    return out


def _per_axis(block: np.ndarray, block_size: int, order_by_dim: bool) -> np.ndarray:
    if order_by_dim:
        return _block_diag(block, block_size)
    return order_by_derivative(block, block.shape[0], block_size)


def Q_discrete_white_noise(dim: int, dt: float = 1.0, var: float = 1.0, block_size: int = 1,
                           order_by_dim: bool = True) -> np.ndarray:
    """The process noise of a piecewise-constant white noise of variance ``var`` over a
    step ``dt``, ``Γ Γᵀ var`` per axis: for ``dim`` 2 (position, velocity) a white
    acceleration, ``Γ = [dt²/2, dt]``; for 3 and 4 a white highest state derivative,
    ``Γᵢ = dt^(d−1−i)/(d−1−i)!`` (Bar-Shalom et al. 2001, §6.3; FilterPy's convention)."""
    if dim not in (2, 3, 4):
        raise ValueError(f"dim must be 2, 3 or 4, not {dim!r}")
    if dim == 2:
        gamma = np.array([dt * dt / 2, dt])
    else:
        gamma = np.array([dt ** (dim - 1 - i) / factorial(dim - 1 - i) for i in range(dim)])
    return _per_axis(np.outer(gamma, gamma) * var, block_size, order_by_dim)


def Q_continuous_white_noise(dim: int, dt: float = 1.0, spectral_density: float = 1.0,
                             block_size: int = 1, order_by_dim: bool = True) -> np.ndarray:
    """The process noise of a continuous white highest derivative of spectral density
    ``q`` integrated over ``dt``: ``Qᵢⱼ = q dt^p / (p (d−1−i)! (d−1−j)!)``,
    ``p = 2d − 1 − i − j`` (``dim`` = 2, 3 or 4), per axis."""
    if dim not in (2, 3, 4):
        raise ValueError(f"dim must be 2, 3 or 4, not {dim!r}")
    q = np.zeros((dim, dim))
    for i in range(dim):
        for j in range(dim):
            p = 2 * dim - 1 - i - j
            q[i, j] = dt ** p / (p * factorial(dim - 1 - i) * factorial(dim - 1 - j))
    return _per_axis(q * spectral_density, block_size, order_by_dim)


def expm(a) -> np.ndarray:
    """The matrix exponential: scaling and squaring over a Taylor series (the scaled
    matrix's norm below 1/2, terms to machine precision)."""
    a = np.asarray(a, dtype=float)
    norm = np.abs(a).sum(axis=1).max() if a.size else 0.0
    s = max(0, int(np.ceil(np.log2(norm / 0.5))) if norm > 0.5 else 0)
    a = a / 2.0 ** s
    out = np.eye(a.shape[0])
    term = np.eye(a.shape[0])
    for k in range(1, 30):
        term = term @ a / k
        out = out + term
        if np.abs(term).max() <= 1e-17 * np.abs(out).max():
            break
    for _ in range(s):
        out = out @ out
    return out


def van_loan_discretization(F, G, dt: float) -> "tuple[np.ndarray, np.ndarray]":
    """``(Φ, Q)`` of ``ẋ = F x + G w`` (``w`` white, unit intensity) over ``dt`` by Van
    Loan's method (1978): the exponential of ``[[−F, G Gᵀ], [0, Fᵀ]] dt``."""
    F, G = np.asarray(F, dtype=float), np.asarray(G, dtype=float)
    n = F.shape[0]
    A = np.zeros((2 * n, 2 * n))
    A[:n, :n] = -F
    A[:n, n:] = G @ G.T
    A[n:, n:] = F.T
    B = expm(A * dt)
    phi = B[n:, n:].T
    return phi, phi @ B[:n, n:]


def linear_ode_discretation(F, L=None, Q=None, dt: float = 1.0):
    """``(Φ, Q_d)`` of ``ẋ = F x + L w`` (``w`` white of intensity ``Q``) over ``dt`` by
    the matrix-fraction decomposition (FilterPy's name, spelling kept)."""
    F = np.asarray(F, dtype=float)
    n = F.shape[0]
    L = np.eye(n) if L is None else np.asarray(L, dtype=float)
    Q = np.zeros((n, n)) if Q is None else np.asarray(Q, dtype=float)
    M = np.zeros((2 * n, 2 * n))
    M[:n, :n] = F
    M[:n, n:] = L @ Q @ L.T
    M[n:, n:] = -F.T
    CD = expm(M * dt)[:, n:]
    return expm(F * dt), CD[:n] @ np.linalg.inv(CD[n:])


def kinematic_state_transition(order: int, dt: float) -> np.ndarray:
    """The transition of a kinematic chain of ``order`` (0: constant position, 1:
    constant velocity, 2: constant acceleration …) over ``dt``."""
    if order < 0 or int(order) != order:
        raise ValueError(f"order must be a non-negative integer, not {order!r}")
    n = order + 1
    F = np.zeros((n, n))
    for i in range(n):
        for j in range(i, n):
            F[i, j] = dt ** (j - i) / factorial(j - i)
    return F


def kinematic_kf(dim: int, order: int, dt: float = 1.0, dim_z: int = 1,
                 order_by_dim: bool = True, kf=None):
    """A :class:`~estimator.filterpy.KalmanFilter` of ``dim`` axes, each a kinematic chain
    of ``order``: ``F`` set as FilterPy's; ``H`` measures the position of axis ``k`` in
    row ``k`` (``dim_z`` rows), as FilterPy's documentation says (its code puts every
    axis's position in every row, their sum); ``x`` zero, ``P``, ``Q``, ``R`` the
    identity."""
    from .filterpy import KalmanFilter

    if dim < 1:
        raise ValueError(f"dim must be at least 1, not {dim!r}")
    n = order + 1
    dim_x = n * dim
    if kf is None:
        kf = KalmanFilter(dim_x=dim_x, dim_z=dim_z)
    F1 = kinematic_state_transition(order, dt)
    kf.F = _per_axis(F1, dim, order_by_dim)
    H = np.zeros((dim_z, dim_x))
    for k in range(min(dim_z, dim)):
        H[k, k * n if order_by_dim else k] = 1.0
    kf.H = H
    return kf


def outer_product_sum(A, B=None) -> np.ndarray:
    """``Σᵢ Aᵢ Bᵢᵀ`` over the rows (``B`` = ``A`` when not given)."""
    A = np.asarray(A, dtype=float)
    B = A if B is None else np.asarray(B, dtype=float)
    return np.einsum("ij,ik->jk", A, B)


def inv_diagonal(S) -> np.ndarray:
    """The inverse of a diagonal matrix (its diagonal inverted)."""
    S = np.asarray(S, dtype=float)
    if S.ndim != 2 or S.shape[0] != S.shape[1]:
        raise ValueError(f"S must be a square matrix, not shape {S.shape}")
    return np.diag(1.0 / np.diag(S))


def runge_kutta4(y, x, dx, f: Callable):
    """One classical Runge–Kutta step of ``dy/dx = f(y, x)`` from ``x`` to ``x + dx``."""
    k1 = dx * f(y, x)
    k2 = dx * f(y + 0.5 * k1, x + 0.5 * dx)
    k3 = dx * f(y + 0.5 * k2, x + 0.5 * dx)
    k4 = dx * f(y + k3, x + dx)
    return y + (k1 + 2 * k2 + 2 * k3 + k4) / 6.0


def reshape_z(z, dim_z: int, ndim: int) -> np.ndarray:
    """A measurement as ``dim_z`` values, a column when ``ndim`` is 2, or a ValueError
    naming ``z``."""
    from .filterpy import _z

    return _z(z, dim_z, ndim)


class Saver:
    """Keep a filter's attributes after every :meth:`save` (FilterPy's ``Saver``): every
    public attribute and property by name (``saver.x``, ``saver["P"]``), as lists, or as
    arrays after :meth:`to_array`. ``skip_private`` drops names starting with ``_``,
    ``skip_callable`` functions, ``ignore`` the names given. The library's native core is
    never copied (it is the filter's engine, not a value)."""

    def __init__(self, kf, save_current: bool = False, skip_private: bool = False,
                 skip_callable: bool = False, ignore: Iterable[str] = ()):
        self._kf = kf
        self._DL: "dict[str, list]" = {}
        self._skip_private = skip_private
        self._skip_callable = skip_callable
        self._ignore = tuple(ignore)
        self._len = 0
        self.properties = [name for name in dir(type(kf))
                           if isinstance(getattr(type(kf), name, None), property)
                           and name not in self._ignore]
        if save_current:
            self.save()

    def save(self):
        """Append the filter's current attributes."""
        kf = self._kf
        values = {name: getattr(kf, name) for name in self.properties}
        values.update(vars(kf))
        for key, v in values.items():
            if key in self._ignore or key == "_core":
                continue
            if self._skip_private and key.startswith("_"):
                continue
            if self._skip_callable and callable(v):
                continue
            self._DL.setdefault(key, []).append(
                np.copy(v) if isinstance(v, np.ndarray) else copy.deepcopy(v))
        self._len += 1

    def __getattr__(self, key):
        try:
            return self.__dict__["_DL"][key]
        except KeyError:
            raise AttributeError(key) from None

    def __getitem__(self, key):
        return self._DL[key]

    def __setitem__(self, key, value):
        self._DL[key] = value

    def __len__(self) -> int:
        return self._len

    @property
    def keys(self):
        """The names kept (a list, as FilterPy's property)."""
        return list(self._DL.keys())

    def to_array(self, flatten: bool = False):
        """Every kept list as a numpy array (``flatten``: see :meth:`flatten`); a name
        whose values differ in shape raises a ValueError naming it."""
        arrays = {}
        for key, v in self._DL.items():
            try:
                arrays[key] = np.array(v)
            except ValueError:
                raise ValueError(f"could not convert {key} into one array "
                                 "(its values differ in shape)") from None
        self._DL.update(arrays)
        if flatten:
            self.flatten()

    def flatten(self):
        """Arrays of columns (``n × k × 1``) as ``n × k``, and ``n × 1`` as ``n``."""
        for key, v in self._DL.items():
            if isinstance(v, np.ndarray) and v.ndim == 3 and v.shape[2] == 1:
                v = v[:, :, 0]
            if isinstance(v, np.ndarray) and v.ndim == 2 and v.shape[1] == 1:
                v = v.ravel()
            self._DL[key] = v

    def __repr__(self) -> str:
        return f"Saver({type(self._kf).__name__}, {self._len} saves, keys {self.keys()})"
