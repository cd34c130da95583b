"""Observability of linear systems: Kalman rank and the Hautus (PBH) test, with scaling.

Rank decisions on matrices that mix metres, radians and stiffnesses of 1e8 are decided by
the tolerance, not by the system. Every test here therefore (i) works on a balanced copy of
the system (``scipy.linalg.matrix_balance`` of ``[[A, 0], [C, 0]]``, a diagonal similarity that
leaves the verdict unchanged) and (ii) takes an explicit relative tolerance ``rtol`` and reports
the margin (smallest singular value) so that weak observability is visible.

Systems are given as matrices or as any object with ``.A``, ``.B``, ``.C`` (and ``.D``)
attributes, e.g. a python-control ``StateSpace``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla

from obsnl._text import block, numbers, one_line
from obsnl.errors import DataError
from obsnl.observability.verdicts import Verdict

__all__ = [
    "LinearSystem",
    "as_linear_system",
    "Scaling",
    "system_scaling",
    "claim",
    "KalmanRankResult",
    "kalman_rank",
    "DEFAULT_RTOL",
    "DEFAULT_WEAK_RTOL",
    "checked_matrix",
]

#: Default relative rank tolerance: a singular value counts as zero below ``rtol * scale``.
DEFAULT_RTOL = 1e-13
#: Default relative margin below which an observable eigenvalue is reported as weak.
DEFAULT_WEAK_RTOL = 1e-8


def checked_matrix(value: Any, name: str, *, rows: int | None = None, cols: int | None = None) -> np.ndarray:
    """A matrix of a linear system as a 2-D float array, its shape and values checked.

    A 1-D array is read as one row when its length is ``cols``, else as one column when its length is ``rows``.

    Parameters
    ----------
    value : array_like
        The matrix.
    name : str
        Its name in a refusal (``"A"``, ``"C"``, ``"L"``).
    rows : int or None
        The number of rows required (None: any).
    cols : int or None
        The number of columns required (None: any).

    Returns
    -------
    numpy.ndarray
        2-D, float.

    Raises
    ------
    DataError
        Not real numbers, not 2-D, the wrong number of rows or columns, or a NaN or an infinity.

    Examples
    --------
    >>> checked_matrix([1, 0], "C", cols=2)
    array([[1., 0.]])
    >>> checked_matrix([[1, 0]], "C", cols=3)
    Traceback (most recent call last):
    ...
    obsnl.errors.DataError: C has 2 columns, expected 3 (the number of states)
    """
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise DataError(f"{name} must be a real numeric matrix ({exc})") from exc
    if a.ndim == 1 and cols is not None and a.size == cols:
        a = a.reshape(1, -1)
    if a.ndim == 1 and rows is not None and a.size == rows:
        a = a.reshape(-1, 1)
    if a.ndim != 2:
        raise DataError(f"{name} must be 2-D, got shape {a.shape}")
    if rows is not None and a.shape[0] != rows:
        raise DataError(f"{name} has {a.shape[0]} rows, expected {rows} (the number of states)")
    if cols is not None and a.shape[1] != cols:
        raise DataError(f"{name} has {a.shape[1]} columns, expected {cols} (the number of states)")
    if not np.all(np.isfinite(a)):
        raise DataError(f"{name} contains NaN or inf; give finite numbers")
    return a


@dataclass(frozen=True, eq=False)
class LinearSystem:
    """A continuous-time LTI system ``dx/dt = A x + B u``, ``y = C x + D u`` (validated, read-only).

    Examples
    --------
    >>> s = LinearSystem([[0, 1], [-1, 0]], [[0], [1]], [[1, 0]])
    >>> s.n_states, s.n_inputs, s.n_outputs
    (2, 1, 1)
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray | None = None

    def __post_init__(self) -> None:
        A = checked_matrix(self.A, "A")
        if A.shape[0] != A.shape[1]:
            raise DataError(f"A must be square, got shape {A.shape}")
        n = A.shape[0]
        B = checked_matrix(self.B if self.B is not None else np.zeros((n, 0)), "B", rows=n)
        C = checked_matrix(self.C, "C", cols=n)
        D = np.zeros((C.shape[0], B.shape[1])) if self.D is None else checked_matrix(self.D, "D")
        if D.shape != (C.shape[0], B.shape[1]):
            raise DataError(f"D has shape {D.shape}, expected {(C.shape[0], B.shape[1])}")
        for k, v in (("A", A), ("B", B), ("C", C), ("D", D)):
            v = v.copy()
            v.flags.writeable = False
            object.__setattr__(self, k, v)

    @property
    def n_states(self) -> int:
        return self.A.shape[0]

    @property
    def n_inputs(self) -> int:
        return self.B.shape[1]

    @property
    def n_outputs(self) -> int:
        return self.C.shape[0]

    def __repr__(self) -> str:
        return one_line(
            "LinearSystem", f"states={self.n_states}", f"inputs={self.n_inputs}", f"outputs={self.n_outputs}"
        )

    def summary(self) -> str:
        """A few lines of plain text: the sizes and the eigenvalues of ``A``.

        Examples
        --------
        >>> print(LinearSystem([[0, 1], [-4, 0]], [[0], [1]], [[1, 0]]).summary(), end="")
        linear system: 2 states, 1 inputs, 1 outputs
        eigenvalues of A: [0+2j, 0-2j]
        """
        return block(
            f"linear system: {self.n_states} states, {self.n_inputs} inputs, {self.n_outputs} outputs",
            f"eigenvalues of A: {numbers(np.linalg.eigvals(self.A), 8)}",
        )


