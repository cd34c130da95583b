"""The joint verdict as a value: what the visited branches and switching surfaces determine together."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from obsnl._text import block, bound, names, one_line, probability_text, verdict_words
from obsnl.observability.assumptions import JointAssumptions

__all__ = ["JointResult", "JointVisit"]


@dataclass(frozen=True)
class JointVisit:
    """One visit of the joint stack.

    Attributes
    ----------
    kind
        ``"branch"`` or ``"surface"``.
    labels
        The branch label (branch visit) or the labels of the two sides (surface visit).
    switching
        The switching function crossed (surface visits; ``""`` for branch visits).
    visible
        Whether the output shows the crossing (surface visits; always True for branch visits).
        None when the surface could not be placed.
    parameter_rank
        Rank of the parameter information the visit carries on its own (its rows with its private
        unknowns eliminated).
    rank_gain
        By how much it raised the joint parameter rank when it was added (in visit order).
    solved_for
        The state solved from ``switching = 0`` to place the point on the surface.
    reason
        Why a surface was skipped (no state in which the switching function is affine, ...).
    """

    kind: str
    labels: tuple[str, ...]
    switching: str = ""
    visible: bool | None = True
    parameter_rank: int = 0
    rank_gain: int = 0
    solved_for: str = ""
    reason: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "labels": list(self.labels),
            "switching": self.switching,
            "visible": self.visible,
            "parameter_rank": self.parameter_rank,
            "rank_gain": self.rank_gain,
            "solved_for": self.solved_for,
            "reason": self.reason,
        }


@dataclass(frozen=True)
class JointResult:
    """What the whole experiment reveals when parameters are shared by all branches.

    Attributes
    ----------
    model
        The model's name.
    observable, unobservable, inconclusive
        States (initial values) and parameters, in model order. A state is observable when its
        value at some visit is determined; ``inconclusive`` comes with ``reason``.
    unknown_inputs
        ``{"observable": (...), "unobservable": (...)}`` (empty without unknown inputs); undecided
        unknown inputs are in ``inconclusive``.
    visits
        The visits used, in order (:class:`JointVisit`).
    union_observable
        Variables observable within a single branch visit on its own (the per-branch union,
        over the branch visits made; see ``assumptions.union_over``).
    parameter_rank
        Rank of the joint parameter row space (first run).
    probability
        Lower bound on the probability that every decided verdict is right.
    seed
        The seed of every random choice.
    runs
        Number of independent runs (prime and points).
    early_stop
        True when visits were skipped because everything was already observable.
    reason
        Why some verdicts are inconclusive (empty otherwise).
    assumptions
        What the verdict assumes (:class:`~obsnl.observability.assumptions.JointAssumptions`): unknown-input
        derivatives, known inputs generic, the visited branches, the surfaces used (visible), invisible and
        skipped, known initial conditions; None when not stated (``to_dict`` then writes ``{}``).
    seconds
        Wall time.
    """

    model: str
    observable: tuple[str, ...]
    unobservable: tuple[str, ...]
    inconclusive: tuple[str, ...]
    unknown_inputs: Mapping[str, tuple[str, ...]]
    visits: tuple[JointVisit, ...]
    union_observable: tuple[str, ...]
    parameter_rank: int
    probability: float
    seed: int
    runs: int
    early_stop: bool
    reason: str
    assumptions: JointAssumptions | None
    seconds: float

    def __repr__(self) -> str:
        words = verdict_words(self.observable, self.unobservable, self.inconclusive, most=6)
        return one_line(
            "JointResult", f"model={self.model!r}", repr(words), f"visits={len(self.visits)}", bound(self.probability)
        )

    def summary(self) -> str:
        """A few lines of plain text: the verdict, why some is undecided, the visits used."""
        return block(
            f"{self.model}: {verdict_words(self.observable, self.unobservable, self.inconclusive, most=12)}",
            f"undecided because: {self.reason}" if self.inconclusive else "",
            f"visits: {names([v.kind + ' ' + '/'.join(v.labels) for v in self.visits], 6)}; parameter rank "
            f"{self.parameter_rank}; P >= {probability_text(self.probability)}, seed {self.seed}",
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary (tuples as lists)."""

        def plain(v: Any) -> Any:
            if isinstance(v, Mapping):
                return {k: plain(x) for k, x in v.items()}
            if isinstance(v, (tuple, list)):
                return [plain(x) for x in v]
            return v

        return {
            "model": self.model,
            "observable": list(self.observable),
            "unobservable": list(self.unobservable),
            "inconclusive": list(self.inconclusive),
            "unknown_inputs": plain(self.unknown_inputs),
            "visits": [v.to_dict() for v in self.visits],
            "union_observable": list(self.union_observable),
            "parameter_rank": self.parameter_rank,
            "probability": self.probability,
            "seed": self.seed,
            "runs": self.runs,
            "early_stop": self.early_stop,
            "reason": self.reason,
            "assumptions": {} if self.assumptions is None else self.assumptions.to_dict(),
            "seconds": self.seconds,
        }
