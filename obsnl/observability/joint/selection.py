"""Which branches an analysis visits: every feasible branch, the branches a user names, representative
branches of a model with many switching functions, or the branches a record actually visits.

:func:`select_branches` returns the branches and a :class:`Visited` value that says how they were
chosen (it travels with the result, so that every answer says what it assumed).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

from obsnl.errors import AnalysisError, NotSupportedError
from obsnl.model.branching.branches import Branch
from obsnl.model.branching.structure import branching
from obsnl.model.core import Model

__all__ = ["Visited", "select_branches"]


@dataclass(frozen=True)
class Visited:
    """How the analysed branches were chosen.

    Attributes
    ----------
    how
        ``"all"`` (every feasible branch), ``"labels"`` (named by the user), ``"representatives"``
        (a base pattern and each independent group's other patterns) or ``"record"`` (the sign
        patterns a simulation under a record visits).
    note
        One sentence for the answer: what was enumerated and what was argued.
    exhaustive
        True when the visited branches are every feasible branch of the model. With ``"labels"``
        and ``"record"`` the verdicts are about the visited branches (what that experiment reveals);
        with ``"representatives"`` they are about the model, and a jointly unobservable verdict over
        the representatives is reported as not decided.
    durations
        For ``"record"``: seconds spent in each visited branch (by label), and the crossings seen.
    """

    how: str
    note: str
    exhaustive: bool
    durations: Mapping[str, float] = field(default_factory=dict)
    crossings: Mapping[str, int] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "how": self.how,
            "note": self.note,
            "exhaustive": self.exhaustive,
            "durations": dict(self.durations),
            "crossings": dict(self.crossings),
        }


def select_branches(
    model: Model,
    *,
    labels: Sequence[str] | None = None,
    patterns: Mapping[tuple[int, ...], float] | None = None,
    crossings: Mapping[str, int] | None = None,
    seed: int = 0,
    max_seconds: float | None = None,
) -> tuple[list[Branch], Visited]:
    """The branches to analyse, and how they were chosen.

    Parameters
    ----------
    model : Model
        Any model.
    labels : sequence of str or None
        Branch labels to keep (of :func:`obsnl.model.split_branches`); None: every feasible branch.
    patterns : mapping of tuple of int to float or None
        Sign patterns actually visited (e.g. by a simulation under a record), with the time spent
        in each; overrides ``labels``.
    crossings : mapping of str to int or None
        Crossings seen per switching function (text), reported with ``patterns``.
    seed : int
        Seed of the feasibility search.
    max_seconds : float or None
        Time limit of the branch split (:func:`obsnl.model.split_branches`).

    Returns
    -------
    (branches, Visited)

    Raises
    ------
    AnalysisError
        An unknown label, or a visited pattern that is not a feasible branch.

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="relay", states=["x"], parameters=["s"], inputs=["u"],
    ...           equations={"x": "u - s*sign(x)"}, outputs={"y": "x"})
    >>> bs, how = select_branches(m, labels=["b"])
    >>> [b.label for b in bs], how.how, how.exhaustive
    (['b'], 'labels', False)
    """
    found = branching(model, seed=seed, max_seconds=max_seconds)  # once: every later choice is made from it
    if patterns is not None:
        # a pattern the record visits holds somewhere: one whose feasibility was undecided is decided now
        by_signs = {tuple(b.signs): replace(b, undecided="") for b in found.branches}
        chosen, durations = [], {}
        for signs, seconds in patterns.items():
            b = by_signs.get(tuple(signs))
            if b is None:  # a branch that was not enumerated
                try:
                    b = found.pattern(signs)
                except NotSupportedError as exc:
                    raise AnalysisError(f"visited sign pattern {tuple(signs)}: {exc}") from None
            chosen.append(b)
            durations[b.label] = round(float(seconds), 6)
        return chosen, Visited(
            how="record",
            exhaustive=False,
            durations=durations,
            crossings=dict(crossings or {}),
            note=(
                f"the {len(chosen)} branches a simulation under the record visits (time in each and the "
                f"crossings are listed); the verdicts are what this experiment reveals"
            ),
        )
    branches = list(found.branches)
    open_ = [b.label for b in branches if b.undecided]
    if found.representatives is not None:
        visited = Visited(how="representatives", exhaustive=False, note=found.representatives.describe())
    elif open_:  # reported, never dropped: each is an inconclusive branch of the answer
        visited = Visited(
            how="all",
            exhaustive=False,
            note=(
                f"every feasible branch ({len(branches) - len(open_)}) and {len(open_)} whose feasibility is undecided "
                f"({', '.join(open_)}: no point was found in them and none was proved impossible; not analysed)"
            ),
        )
    else:
        visited = Visited(
            how="all",
            exhaustive=True,
            note=f"every feasible branch ({len(branches)})" if len(branches) > 1 else "smooth model",
        )
    if labels is None:
        return branches, visited
    every = {b.label: b for b in branches}
    missing = [lb for lb in labels if lb not in every]
    if missing:
        raise AnalysisError(f"no branch labelled {', '.join(map(repr, missing))}; the branches are {', '.join(every)}")
    chosen = [every[lb] for lb in dict.fromkeys(labels)]
    return chosen, Visited(
        how="labels",
        exhaustive=len(chosen) == len(every) and visited.exhaustive,
        note=f"only the branches {', '.join(b.label for b in chosen)} (the branches asked)",
    )