def as_linear_system(system: Any, C: Any = None) -> LinearSystem:
    """A :class:`LinearSystem` from a system object (``.A, .B, .C``), a tuple, or a pair ``(A, C)``.

    Accepts a python-control ``StateSpace`` (continuous time only), a :class:`LinearSystem`,
    a tuple ``(A, B, C[, D])``, or ``as_linear_system(A, C)``.

    Parameters
    ----------
    system : Any
        A system object, a tuple, or the matrix ``A``.
    C : array_like or None
        The output matrix when ``system`` is ``A``.

    Returns
    -------
    LinearSystem

    Raises
    ------
    DataError
        For a discrete-time system or an unreadable object.
    """
    if isinstance(system, LinearSystem) and C is None:
        return system
    if C is not None:
        A = checked_matrix(system, "A")
        return LinearSystem(A, np.zeros((A.shape[0], 0)), C)
    if all(hasattr(system, k) for k in ("A", "B", "C")):
        dt = getattr(system, "dt", 0)
        if dt not in (0, None):
            raise DataError(f"a discrete-time system (dt={dt}) was given; the tests here are for continuous time")
        return LinearSystem(system.A, system.B, system.C, getattr(system, "D", None))
    if isinstance(system, (tuple, list)) and len(system) in (3, 4):
        return LinearSystem(*system)
    raise DataError(
        f"cannot read a linear system from {type(system).__name__}; pass an object with .A, .B, .C "
        "(e.g. control.StateSpace), a tuple (A, B, C[, D]) or the matrices A and C"
    )


