"""Gains of an extended (disturbance / PI) observer: the stationary Kalman-Bucy gain and pole placement.

The extended system comes from :func:`obsnl.linear.observer.extend`; its Hautus test
(:func:`obsnl.linear.observer.extended_observability`) says whether a stabilising gain exists.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla
import scipy.signal

from obsnl.errors import AnalysisError, DataError
from obsnl.linear.observer import ExtendedSystem
from obsnl.linear.systems import checked_matrix

__all__ = ["ObserverDesign", "riccati_gain", "place_gain"]


@dataclass(frozen=True, eq=False)
class ObserverDesign:
    """An observer gain ``L`` for an extended system and what it does.

    ``eigenvalues`` are those of ``A_e - L C_e``; ``force_eigenvalues`` the ``q`` of them with
    the largest participation of the fictitious states; ``residual`` the relative Riccati
    residual (NaN for pole placement).
    """

    L: np.ndarray
    method: str
    eigenvalues: np.ndarray
    force_eigenvalues: np.ndarray
    residual: float

    @property
    def stable(self) -> bool:
        return bool(np.all(self.eigenvalues.real < 0))

    def to_dict(self) -> dict:
        c = lambda z: [[float(v.real), float(v.imag)] for v in z]  # noqa: E731
        return {
            "method": self.method,
            "stable": self.stable,
            "eigenvalues": c(self.eigenvalues),
            "force_eigenvalues": c(self.force_eigenvalues),
            "residual": self.residual,
            "gain_norm": float(np.linalg.norm(self.L, 2)),
        }


def _design(ext: ExtendedSystem, L: np.ndarray, method: str, residual: float) -> ObserverDesign:
    Acl = ext.A - L @ ext.C
    w, vl, vr = sla.eig(Acl, left=True, right=True)
    vl = vl / np.conj(np.sum(np.conj(vl) * vr, axis=0))[None, :]
    part = np.abs(vl * vr)
    frac = part[ext.n :].sum(axis=0) / part.sum(axis=0)
    idx = np.argsort(-frac)[: ext.q]
    bad = int(np.sum(w.real >= -1e-9 * np.abs(w).max(initial=1.0)))
    if bad:
        raise AnalysisError(
            f"the {method} gain leaves {bad} observer eigenvalue(s) unstable or on the imaginary "
            "axis; check extended_observability (an unobservable fictitious mode?)"
        )
    return ObserverDesign(L, method, w, w[idx], residual)


def riccati_gain(ext: ExtendedSystem, *, R: Any, q_x: float = 1.0, q_v: float = 1.0, Q: Any = None) -> ObserverDesign:
    """Stationary Kalman-Bucy gain: ``A_e P + P A_e^T - P C_e^T R^-1 C_e P + Q = 0``, ``L = P C_e^T R^-1``.

    Parameters
    ----------
    ext : ExtendedSystem
        The extended system.
    R : Any
        Output weight (p x p, or a vector of variances).
    q_x, q_v : float
        ``Q = blkdiag(q_x I_n, q_v I_q)`` unless ``Q`` is given; ``q_v`` is the random-walk
        intensity of the fictitious states and sets how fast the force estimate follows.

    Raises
    ------
    AnalysisError
        scipy cannot isolate the stable subspace (unobservable fictitious modes) or the gain
        is not stabilising.

    References
    ----------
    .. [1] R. E. Kalman and R. S. Bucy, "New results in linear filtering and prediction theory", J. Basic Engineering
       83(1), 95-108, 1961. doi:10.1115/1.3658902
    """
    nq, p = ext.A.shape[0], ext.C.shape[0]
    Rm = np.diag(np.asarray(R, dtype=float)) if np.ndim(R) == 1 else checked_matrix(R, "R")
    if Rm.shape != (p, p) or not np.all(np.isfinite(Rm)):
        raise DataError(f"R must be {p} x {p} (or {p} variances) and finite")
    if Q is None:
        Qm = np.diag(np.r_[np.full(ext.n, float(q_x)), np.full(ext.q, float(q_v))])
    else:
        Qm = checked_matrix(Q, "Q", rows=nq, cols=nq)
    Qm, Rm = (Qm + Qm.T) / 2, (Rm + Rm.T) / 2
    try:
        P = sla.solve_continuous_are(ext.A.T, ext.C.T, Qm, Rm)
    except (np.linalg.LinAlgError, ValueError) as exc:
        raise AnalysisError(
            f"the observer Riccati equation has no stabilising solution ({exc}); "
            "check extended_observability and that Q excites the fictitious states"
        ) from exc
    L = np.linalg.solve(Rm, ext.C @ P).T
    res = ext.A @ P + P @ ext.A.T - P @ ext.C.T @ np.linalg.solve(Rm, ext.C @ P) + Qm
    rel = float(np.linalg.norm(res) / max(float(np.linalg.norm(Qm)), float(np.linalg.norm(ext.A @ P)), 1e-300))
    return _design(ext, L, "riccati", rel)


def place_gain(ext: ExtendedSystem, poles: Any, *, method: str = "YT") -> ObserverDesign:
    """Observer gain by pole placement on the dual pair: ``L = place(A_e^T, C_e^T, poles)^T``.

    The MIMO gain is not unique, and YT cannot place a pole more often than rank(C); prefer
    :func:`riccati_gain` for large, stiff systems.

    Parameters
    ----------
    ext : ExtendedSystem
    poles : array_like
    method : str
        The system; one pole per extended state; the ``scipy.signal.place_poles`` method.

    Returns
    -------
    ObserverDesign

    Raises
    ------
    DataError, AnalysisError
        Wrong number of poles; the placement failed.

    References
    ----------
    .. [1] A. L. Tits and Y. Yang, "Globally convergent algorithms for robust pole assignment by state feedback", IEEE
       Trans. Automatic Control 41(10), 1432-1452, 1996. doi:10.1109/9.539425
    """
    poles = np.asarray(poles, dtype=complex).ravel()
    if poles.size != ext.A.shape[0]:
        raise DataError(f"give {ext.A.shape[0]} poles (one per extended state), got {poles.size}")
    try:
        res = scipy.signal.place_poles(ext.A.T, ext.C.T, poles, method=method)
    except ValueError as exc:
        raise AnalysisError(f"pole placement failed: {exc}") from exc
    return _design(ext, np.real(res.gain_matrix.T), "place", float("nan"))
