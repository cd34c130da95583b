"""The Hautus (PBH) test: observability of each eigenvalue of a linear system."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from obsnl._text import block, number, one_line
from obsnl.linear.systems import DEFAULT_RTOL, DEFAULT_WEAK_RTOL, as_linear_system, claim, system_scaling
from obsnl.observability.verdicts import Verdict

__all__ = ["EigenTest", "HautusResult", "hautus"]


@dataclass(frozen=True)
class EigenTest:
    """The PBH test at one eigenvalue: ``rank [lam I - A; C]`` after scaling.

    ``margin`` is the smallest singular value divided by the scale ``||[A; C]||`` of the
    scaled pair; ``deficiency = multiplicity-free rank loss`` (n - rank).
    """

    eigenvalue: complex
    sigma_min: float
    margin: float
    deficiency: int
    mode_index: float
    verdict: Verdict

    def to_dict(self) -> dict:
        lam = complex(self.eigenvalue)
        return {
            "eigenvalue": [lam.real, lam.imag],
            "sigma_min": self.sigma_min,
            "margin": self.margin,
            "deficiency": self.deficiency,
            "mode_index": self.mode_index,
            "verdict": self.verdict.value,
        }


@dataclass(frozen=True)
class HautusResult:
    """Outcome of :func:`hautus`: one :class:`EigenTest` per distinct eigenvalue (upper half plane)."""

    n: int
    tests: tuple[EigenTest, ...]
    rtol: float
    weak_rtol: float
    scaling: str

    @property
    def observable(self) -> bool:
        return all(t.deficiency == 0 for t in self.tests)

    @property
    def detectable(self) -> bool:
        """True when every rank-deficient eigenvalue has a negative real part."""
        return all(t.deficiency == 0 or t.eigenvalue.real < 0 for t in self.tests)

    @property
    def deficiency(self) -> int:
        """Sum of the rank losses over the distinct eigenvalues, counting conjugates twice.

        Equals ``n - kalman rank`` when the unobservable eigenvalues are non-derogatory
        (one Jordan block each), e.g. when they are distinct.
        """
        return sum(t.deficiency * (1 if t.eigenvalue.imag == 0 else 2) for t in self.tests)

    @property
    def margin(self) -> float:
        return min((t.margin for t in self.tests), default=float("inf"))

    @property
    def verdict(self) -> Verdict:
        if not self.observable:
            return Verdict.UNOBSERVABLE
        if any(t.verdict is Verdict.WEAK for t in self.tests):
            return Verdict.WEAK
        return Verdict.OBSERVABLE

    def __repr__(self) -> str:
        return one_line(
            "HautusResult",
            f"verdict={self.verdict.value!r}",
            f"eigenvalues={len(self.tests)}",
            f"deficiency={self.deficiency}",
            f"margin={number(self.margin)}",
            f"detectable={self.detectable}",
        )

    def summary(self) -> str:
        """A few lines of plain text: the verdict, then each eigenvalue's test."""
        rows = [
            f"lambda = {number(t.eigenvalue)}: {t.verdict.value} (margin {number(t.margin)}, rank loss {t.deficiency}, mode index "
            f"{number(t.mode_index)})"
            for t in self.tests
        ]
        return block(
            f"{claim(self.verdict)}; {'detectable' if self.detectable else 'NOT detectable'}, "
            f"margin {number(self.margin)} (Hautus test, {self.n} states)",
            *rows[:10],
            f"... and {len(rows) - 10} more eigenvalues" if len(rows) > 10 else "",
        )

    def to_dict(self) -> dict:
        return {
            "n": self.n,
            "verdict": self.verdict.value,
            "observable": self.observable,
            "detectable": self.detectable,
            "margin": self.margin,
            "rtol": self.rtol,
            "weak_rtol": self.weak_rtol,
            "scaling": self.scaling,
            "tests": [t.to_dict() for t in self.tests],
        }


