"""The branches of a model, found once: its switching functions, then every feasible branch or, past
:data:`ENUMERATE_UP_TO` switching functions, representative branches.

:func:`branching` is what an analysis computes at its entry
(:func:`obsnl.observability.joint.selection.select_branches`) and hands down: one :class:`Branching` value holds the switching structure
(:class:`~obsnl.model.branching.switching.Switching`), the branches with their smooth models and, where they
stand for the model's branches, the representatives. A sign pattern that was not enumerated is made from the
same structure (:meth:`Branching.pattern`), without finding the switching functions again.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from obsnl.errors import NotSupportedError
from obsnl.model.branching.branches import MAX_SWITCHING, Branch, split_by
from obsnl.model.branching.switching import Switching, switching_structure
from obsnl.model.core import Model

if TYPE_CHECKING:  # the representatives load past ENUMERATE_UP_TO switching functions or for a pattern
    from obsnl.model.branching.representatives import Representatives

__all__ = ["Branching", "branching", "ENUMERATE_UP_TO"]

#: Above this many switching functions (2**8 = 256 sign patterns) the branches are not enumerated:
#: representative branches stand for them (:mod:`obsnl.model.branching.representatives`). An enumeration of
#: 2**8 patterns of a 4-storey building takes about 17 s here, 2**10 several minutes.
ENUMERATE_UP_TO = 8


@dataclass(frozen=True)
class Branching:
    """A model's branches and what they stand for.

    Attributes
    ----------
    model
        The (non-smooth) model.
    switching
        Its outermost switching structure.
    branches
        Every feasible branch (and those whose feasibility is undecided, :attr:`Branch.undecided`), or the
        representatives' branches.
    representatives
        The representatives, where ``branches`` are theirs; None where ``branches`` are every branch.
    seed
        Seed of the feasibility search (also used by :meth:`pattern`).
    """

    model: Model
    switching: Switching
    branches: tuple[Branch, ...]
    representatives: Representatives | None
    seed: int = 0

    def pattern(self, signs: Sequence[int]) -> Branch:
        """The branch of one sign pattern of the outermost switching functions
        (:func:`obsnl.model.branching.representatives.branch_of_pattern`)."""
        from obsnl.model.branching.representatives import pattern_branch

        return pattern_branch(self.model, self.switching, tuple(int(s) for s in signs), seed=self.seed)


def branching(
    model: Model, *, seed: int = 0, max_seconds: float | None = None, enumerate_up_to: int = ENUMERATE_UP_TO
) -> Branching:
    """The branches of ``model``: every feasible one, or representatives past ``enumerate_up_to`` switching functions.

    Parameters
    ----------
    model : Model
        Any model.
    seed : int
        Seed of the feasibility search.
    max_seconds : float or None
        Time limit of an enumeration (:func:`obsnl.model.split_branches`).
    enumerate_up_to : int
        Most switching functions whose sign patterns are all enumerated; past them (and where the model's
        switching functions fall into independent groups, :mod:`obsnl.model.branching.representatives`)
        representative branches stand for them.

    Returns
    -------
    Branching

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="two", states=["x", "y"], parameters=["a", "b"],
    ...           equations={"x": "-a*sign(x)", "y": "-b*sign(y)"}, outputs={"o": "x + y"})
    >>> [b.label for b in branching(m).branches], [b.label for b in branching(m, enumerate_up_to=1).branches]
    (['a', 'b', 'c', 'd'], ['r0', 'r1', 'r2'])
    """
    level = switching_structure(model)
    if len(level.functions) > min(enumerate_up_to, MAX_SWITCHING):
        from obsnl.model.branching.representatives import representatives_of

        try:
            reps = representatives_of(model, level, seed=seed)
        except NotSupportedError:  # nested non-smooth functions: the enumeration decides (or refuses)
            reps = None
        if reps is not None:
            return Branching(model, level, reps.branches, reps, seed)
    branches = split_by(model, level, seed=seed, max_seconds=max_seconds, undecided=True)
    return Branching(model, level, branches, None, seed)
