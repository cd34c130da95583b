"""The verdict of a test and the result value of one smooth branch: frozen, JSON-ready, rendered only in
``report``.
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from obsnl._text import block, names, one_line

__all__ = ["Verdict", "BranchResult"]


class Verdict(str, enum.Enum):
    """The one answer of an observability test, nonlinear or linear.

    ``OBSERVABLE``: every unknown is decided and determined by the outputs; ``UNOBSERVABLE``: some
    unknown is not; ``INCONCLUSIVE``: not decided (the result says why). ``WEAK`` ("weakly
    observable") is said only by the linear tests (:func:`obsnl.kalman_rank`, :func:`obsnl.hautus`):
    full rank, but some mode reaches the outputs only by a margin below the weak tolerance. The
    values are the strings that JSON files and reports carry.

    Examples
    --------
    >>> Verdict("weakly observable") is Verdict.WEAK
    True
    >>> Verdict.INCONCLUSIVE.summary()
    'inconclusive: some unknowns were not decided (the result gives the reason)'
    """

    OBSERVABLE = "observable"
    WEAK = "weakly observable"
    UNOBSERVABLE = "unobservable"
    INCONCLUSIVE = "inconclusive"

    def summary(self) -> str:
        """What the verdict claims, in one line."""
        return {
            "observable": "observable: the outputs determine every unknown",
            "weakly observable": "weakly observable: full rank, but some mode reaches the outputs only by a "
            "margin below the weak tolerance",
            "unobservable": "unobservable: some unknown is not determined by the outputs",
            "inconclusive": "inconclusive: some unknowns were not decided (the result gives the reason)",
        }[self.value]


@dataclass(frozen=True)
class BranchResult:
    """Observability of one smooth branch.

    Attributes
    ----------
    label, guard
        The branch label and its guard as text (``"true"`` for a smooth model).
    observable, unobservable
        Names of states (initial values) and parameters, in model order. Variables that do not
        appear in the branch's equations are unobservable and also listed in ``absent``.
    absent
        Variables that do not appear in this branch's equations or outputs.
    rank, size
        Rank of the observability-identifiability Jacobian and the number of unknowns.
    transcendence_degree
        ``size - rank``: how many unknowns must be known for all the others to be observable
        (absent variables count, as the seed paper counts w_h in branches (b), (d)).
    seconds
        Wall time of this branch's analysis.
    verdict
        :class:`Verdict`; ``INCONCLUSIVE`` comes with ``reason`` and then the lists hold only
        what was decided (undecided variables are in ``undecided``).
    order
        Number of Lie derivatives (ORC) or power-series terms (randomized test) used.
    method
        ``"orc"`` or ``"sedoglavic"``.
    unknown_inputs
        Classes of unknown inputs ``{"observable": [...], "unobservable": [...]}`` when the model has some.
    notes
        Plain-text notes: what was decomposed, augmented non-rational terms and what that means.
    signs
        The sign of each switching function of the model in this branch (empty for a smooth model).
    """

    label: str
    guard: str
    observable: tuple[str, ...]
    unobservable: tuple[str, ...]
    absent: tuple[str, ...]
    rank: int
    size: int
    transcendence_degree: int
    seconds: float
    verdict: Verdict = Verdict.OBSERVABLE
    reason: str = ""
    undecided: tuple[str, ...] = ()
    order: int | None = None
    method: str = ""
    unknown_inputs: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    signs: tuple[int, ...] = ()

    def __repr__(self) -> str:
        return one_line(
            "BranchResult",
            f"label={self.label!r}",
            f"guard={self.guard!r}",
            f"verdict={self.verdict.value!r}",
            f"rank={self.rank}/{self.size}",
            f"unobservable={names(self.unobservable, 6)!r}",
        )

    def summary(self) -> str:
        """A few lines of plain text: the branch's verdict, then its lists."""
        degree = "not decided" if self.verdict is Verdict.INCONCLUSIVE else self.transcendence_degree
        return block(
            f"branch ({self.label}) {self.guard}: {self.verdict.value} (rank {self.rank}/{self.size}, "
            f"transcendence degree {degree}, {self.method or 'method not recorded'}, {self.seconds:.3g} s)",
            f"observable: {names(self.observable, 12)}",
            f"unobservable: {names(self.unobservable, 12)}",
            f"absent: {names(self.absent, 12)}" if self.absent else "",
            f"undecided: {names(self.undecided, 12)} ({self.reason})" if self.undecided else "",
        )

    def to_dict(self, *, extended: bool = False) -> dict[str, Any]:
        """The branch as JSON-ready data.

        The default keys are those of ``obsnl analyze --format json``: ``label, guard, observable,
        unobservable, absent, rank, size, transcendence_degree, seconds, verdict``, with
        ``unknown_inputs`` (``{"observable": [...], "unobservable": [...]}``) when the model has
        some, and ``reason, undecided`` for an inconclusive branch, whose ``transcendence_degree`` is
        None (nothing is claimed for what was not decided). ``extended=True`` adds ``reason,
        undecided, order, method, unknown_inputs, notes`` always.
        """
        inconclusive = self.verdict is Verdict.INCONCLUSIVE
        d: dict[str, Any] = {
            "label": self.label,
            "guard": self.guard,
            "observable": list(self.observable),
            "unobservable": list(self.unobservable),
            "absent": list(self.absent),
            "rank": self.rank,
            "size": self.size,
            "transcendence_degree": None if inconclusive else self.transcendence_degree,
            "seconds": self.seconds,
            "verdict": self.verdict.value,
        }
        if self.unknown_inputs:
            d["unknown_inputs"] = {k: list(v) for k, v in self.unknown_inputs.items()}
        if inconclusive:
            d.update(reason=self.reason, undecided=list(self.undecided))
        if extended:
            d.update(
                reason=self.reason,
                undecided=list(self.undecided),
                order=self.order,
                method=self.method,
                unknown_inputs={k: list(v) for k, v in self.unknown_inputs.items()},
                notes=list(self.notes),
            )
        return d
