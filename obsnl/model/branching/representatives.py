"""Representative branches of a model with many switching functions, without visiting 2^m sign patterns.

A multi-storey building with a hysteretic element per storey has two switching functions per storey
(its drift rate and its hysteretic state): ``4^n`` sign patterns, which no enumeration reaches for
``n = 10``. But each storey's pair acts only on that storey's equations. :func:`switching_groups`
finds such independent factors: two switching functions are in one group when some equation (a
state's right-hand side or an output) contains both; a group's sign pattern decides the form of the
equations it touches and of no other.

:func:`representative_branches` then takes one *base* pattern (per group, in turn, the first local
pattern in Gray-code order that is feasible together with the groups fixed before it) and, for every
group, each of its other local patterns with every other group at the base (``1 + sum(2^|g| - 1)``
patterns, ``1 + 3n`` for the building), drops the infeasible ones (exactly, by linear programming,
for affine switching functions) and merges patterns that give the same smooth field. Every branch
returned is a genuine branch of the model (its guard is feasible, its field exact).

What this allows, and what it does not (said in every answer that uses it): every verdict *within*
a representative branch is exact; the per-branch union over them is a subset of the union over all
branches; a jointly observable verdict is exact (the joint rank only grows with more visits), while
a jointly unobservable one over representatives is not a verdict over all ``2^m`` patterns and is
reported as inconclusive.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from obsnl.errors import NotSupportedError
from obsnl.model.bounds.work import can_expand
from obsnl.model.branching.branches import Branch, gray_code, sides_of, smooth_branch
from obsnl.model.branching.feasibility import feasible
from obsnl.model.branching.switching import Switching, switching_structure
from obsnl.model.core import Model

__all__ = [
    "Representatives",
    "switching_groups",
    "groups_of",
    "representative_branches",
    "representatives_of",
    "branch_of_pattern",
    "pattern_branch",
    "MAX_GROUP",
]

#: At most this many switching functions in one group (2**12 local patterns).
MAX_GROUP = 12


@dataclass(frozen=True)
class Representatives:
    """Representative branches and what they stand for.

    Attributes
    ----------
    branches
        The branches (labels ``r0`` = base, ``r1``, ...), each a genuine branch of the model.
    switching
        All switching functions, in order (the branches' ``signs`` refer to them).
    groups
        Indices of the switching functions of each independent group.
    patterns
        Number of sign patterns of the model (``2 ** len(switching)``), none enumerated.
    merged
        ``(label kept, sign pattern)`` for patterns dropped because their field equals a kept one.
    infeasible
        Sign patterns tried and proved infeasible.
    undecided
        Sign patterns tried in which no point was found and none was proved impossible (not analysed).
    """

    branches: tuple[Branch, ...]
    switching: tuple[sp.Expr, ...]
    groups: tuple[tuple[int, ...], ...]
    patterns: int
    merged: tuple[tuple[str, tuple[int, ...]], ...]
    infeasible: tuple[tuple[int, ...], ...]
    undecided: tuple[tuple[int, ...], ...] = ()

    def describe(self) -> str:
        """One sentence for an answer's notes: what was enumerated and what was argued."""
        sizes = [len(g) for g in self.groups]
        return (
            f"{len(self.switching)} switching functions in {len(self.groups)} independent groups "
            f"(sizes {sizes}); {len(self.branches)} representative branches analysed (a base pattern and "
            f"each group's other patterns in turn; {len(self.merged)} merged as equal fields, "
            f"{len(self.infeasible)} infeasible"
            f"{f', {len(self.undecided)} undecided (no point found, none proved impossible)' if self.undecided else ''}"
            f") instead of {self.patterns} sign patterns; per-branch "
            f"verdicts are exact for these branches, a jointly observable verdict is exact, a jointly "
            f"unobservable one over them is not decided"
        )


def _expanded(e: sp.Expr) -> sp.Expr:
    """``e`` expanded when that is cheap (:func:`obsnl.model.bounds.work.can_expand`), else as it is."""
    return sp.expand(e) if can_expand(e) else e


def switching_groups(model: Model) -> tuple[tuple[sp.Expr, ...], tuple[tuple[int, ...], ...]]:
    """The model's switching functions and their independent groups (module docstring).

    Parameters
    ----------
    model : Model
        A non-smooth model whose non-smooth functions are not nested.

    Returns
    -------
    (switching functions, groups)
        Groups as tuples of indices into the switching functions, in order of first appearance.

    Raises
    ------
    NotSupportedError
        Nested non-smooth functions (use :func:`obsnl.model.split_branches`).

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="two", states=["x", "y"], parameters=["a", "b"],
    ...           equations={"x": "-a*sign(x)", "y": "-b*sign(y) - Abs(y - 1)"}, outputs={"o": "x + y"})
    >>> sw, groups = switching_groups(m)
    >>> [str(g) for g in sw], groups
    (['x', 'y - 1', 'y'], ((0,), (1, 2)))
    """
    level = switching_structure(model)
    return level.functions, groups_of(level)


def groups_of(level: Switching) -> tuple[tuple[int, ...], ...]:
    """The independent groups of ``level``'s switching functions: two are in one group when some expression
    switches on both (:attr:`~obsnl.model.branching.switching.Switching.members`); in order of first appearance."""
    parent = list(range(len(level.functions)))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for idx in level.members:
        for j in idx[1:]:
            parent[find(j)] = find(idx[0])
    groups: dict[int, list[int]] = {}
    for j in range(len(parent)):
        groups.setdefault(find(j), []).append(j)
    return tuple(tuple(g) for g in sorted(groups.values(), key=lambda g: g[0]))


def representative_branches(model: Model, *, seed: int = 0) -> Representatives:
    """Representative branches of a model with independent groups of switching functions.

    Parameters
    ----------
    model : Model
        A non-smooth model without nested non-smooth functions.
    seed : int
        Seed of the witness search for non-affine switching functions.

    Returns
    -------
    Representatives

    Raises
    ------
    NotSupportedError
        Nested non-smooth functions, a group of more than :data:`MAX_GROUP` switching functions, or
        no feasible base pattern.

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="two", states=["x", "y"], parameters=["a", "b"],
    ...           equations={"x": "-a*sign(x)", "y": "-b*sign(y)"}, outputs={"o": "x + y"})
    >>> reps = representative_branches(m)
    >>> [(b.label, b.signs) for b in reps.branches], reps.patterns
    ([('r0', (1, 1)), ('r1', (-1, 1)), ('r2', (1, -1))], 4)
    """
    return representatives_of(model, switching_structure(model), seed=seed)


def representatives_of(model: Model, level: Switching, *, seed: int = 0) -> Representatives:
    """:func:`representative_branches` of ``model`` whose switching structure ``level``
    (:func:`obsnl.model.branching.switching.switching_structure`) is already found.

    Parameters
    ----------
    model : Model
        A non-smooth model without nested non-smooth functions.
    level : Switching
        Its switching structure.
    seed : int
        Seed of the witness search.

    Returns
    -------
    Representatives
    """
    rng = np.random.default_rng(seed)
    sw, groups = level.functions, groups_of(level)  # not nested: its declared functions are checked
    big = [g for g in groups if len(g) > MAX_GROUP]
    if big:
        raise NotSupportedError(
            f"{len(big[0])} switching functions act on the same equations; at most "
            f"{MAX_GROUP} per group are supported. Smooth some of them (tanh(v/eps) for sign(v))"
        )
    base = [0] * len(sw)
    fixed: list[int] = []
    for g in groups:
        for local in gray_code(len(g)):
            trial = dict(zip(g, local))
            conds = [(sw[j], base[j]) for j in fixed] + [(sw[j], trial[j]) for j in g]
            witness = feasible(conds, rng, level.memo, bounds=level.bounds)[0]
            if witness is not None:
                for j in g:
                    base[j] = trial[j]
                fixed += list(g)
                break
        else:
            raise NotSupportedError(f"no feasible sign pattern of the switching functions {[str(sw[j]) for j in g]}")
    candidates = [tuple(base)]
    for g in groups:
        for local in gray_code(len(g)):
            pattern = list(base)
            for j, s in zip(g, local):
                pattern[j] = s
            if tuple(pattern) != tuple(base):
                candidates.append(tuple(pattern))
    sides, dropped, _ = sides_of(level, candidates, rng, undecided=False)  # an undecided pattern is not analysed
    branches: list[Branch] = []
    fields: dict[tuple, str] = {}
    merged = []
    for side in sides:
        new = tuple(_expanded(e) for e in side.exprs)
        if new in fields:  # the same field as a kept pattern's (checked finite there)
            merged.append((fields[new], side.signs))
            continue
        fields[new] = f"r{len(branches)}"
        branches.append(smooth_branch(model, fields[new], sw, side.signs, new, side.witness))
    return Representatives(
        branches=tuple(branches),
        switching=sw,
        groups=groups,
        patterns=2 ** len(sw),
        merged=tuple(merged),
        infeasible=tuple(d.signs for d in dropped if d.proved),
        undecided=tuple(d.signs for d in dropped if not d.proved),
    )


def branch_of_pattern(model: Model, signs: tuple[int, ...], *, seed: int = 0, label: str | None = None) -> Branch:
    """The branch of one sign pattern of the model's (first-level) switching functions.

    Parameters
    ----------
    model : Model
        A non-smooth model without nested non-smooth functions.
    signs : tuple of int
        One sign (+1 or -1) per switching function, in the order of :func:`switching_groups`.
    seed : int
        Seed of the witness search.
    label : str or None
        The branch's label (default: the pattern as a string of ``+`` and ``-``).

    Returns
    -------
    Branch

    Raises
    ------
    NotSupportedError
        A pattern of the wrong length or an infeasible one.

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="relay", states=["x"], parameters=["s"], equations={"x": "-s*sign(x)"},
    ...           outputs={"y": "x"})
    >>> b = branch_of_pattern(m, (-1,))
    >>> b.label, dict(b.model.equations)
    ('-', {x: s})
    """
    return pattern_branch(model, switching_structure(model), signs, seed=seed, label=label)


def pattern_branch(
    model: Model, level: Switching, signs: tuple[int, ...], *, seed: int = 0, label: str | None = None
) -> Branch:
    """:func:`branch_of_pattern` of ``model`` whose switching structure ``level`` is already found.

    Parameters
    ----------
    model : Model
        The model, ``level`` its switching structure.
    level : Switching
        Its functions are those ``signs`` give a sign to, in order.
    signs : tuple of int
        The pattern; ``seed`` and ``label`` as for :func:`branch_of_pattern`.
    seed : int
        Seed of the witness search.
    label : str or None
        The branch's label (None: ``+`` and ``-`` for the signs).
    """
    sw = level.functions
    if level.nested:
        raise NotSupportedError("nested non-smooth functions: use obsnl.model.split_branches")
    if len(signs) != len(sw) or any(s not in (1, -1) for s in signs):
        raise NotSupportedError(f"a sign pattern needs {len(sw)} signs of +1 or -1, got {signs!r}")
    sides, dropped, _ = sides_of(level, [tuple(signs)], np.random.default_rng(seed), undecided=False)
    if dropped:
        raise NotSupportedError(f"the sign pattern {signs} is infeasible ({dropped[0].reason})")
    label = label or "".join("+" if s > 0 else "-" for s in signs)
    return smooth_branch(model, label, sw, signs, [_expanded(e) for e in sides[0].exprs], sides[0].witness)
