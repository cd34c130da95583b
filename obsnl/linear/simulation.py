"""Running an observer: zero-order-hold discretization and the simulation of a designed observer along a
record.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla

from obsnl.errors import DataError
from obsnl.linear.observer import ExtendedSystem
from obsnl.linear.systems import checked_matrix

__all__ = ["ObserverRun", "simulate_observer", "zoh", "run_discrete", "checked_samples"]


# --------------------------------------------------------------------------- simulation
def zoh(A: np.ndarray, B: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact zero-order-hold discretisation ``(Phi, Gamma)`` of ``dx/dt = A x + B u`` with step ``dt``.

    Parameters
    ----------
    A : numpy.ndarray
    B : numpy.ndarray
    dt : float
        System (n x n) and input (n x m) matrices; step (s).

    Returns
    -------
    tuple of numpy.ndarray
    """
    n, m = A.shape[0], B.shape[1]
    big = np.zeros((n + m, n + m))
    big[:n, :n], big[:n, n:] = A, B
    E = sla.expm(big * dt)
    return E[:n, :n], E[:n, n:]


def run_discrete(Phi: np.ndarray, g: np.ndarray, x0: np.ndarray | None = None) -> np.ndarray:
    """States of ``x[k+1] = Phi x[k] + g[k]`` for k = 0..N-2 (returns N x n, ``x[0] = x0``).

    Parameters
    ----------
    Phi : numpy.ndarray
    g : numpy.ndarray
    x0 : numpy.ndarray or None
        Transition matrix (n x n); forcing per step (N x n); initial state (None: zero).

    Returns
    -------
    numpy.ndarray
    """
    x = np.zeros((g.shape[0], Phi.shape[0]))
    if x0 is not None:
        x[0] = x0
    PhiT = np.ascontiguousarray(Phi.T)
    for k in range(g.shape[0] - 1):
        x[k + 1] = x[k] @ PhiT + g[k]
    return x


@dataclass(frozen=True, eq=False)
class ObserverRun:
    """Observer outputs per sample: extended state ``xhat`` (N, n+q), force ``nhat`` (N, s),
    output residual ``residual = y - C xhat`` (N, p)."""

    xhat: np.ndarray
    nhat: np.ndarray
    residual: np.ndarray


def checked_samples(a: Any, name: str, cols: int, rows: int | None = None) -> np.ndarray:
    """A sampled signal as a float array of one row per sample, its shape and values checked.

    Parameters
    ----------
    a : array_like
        The samples, (N, cols); a 1-D array is one column when ``cols`` is 1.
    name : str
        The signal's name in a refusal (``"u"``, ``"y"``).
    cols : int
        The number of channels (columns).
    rows : int or None
        The number of samples required (None: any).

    Returns
    -------
    numpy.ndarray
        (N, cols), float.

    Raises
    ------
    DataError
        Another shape, or a NaN or an infinity among the samples.

    Examples
    --------
    >>> checked_samples([1, 2, 3], "y", 1).shape
    (3, 1)
    >>> checked_samples([[1, 2]], "u", 3)
    Traceback (most recent call last):
    ...
    obsnl.errors.DataError: u has shape (1, 2), expected (N, 3): one row per sample
    """
    a = np.asarray(a, dtype=float)
    if a.ndim == 1 and cols == 1:
        a = a[:, None]
    if a.ndim != 2 or a.shape[1] != cols or (rows is not None and a.shape[0] != rows):
        want = f"({rows if rows is not None else 'N'}, {cols})"
        raise DataError(f"{name} has shape {a.shape}, expected {want}: one row per sample")
    if not np.all(np.isfinite(a)):
        raise DataError(f"{name} contains NaN or inf; clean or interpolate the samples first")
    return a


def observer_matrices(ext: ExtendedSystem, L: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """ZOH matrices of the observer ``dx/dt = (A_e - L C_e) x + [B_e, L] [u; y]``."""
    if not dt > 0:
        raise DataError(f"the time step dt must be positive, got {dt}")
    return zoh(ext.A - L @ ext.C, np.hstack([ext.B, L]), dt)


def simulate_observer(ext: ExtendedSystem, L: Any, *, dt: float, u: Any, y: Any, x0: Any = None) -> ObserverRun:
    """Run the extended observer on sampled inputs ``u`` (N, m) and outputs ``y`` (N, p).

    The observer is discretised exactly (zero-order hold of ``u`` and ``y`` over each step).

    Parameters
    ----------
    ext : ExtendedSystem
    L : array_like
    dt : float
        The system; observer gain (extended states x outputs); sample step (s).
    u : array_like
    y : array_like
    x0 : array_like or None
        Sampled inputs and outputs; initial estimate (None: zero).

    Returns
    -------
    ObserverRun
    """
    y = checked_samples(y, "y", ext.C.shape[0])
    u = checked_samples(u, "u", ext.B.shape[1], rows=y.shape[0]) if ext.B.shape[1] else np.zeros((y.shape[0], 0))
    L = checked_matrix(L, "L", rows=ext.A.shape[0])
    Phi, Gam = observer_matrices(ext, L, dt)
    xhat = run_discrete(Phi, np.hstack([u, y]) @ Gam.T, None if x0 is None else np.asarray(x0, dtype=float))
    return ObserverRun(xhat, ext.force(xhat), y - xhat @ ext.C.T)