def distinct_eigenvalues(A: np.ndarray, *, rtol: float = 1e-9) -> np.ndarray:
    """Distinct eigenvalues with non-negative imaginary part (clusters within ``rtol*||A||`` merged)."""
    lam = np.linalg.eigvals(A)
    tol = rtol * max(float(np.linalg.norm(A, 2)), 1.0)
    lam = lam[lam.imag >= -tol]
    out: list[complex] = []
    for v in sorted(lam, key=lambda z: (z.real, z.imag)):
        if not any(abs(v - w) <= tol for w in out):
            out.append(complex(v.real, max(v.imag, 0.0)) if abs(v.imag) <= tol else complex(v))
    return np.array(out, dtype=complex)


def hautus(
    system: Any,
    C: Any = None,
    *,
    eigenvalues: Any = None,
    rtol: float = DEFAULT_RTOL,
    weak_rtol: float = DEFAULT_WEAK_RTOL,
    scaling: str = "balance",
) -> HautusResult:
    """Hautus / Popov-Belevitch-Hautus test: ``rank [lam I - A; C] = n`` at every eigenvalue of A.

    Parameters
    ----------
    system, C : Any
        A system object (``.A, .C``, e.g. ``control.StateSpace``) or tuple, or the matrices.
    eigenvalues : Any
        Points to test (default: the distinct eigenvalues of ``A``, upper half plane only:
        a real pair gives the same singular values at ``lam`` and ``conj(lam)``).
    rtol : float
        Rank tolerance relative to ``||[A; C]||`` of the scaled pair (explicit, not numpy's).
    weak_rtol : float
        An eigenvalue with full rank but ``margin < weak_rtol`` is reported as weak.
    scaling : str
        ``"balance"`` (default) or ``"none"``, see :func:`system_scaling`.

    Returns
    -------
    HautusResult
        Per eigenvalue: smallest singular value, relative margin, rank deficiency, the modal
        index ``||C v|| / max ||C v||`` (unit eigenvectors ``v`` of the scaled ``A``) and a verdict;
        overall ``observable``, ``detectable`` and ``margin``.

    References
    ----------
    .. [1] M. L. J. Hautus, "Controllability and observability conditions of linear autonomous systems", Proc.
       Koninklijke Nederlandse Akademie van Wetenschappen, Ser. A, 72, 443-448, 1969.

    Examples
    --------
    >>> r = hautus([[-1, 0], [0, -2]], [[1, 0]])
    >>> r.observable, r.detectable
    (False, True)
    """
    sysm = as_linear_system(system, C)
    sc = system_scaling(sysm.A, sysm.C, method=scaling)
    A, Cs = sc.apply(sysm.A, sysm.C)
    n = A.shape[0]
    scale = max(np.linalg.norm(np.vstack([A, Cs]), 2), np.finfo(float).tiny)
    lams = distinct_eigenvalues(A) if eigenvalues is None else np.atleast_1d(np.asarray(eigenvalues, dtype=complex))
    w, vecs = np.linalg.eig(A)
    cv = np.linalg.norm(Cs @ vecs, axis=0) / np.linalg.norm(vecs, axis=0)
    cmax = max(float(cv.max()) if cv.size else 0.0, np.finfo(float).tiny)
    tests = []
    for lam in lams:
        s = np.linalg.svd(np.vstack([lam * np.eye(n) - A, Cs]), compute_uv=False)
        defic = int(np.sum(s <= rtol * scale))
        rel = float(s[-1] / scale)
        mode = float(cv[np.argmin(np.abs(w - lam))] / cmax) if w.size else 0.0
        verdict = Verdict.UNOBSERVABLE if defic else (Verdict.WEAK if rel < weak_rtol else Verdict.OBSERVABLE)
        tests.append(EigenTest(complex(lam), float(s[-1]), rel, defic, mode, verdict))
    return HautusResult(n, tuple(tests), rtol, weak_rtol, sc.method)
