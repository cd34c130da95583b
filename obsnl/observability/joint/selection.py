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
from obsnl.model.branching.branches import _MAX_SWITCHING, Branch, split_branches
from obsnl.model.core import NONSMOOTH_FUNCTIONS, Model
from obsnl.model.branching.representatives import representative_branches
from obsnl.model.branching.switching import switching_of

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
        return {"how": self.how, "note": self.note, "exhaustive": self.exhaustive,
                "durations": dict(self.durations), "crossings": dict(self.crossings)}


#: Above this many switching functions (2**8 = 256 sign patterns) the branches are not enumerated:
#: representative branches stand for them (:mod:`obsnl.model.branching.representatives`). An enumeration of
#: 2**8 patterns of a 4-storey building takes about 17 s here, 2**10 several minutes.
ENUMERATE_UP_TO = 8


def _too_many(model: Model) -> bool:
    """True when the first level has more switching functions than an enumeration handles."""
    exprs = list(model.rhs) + list(model.output_exprs)
    if not any(e.has(*NONSMOOTH_FUNCTIONS) for e in exprs):
        return False
    return len(switching_of(exprs, model.switching, {})) > min(ENUMERATE_UP_TO, _MAX_SWITCHING)


def select_branches(model: Model, *, labels: Sequence[str] | None = None,
                    patterns: Mapping[tuple[int, ...], float] | None = None,
                    crossings: Mapping[str, int] | None = None, seed: int = 0,
                    max_seconds: float | None = None) -> tuple[list[Branch], Visited]:
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
    if patterns is not None:
        every = _all_or_representatives(model, seed, max_seconds)[0]
        # a pattern the record visits holds somewhere: one whose feasibility was undecided is decided now
        by_signs = {tuple(b.signs): replace(b, undecided="") for b in every}
        chosen, durations = [], {}
        for signs, seconds in patterns.items():
            b = by_signs.get(tuple(signs))
            if b is None:
                b = _branch_for(model, signs, seed)
            chosen.append(b)
            durations[b.label] = round(float(seconds), 6)
        return chosen, Visited(
            how="record", exhaustive=False, durations=durations, crossings=dict(crossings or {}),
            note=(f"the {len(chosen)} branches a simulation under the record visits (time in each and the "
                  f"crossings are listed); the verdicts are what this experiment reveals"))
    branches, visited = _all_or_representatives(model, seed, max_seconds)
    if labels is None:
        return branches, visited
    every = {b.label: b for b in branches}
    missing = [lb for lb in labels if lb not in every]
    if missing:
        raise AnalysisError(f"no branch labelled {', '.join(map(repr, missing))}; the branches are "
                            f"{', '.join(every)}")
    chosen = [every[lb] for lb in dict.fromkeys(labels)]
    return chosen, Visited(how="labels", exhaustive=len(chosen) == len(every) and visited.exhaustive,
                           note=f"only the branches {', '.join(b.label for b in chosen)} (the branches asked)")


def _all_or_representatives(model: Model, seed: int, max_seconds: float | None = None) -> tuple[list[Branch], Visited]:
    if _too_many(model):
        try:
            reps = representative_branches(model, seed=seed)
        except NotSupportedError:  # nested non-smooth functions: the enumeration decides (or refuses)
            reps = None
        if reps is not None:
            return list(reps.branches), Visited(how="representatives", exhaustive=False, note=reps.describe())
    branches = list(split_branches(model, seed=seed, max_seconds=max_seconds, undecided=True))
    open_ = [b.label for b in branches if b.undecided]
    if open_:  # reported, never dropped: each is an inconclusive branch of the answer
        return branches, Visited(how="all", exhaustive=False, note=(
            f"every feasible branch ({len(branches) - len(open_)}) and {len(open_)} whose feasibility is undecided "
            f"({', '.join(open_)}: no point was found in them and none was proved impossible; not analysed)"))
    return branches, Visited(how="all", exhaustive=True,
                             note=f"every feasible branch ({len(branches)})" if len(branches) > 1 else "smooth model")


def _branch_for(model: Model, signs: Sequence[int], seed: int) -> Branch:
    """The branch of a sign pattern of a model whose branches were not all enumerated."""
    from obsnl.model.branching.representatives import branch_of_pattern

    try:
        return branch_of_pattern(model, tuple(int(s) for s in signs), seed=seed)
    except NotSupportedError as exc:
        raise AnalysisError(f"visited sign pattern {tuple(signs)}: {exc}") from None
