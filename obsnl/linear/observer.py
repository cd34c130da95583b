"""Extended (disturbance / PI) observers: fictitious force models and their Hautus test (gains: :mod:`obsnl.linear.gains`).

An unknown force ``n(t)`` entering the plant through ``N_R`` is approximated by a signal
model ``n ~ H v``, ``dv/dt = V v`` (integrator or oscillator). Appending ``v`` to the state
gives the extended system ``A_e = [[A, N_R H], [0, V]]``, ``C_e = [C, 0]``; an identity
observer of that system estimates the force as ``n_hat = H v_hat`` (P. C. Mueller's
disturbance observer, the PI observer of Soeffker et al.; the seed paper
``001_d0508a78c5399696.txt`` eqs. (14)-(27)).

Whether this works is decided by the Hautus test of the extended pair, split as in the
docs/observer_bank.md section 1.4: the plant test at ``lam`` in spec(A) \\ spec(V);
at ``lam`` in spec(V) the rank of ``G(lam) = C (lam I - A)^-1 N_R H`` restricted to the
eigenvectors of V (which needs at least as many measurements as force channels, p >= s);
the full block matrix where the spectra meet.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla

from obsnl.errors import DataError
from obsnl.linear.hautus import HautusResult, distinct_eigenvalues, hautus
from obsnl.linear.systems import (
    DEFAULT_RTOL,
    DEFAULT_WEAK_RTOL,
    LinearSystem,
    as_linear_system,
    checked_matrix,
    system_scaling,
)
from obsnl.observability.verdicts import Verdict

__all__ = [
    "FictitiousModel",
    "integrator",
    "oscillator",
    "ExtendedSystem",
    "extend",
    "ChannelTest",
    "ExtendedObservability",
    "extended_observability",
]


# --------------------------------------------------------------------------- fictitious models
@dataclass(frozen=True, eq=False)
class FictitiousModel:
    """Signal model ``n = H v``, ``dv/dt = V v`` of ``s`` force channels with ``q`` states."""

    V: np.ndarray
    H: np.ndarray
    kind: str

    def __post_init__(self) -> None:
        V = checked_matrix(self.V, "V")
        if V.shape[0] != V.shape[1]:
            raise DataError(f"V must be square, got shape {V.shape}")
        object.__setattr__(self, "V", V)
        object.__setattr__(self, "H", checked_matrix(self.H, "H", cols=V.shape[0]))

    @property
    def q(self) -> int:
        return self.V.shape[0]

    @property
    def s(self) -> int:
        return self.H.shape[0]


def integrator(s: int = 1) -> FictitiousModel:
    """Integrator model (constant or slowly varying force): ``V = 0``, ``H = I`` with ``s`` channels."""
    if int(s) < 1:
        raise DataError(f"the number of force channels s must be >= 1, got {s}")
    return FictitiousModel(np.zeros((s, s)), np.eye(s), "integrator")


def oscillator(omegas: Sequence[float], s: int = 1, *, bias: bool = True) -> FictitiousModel:
    """Oscillator model: per channel a bias (optional) plus one harmonic oscillator per ``omega`` (rad/s).

    Each oscillator is ``[[0, 1], [-omega^2, 0]]`` read out by ``[1, 0]``; blocks are stacked
    per channel, so ``q = s (bias + 2 len(omegas))``.

    Parameters
    ----------
    omegas : sequence of float
    s : int
    bias : bool
        Frequencies (rad/s, positive); channels (>= 1); add a bias state per channel.

    Returns
    -------
    FictitiousModel

    Raises
    ------
    DataError
        For ``s < 1``, a bad frequency, or no state at all.
    """
    om = [float(w) for w in omegas]
    if int(s) < 1 or any(not np.isfinite(w) or w <= 0 for w in om) or (not om and not bias):
        raise DataError("oscillator needs s >= 1 and positive finite frequencies (or bias=True)")
    blocks = ([np.zeros((1, 1))] if bias else []) + [np.array([[0.0, 1.0], [-w * w, 0.0]]) for w in om]
    hrow = np.array(([1.0] if bias else []) + [1.0, 0.0] * len(om))
    V = sla.block_diag(*(blocks * s))
    H = sla.block_diag(*([hrow[None, :]] * s))
    return FictitiousModel(V, H, "oscillator")


# --------------------------------------------------------------------------- extended system
@dataclass(frozen=True, eq=False)
class ExtendedSystem:
    """Plant plus fictitious model: ``A_e = [[A, N_R H], [0, V]]``, ``B_e = [B; 0]``, ``C_e = [C, 0]``."""

    plant: LinearSystem
    N_R: np.ndarray
    model: FictitiousModel
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray

    @property
    def n(self) -> int:
        return self.plant.n_states

    @property
    def q(self) -> int:
        return self.model.q

    @property
    def s(self) -> int:
        return self.model.s

    def force(self, xe: np.ndarray) -> np.ndarray:
        """Force estimate ``H v`` from extended states (..., n + q) -> (..., s)."""
        return np.asarray(xe)[..., self.n :] @ self.model.H.T


def extend(system: Any, N_R: Any, model: FictitiousModel) -> ExtendedSystem:
    """Extend a plant (``.A, .B, .C`` object, tuple) by the fictitious model acting through ``N_R`` (n x s).

    Parameters
    ----------
    system : Any
    N_R : array_like
    model : FictitiousModel
        The plant (:func:`~obsnl.linear.systems.as_linear_system`), force input matrix, force model.

    Returns
    -------
    ExtendedSystem

    Raises
    ------
    DataError
        When ``N_R`` does not match the plant or the model.

    Examples
    --------
    >>> ext = extend(([[0, 1], [-1, -0.1]], [[0], [1]], [[1, 0]]), [[0], [1]], integrator(1))
    >>> ext.A.shape, ext.C.shape
    ((3, 3), (1, 3))
    """
    plant = as_linear_system(system)
    n, q = plant.n_states, model.q
    N = checked_matrix(N_R, "N_R", rows=n)
    if N.shape[1] != model.s:
        raise DataError(f"N_R has {N.shape[1]} columns but the fictitious model has s = {model.s} channels")
    A = np.block([[plant.A, N @ model.H], [np.zeros((q, n)), model.V]])
    B = np.vstack([plant.B, np.zeros((q, plant.n_inputs))])
    C = np.hstack([plant.C, np.zeros((plant.n_outputs, q))])
    return ExtendedSystem(plant, N, model, A, B, C)


@dataclass(frozen=True)
class ChannelTest:
    """Hautus test at an eigenvalue ``lam`` of V.

    ``method`` is ``"G"`` (rank of ``G(lam) H Z``, Z the eigenvectors of V at lam) or
    ``"block"`` (full extended PBH matrix, used when lam is also an eigenvalue of A).
    ``singular_values`` are those of the tested matrix; ``condition`` is sigma_max/sigma_min of G.
    """

    eigenvalue: complex
    method: str
    singular_values: tuple[float, ...]
    deficiency: int
    condition: float

    def to_dict(self) -> dict:
        lam = complex(self.eigenvalue)
        return {
            "eigenvalue": [lam.real, lam.imag],
            "method": self.method,
            "singular_values": list(self.singular_values),
            "deficiency": self.deficiency,
            "condition": self.condition,
        }


@dataclass(frozen=True)
class ExtendedObservability:
    """Outcome of :func:`extended_observability` (see the module docstring for the case split)."""

    n_outputs: int
    n_channels: int
    plant: HautusResult
    channels: tuple[ChannelTest, ...]
    verdict: Verdict
    detectable: bool
    reason: str
    weak_cond: float

    @property
    def enough_outputs(self) -> bool:
        """The necessary condition p >= s (independent measurements >= modelled force channels)."""
        return self.n_outputs >= self.n_channels

    @property
    def observable(self) -> bool:
        return self.verdict is not Verdict.UNOBSERVABLE

    def to_dict(self) -> dict:
        return {
            "verdict": self.verdict.value,
            "observable": self.observable,
            "detectable": self.detectable,
            "reason": self.reason,
            "n_outputs": self.n_outputs,
            "n_channels": self.n_channels,
            "enough_outputs": self.enough_outputs,
            "weak_cond": self.weak_cond,
            "channels": [c.to_dict() for c in self.channels],
            "plant": self.plant.to_dict(),
        }


def extended_observability(
    system: Any,
    N_R: Any,
    model: FictitiousModel,
    *,
    rtol: float = DEFAULT_RTOL,
    weak_rtol: float = DEFAULT_WEAK_RTOL,
    weak_cond: float = 1e2,
    scaling: str = "balance",
    output_scale: Any = None,
) -> ExtendedObservability:
    """Hautus test of the extended pair ``(A_e, C_e)``, split by eigenvalue (docs/observer_bank.md section 1.4).

    Parameters
    ----------
    system : object
        Plant (``.A, .B, .C`` object or tuple).
    N_R : Any
        Force distribution (n x s).
    model : FictitiousModel
        The fictitious model of the unknown forces.
    rtol, weak_rtol : float
        As in :func:`obsnl.linear.hautus.hautus`; ``rtol`` is also the relative rank tolerance for ``G``.
    scaling : str
        As in :func:`obsnl.linear.hautus.hautus`.
    weak_cond : float
        A channel test with ``cond(G(lam)) > weak_cond`` makes the verdict "weakly observable".
    output_scale : Any
        Optional per-output scale (e.g. the noise level) dividing the rows of ``G`` before its
        condition number is taken; ranks do not depend on it, the condition number does.

    Returns
    -------
    ExtendedObservability
        ``verdict`` is unobservable when p < s (checked first), when a plant eigenvalue fails
        the PBH test, or when ``G(lam)`` loses rank at an eigenvalue of V.

    Examples
    --------
    >>> plant = ([[0, 1], [-1, -0.1]], [[0], [1]], [[1, 0]])
    >>> extended_observability(plant, [[0, 0], [1, 1]], integrator(2)).reason
    'p = 1 independent measurements < s = 2 modelled force channels'
    """
    ext = extend(system, N_R, model)
    A, C, n, q, s = ext.plant.A, ext.plant.C, ext.n, ext.q, ext.s
    sv_c = np.linalg.svd(C, compute_uv=False)
    p = int(np.sum(sv_c > rtol * max(sv_c.max(initial=0.0), np.finfo(float).tiny)))
    wscale = np.ones(C.shape[0]) if output_scale is None else np.asarray(output_scale, dtype=float).ravel()
    if wscale.shape != (C.shape[0],) or np.any(~np.isfinite(wscale)) or np.any(wscale <= 0):
        raise DataError(f"output_scale needs {C.shape[0]} positive finite numbers, one per output")
    lam_v = distinct_eigenvalues(model.V)
    lam_a = distinct_eigenvalues(A)
    tol_a = 1e-9 * max(float(np.linalg.norm(A, 2)), 1.0)
    plant_lams = [lam for lam in lam_a if np.min(np.abs(lam_v - lam), initial=np.inf) > tol_a]
    plant = hautus(ext.plant, eigenvalues=plant_lams, rtol=rtol, weak_rtol=weak_rtol, scaling=scaling)
    channels: list[ChannelTest] = []
    for lam in lam_v:
        Z = sla.null_space(lam * np.eye(q) - model.V.astype(complex), rcond=1e-10)
        if np.min(np.abs(lam_a - lam)) > tol_a:
            G = C @ np.linalg.solve(lam * np.eye(n) - A, ext.N_R @ model.H @ Z)
            sv = np.linalg.svd(G / wscale[:, None], compute_uv=False)
            defic = Z.shape[1] - int(np.sum(sv > rtol * max(sv.max(initial=0.0), np.finfo(float).tiny)))
            cond = float(sv[0] / sv[-1]) if sv.size and sv[-1] > 0 and defic == 0 else float("inf")
            channels.append(ChannelTest(complex(lam), "G", tuple(float(x) for x in sv), defic, cond))
        else:
            sc = system_scaling(ext.A, ext.C, method=scaling)
            Ae, Ce = sc.apply(ext.A, ext.C)
            scale = np.linalg.norm(np.vstack([Ae, Ce]), 2)
            sv = np.linalg.svd(np.vstack([lam * np.eye(n + q) - Ae, Ce]), compute_uv=False)
            defic = int(np.sum(sv <= rtol * scale))
            channels.append(ChannelTest(complex(lam), "block", (float(sv[-1]),), defic, float("nan")))
    reasons = []
    if p < s:
        reasons.append(f"p = {p} independent measurements < s = {s} modelled force channels")
    bad_plant = [t for t in plant.tests if t.deficiency]
    if bad_plant:
        reasons.append(f"plant unobservable at {len(bad_plant)} eigenvalue(s), e.g. {bad_plant[0].eigenvalue:.4g}")
    bad_ch = [c for c in channels if c.deficiency]
    if bad_ch and p >= s:
        reasons.append(f"force channels unobservable at lam = {bad_ch[0].eigenvalue:.4g} (rank of G(lam) < s)")
    weak = [c for c in channels if c.method == "G" and c.condition > weak_cond]
    if reasons:
        verdict = Verdict.UNOBSERVABLE
    elif weak or plant.verdict is Verdict.WEAK:
        verdict = Verdict.WEAK
        reasons.append(
            f"cond(G(lam)) = {weak[0].condition:.3g} > {weak_cond:g}"
            if weak
            else f"plant PBH margin {plant.margin:.2e} < {weak_rtol:g}"
        )
    else:
        verdict = Verdict.OBSERVABLE
    detectable = not bad_ch and p >= s and all(t.eigenvalue.real < 0 for t in bad_plant)
    return ExtendedObservability(p, s, plant, tuple(channels), verdict, detectable, "; ".join(reasons), weak_cond)