@dataclass(frozen=True, eq=False)
class Scaling:
    """Diagonal change of coordinates ``x = diag(state) z``, outputs divided by ``output``.

    Apply with :meth:`apply`; ranks and verdicts are invariant, singular values are not.
    """

    method: str
    state: np.ndarray
    output: np.ndarray

    def apply(self, A: np.ndarray, C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The scaled pair ``(T^-1 A T, S^-1 C T)``."""
        t = self.state
        return A * (t[None, :] / t[:, None]), C * t[None, :] / self.output[:, None]


def system_scaling(A: Any, C: Any, *, method: str = "balance") -> Scaling:
    """A diagonal scaling of ``(A, C)`` for rank decisions.

    Parameters
    ----------
    A, C : Any
        State and output matrices.
    method : {"balance", "none"}
        ``"balance"`` balances ``[[A, 0], [C, 0]]`` with ``scipy.linalg.matrix_balance``
        (powers of two, no permutation) and then scales each output row to unit norm;
        ``"none"`` is the identity.
    """
    sysm = as_linear_system(A, C)
    A, C = sysm.A, sysm.C
    n, p = A.shape[0], C.shape[0]
    if method == "none":
        return Scaling("none", np.ones(n), np.ones(p))
    if method != "balance":
        raise DataError(f"unknown scaling method {method!r}; use 'balance' or 'none'")
    big = np.zeros((n + p, n + p))
    big[:n, :n], big[n:, :n] = A, C
    _, (s, _perm) = sla.matrix_balance(big, permute=False, separate=True)
    t = np.asarray(s[:n], dtype=float)
    rows = np.linalg.norm(C * t[None, :], axis=1)
    rows[rows == 0] = 1.0
    return Scaling("balance", t, rows)


def claim(verdict: Verdict) -> str:
    """What a linear test's verdict claims, in one line (the modes of a linear system).

    Parameters
    ----------
    verdict : Verdict
        ``OBSERVABLE``, ``WEAK`` or ``UNOBSERVABLE`` (the linear tests never answer ``INCONCLUSIVE``).

    Examples
    --------
    >>> claim(Verdict.WEAK)
    'weakly observable: full rank, but some mode reaches the outputs only by a margin below the weak tolerance'
    """
    return {
        "observable": "observable: every mode reaches the outputs with a margin",
        "weakly observable": "weakly observable: full rank, but some mode reaches the outputs only by a "
        "margin below the weak tolerance",
        "unobservable": "unobservable: some mode never reaches the outputs (rank lost at an eigenvalue)",
    }[verdict.value]


@dataclass(frozen=True)
class KalmanRankResult:
    """Rank of the observability (Krylov) matrix, computed as the dimension of the observable subspace.

    ``steps`` holds the number of new directions found at each Krylov step; ``margins`` the
    smallest accepted singular value (relative to ``||A||``) at each step.
    """

    n: int
    rank: int
    steps: tuple[int, ...]
    margins: tuple[float, ...]
    rtol: float
    scaling: str

    @property
    def observable(self) -> bool:
        return self.rank == self.n

    def __repr__(self) -> str:
        return one_line(
            "KalmanRankResult",
            f"observable={self.observable}",
            f"rank={self.rank}/{self.n}",
            f"scaling={self.scaling!r}",
        )

    def summary(self) -> str:
        """A few lines of plain text: the rank, and the new directions and margins of each Krylov step."""
        return block(
            f"{'observable' if self.observable else 'unobservable'}: Kalman rank {self.rank} of {self.n} "
            f"(rtol {self.rtol:g}, scaling {self.scaling})",
            f"new directions per Krylov step: {list(self.steps)}; smallest accepted singular value per step "
            f"(relative): {numbers(self.margins, 8)}",
        )

    def to_dict(self) -> dict:
        return {
            "n": self.n,
            "rank": self.rank,
            "observable": self.observable,
            "steps": list(self.steps),
            "margins": list(self.margins),
            "rtol": self.rtol,
            "scaling": self.scaling,
        }


def kalman_rank(system: Any, C: Any = None, *, rtol: float = 1e-8, scaling: str = "balance") -> KalmanRankResult:
    """Kalman rank test: ``rank [C; CA; ...; CA^(n-1)]`` by an orthogonal Krylov (staircase) iteration.

    Forming ``C A^k`` explicitly is hopeless for stiff mechanical models (``||A|| ~ 1e4``
    raised to the 23rd power); instead the observable subspace ``span{(A^T)^k C^T}`` is
    built one orthonormal block at a time, which is the numerically stable way to compute
    the same rank (the observability staircase form).

    Parameters
    ----------
    system, C : Any
        A system object (``.A, .C``) or tuple, or the matrices ``A`` and ``C``.
    rtol : float
        A new direction is accepted when its singular value exceeds ``rtol * ||A||`` (after
        scaling); at the first step, when it exceeds ``rtol * ||C||``. The orthogonalisation
        leaves round-off directions of order 1e-10 on badly scaled systems, hence the default.
    scaling : str
        ``"balance"`` (default) or ``"none"``, see :func:`system_scaling`.

    References
    ----------
    .. [1] R. E. Kalman, "Mathematical description of linear dynamical systems", J. SIAM Control Ser. A 1(2), 152-192,
       1963. doi:10.1137/0301010

    Examples
    --------
    >>> kalman_rank([[0, 1], [-2, -3]], [[1, 0]]).rank
    2
    """
    sysm = as_linear_system(system, C)
    sc = system_scaling(sysm.A, sysm.C, method=scaling)
    A, Cs = sc.apply(sysm.A, sysm.C)
    n = A.shape[0]
    Q = np.zeros((n, 0))
    new = Cs.T
    ref = max(np.linalg.norm(Cs, 2), np.finfo(float).tiny)
    steps: list[int] = []
    margins: list[float] = []
    normA = max(np.linalg.norm(A, 2), np.finfo(float).tiny)
    while Q.shape[1] < n:
        for _ in range(2):  # re-orthogonalise twice against the accepted basis
            new = new - Q @ (Q.T @ new)
        U, s, _ = np.linalg.svd(new, full_matrices=False)
        k = int(np.sum(s > rtol * ref))
        if k == 0:
            break
        Q = np.hstack([Q, U[:, :k]])
        steps.append(k)
        margins.append(float(s[k - 1] / ref))
        new = A.T @ U[:, :k]
        ref = normA
    return KalmanRankResult(n, Q.shape[1], tuple(steps), tuple(margins), rtol, sc.method)
