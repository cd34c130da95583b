"""The value of a sensor search: the sets that suffice, the smallest, and the reasons of those refused."""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from obsnl._display import render
from obsnl._types import JSONValue
from obsnl.design.sufficiency import Sufficiency
from obsnl.observability.assumptions import Assumptions

if TYPE_CHECKING:  # the ranking simulates (casadi): named here, imported by rank_sufficient_sets only
    from obsnl.design.ranking import Ranking

__all__ = ["SearchAssumptions", "SensorSearch"]

#: What every verdict of a sensor search assumes besides the analysis and the branches visited.
MONOTONICITY = "a superset of a sufficient set is sufficient; a subset of an insufficient set is not"


@dataclass(frozen=True)
class SearchAssumptions:
    """What every verdict of a sensor search assumes: the analysis' own, the branches visited, monotonicity.

    Attributes
    ----------
    analysis
        The assumptions of the joint verdicts (:class:`~obsnl.observability.assumptions.Assumptions`).
    visited
        The branches visited, in words (``"every feasible branch"``, or those a record visits).
    monotonicity
        The rule that spares analyses (:data:`MONOTONICITY`).
    """

    analysis: Assumptions
    visited: str = "every feasible branch"
    monotonicity: str = MONOTONICITY

    def to_dict(self) -> dict[str, JSONValue]:
        """JSON-ready: the analysis' keys, then ``visited`` and ``monotonicity``."""
        return {**self.analysis.to_dict(), "visited": self.visited, "monotonicity": self.monotonicity}


@dataclass(frozen=True)
class SensorSearch:
    """Every minimal sufficient set of sensors (up to a size), with certificates.

    Attributes
    ----------
    model
        The model's name.
    candidates
        The candidate sensors (the model's outputs), in order.
    targets
        States and parameters that must be jointly identifiable.
    max_size
        Largest set size searched.
    minimal_sets
        Every minimal sufficient set of at most ``max_size`` sensors, smallest first.
    undecided_sets
        Sets whose sufficiency, or whose minimality, could not be decided (with the reason in
        :attr:`checked`).
    none_exists
        True when even the full set of candidates is insufficient (then ``minimal_sets`` is empty and
        ``proof`` says why).
    proof
        Why no set suffices (the targets no sensor reveals, the symmetries no sensor breaks); empty
        otherwise.
    checked
        Every set whose answer was established, by analysis, reachability or implication.
    analyses
        Joint verdicts run (the cost of the search; compare with ``2**len(candidates) - 1`` sets).
    seed
        Seed of every analysis.
    assumptions
        What the verdicts assume (:class:`SearchAssumptions`: the analysis' assumptions and the visited branches);
        None when not stated.
    ranking
        The sufficient sets of one size ranked along a record (:class:`~obsnl.design.ranking.Ranking`), when
        :func:`~obsnl.design.sensors.rank_sufficient_sets` made it; else None.
    seconds
        Wall time.
    complete
        True when :attr:`minimal_sets` are every minimal set of any size, not only of at most ``max_size``
        sensors: every size was searched, or every larger set that contains none of them was proven
        insufficient (the search then stopped early), or no set suffices.
    """

    model: str
    candidates: tuple[str, ...]
    targets: tuple[str, ...]
    max_size: int
    minimal_sets: tuple[tuple[str, ...], ...]
    undecided_sets: tuple[tuple[str, ...], ...] = ()
    none_exists: bool = False
    proof: str = ""
    checked: tuple[Sufficiency, ...] = field(default=(), repr=False)
    analyses: int = 0
    seed: int = 0
    assumptions: SearchAssumptions | None = field(default=None, repr=False)
    seconds: float = 0.0
    ranking: Ranking | None = field(default=None, repr=False, compare=False)
    effective_independence: tuple[str, ...] = ()
    complete: bool = False

    @property
    def exhaustive(self) -> int:
        """Number of non-empty sets of candidates (what a search without monotonicity would test)."""
        return 2 ** len(self.candidates) - 1

    def answer(self, sensors: Sequence[str]) -> Sufficiency | None:
        """The established answer for one set (None when the search did not reach it)."""
        key = frozenset(sensors)
        return next((c for c in self.checked if frozenset(c.sensors) == key), None)

    def certificates(self) -> list[dict[str, Any]]:
        """Per minimal set: its own analysis, and how each set with one sensor removed was proven insufficient."""
        out = []
        for s in self.minimal_sets:
            own = self.answer(s)
            removed = {}
            for name in s:
                rest = tuple(x for x in s if x != name)
                if not rest:
                    removed[name] = {"sufficient": False, "how": "empty", "reason": "no sensor left"}
                    continue
                ans = self.answer(rest)
                removed[name] = ans.to_dict() if ans is not None else {"sufficient": None, "how": "missing"}
            out.append({"sensors": list(s), "analysis": own.to_dict() if own is not None else None, "without": removed})
        return out

    def summary(self) -> str:
        """A few lines: the minimal sets, or why none exists, and the cost of the search."""
        if self.none_exists:
            head = f"no set of the {len(self.candidates)} candidate sensors suffices: {self.proof}"
        elif self.minimal_sets:
            head = "minimal sensor sets: " + "; ".join("{" + ", ".join(s) + "}" for s in self.minimal_sets)
            head += " (every one, of any size)" if self.complete else f" (of at most {self.max_size} sensors)"
        else:
            head = f"no sufficient set of at most {self.max_size} sensors"
        tail = f"{self.analyses} analyses for {self.exhaustive} possible sets"
        if self.undecided_sets:
            tail += f"; undecided: {len(self.undecided_sets)} sets"
        return f"{head}\n{tail}"

    def _repr_html_(self) -> str | None:
        """Notebook display: the minimal sets, drawn by :mod:`obsnl.report` (:mod:`obsnl._display`)."""
        return render("html", self)

    def __repr__(self) -> str:
        return (
            f"SensorSearch(model={self.model!r}, minimal_sets={len(self.minimal_sets)}, "
            f"none_exists={self.none_exists}, analyses={self.analyses})"
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: ``minimal_sets``, ``analyses``, ``certificates`` and the rest of the search."""
        out = {
            "model": self.model,
            "candidates": list(self.candidates),
            "targets": list(self.targets),
            "max_size": self.max_size,
            "minimal_sets": [list(s) for s in self.minimal_sets],
            "undecided_sets": [list(s) for s in self.undecided_sets],
            "none_exists": self.none_exists,
            "proof": self.proof,
            "analyses": self.analyses,
            "possible_sets": self.exhaustive,
            "certificates": self.certificates(),
            "checked": [c.to_dict() for c in self.checked],
            "seed": self.seed,
            "assumptions": {} if self.assumptions is None else self.assumptions.to_dict(),
            "seconds": round(self.seconds, 3),
            "complete": self.complete,
        }
        if self.ranking is not None:
            out["ranking"] = self.ranking.to_dict()["rows"]
            out["ranking_setup"] = {k: v for k, v in self.ranking.to_dict().items() if k != "rows"}
            out["effective_independence"] = list(self.effective_independence)
        return out

    def sufficient_sets(self, size: int) -> list[tuple[str, ...]]:
        """Every set of ``size`` candidates known sufficient: a minimal set, or one that contains one."""
        return [
            c for c in itertools.combinations(self.candidates, size) if any(set(x) <= set(c) for x in self.minimal_sets)
        ]
