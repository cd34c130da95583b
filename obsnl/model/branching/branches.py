"""Split a non-smooth model into smooth branches (Chatzis et al., as in the seed paper §3.1).

A *switching function* is the argument of ``sign``/``Abs``/``Heaviside``, the difference of the
two sides of a ``Piecewise`` condition, or a pairwise difference of ``Max``/``Min`` arguments.
Each is factored; the sign of a product or power follows from its factors, so
``sign((sigma - eta)*x2)`` adds no switching function beyond ``sigma - eta`` and ``x2``.
A branch fixes the sign of every switching function; inside it every non-smooth function is
replaced by its analytic extension (``sign(g) -> ±1``, ``Abs(g) -> ±g``, ...). Sign patterns that
no point satisfies are dropped (exactly by linear programming when the switching functions are
affine, by a search for a witness point otherwise). Nested non-smooth functions are resolved
level by level.

Branches are ordered in reflected Gray-code order over the switching functions (neighbours differ
across one switching surface); for the seed model this is the paper's order (a)-(d).
"""

from __future__ import annotations

import copy
import dataclasses
import string
import time
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Literal, NamedTuple, overload

import numpy as np
import sympy as sp

from obsnl.errors import AnalysisError, ModelError, NotSupportedError
from obsnl.model.bounds.budget import check_time
from obsnl.model.branching.feasibility import feasible
from obsnl.model.branching.switching import (
    Switching,
    check_declared,
    expr_text,
    switching_functions,
    switching_structure,
)
from obsnl.model.core import Model
from obsnl.model.reading.parse import shorten

__all__ = [
    "Branch",
    "DroppedPattern",
    "Side",
    "split_branches",
    "split_by",
    "sides_of",
    "smooth_branch",
    "switching_functions",
    "check_finite",
    "gray_code",
    "MAX_SWITCHING",
]

#: Most switching functions in all (nested ones included) whose sign patterns are enumerated: 2**12 at most.
MAX_SWITCHING = 12
_MAX_BRANCHES = 1024  # smooth branches in all
_FIELDS = {f.name for f in dataclasses.fields(Model)}


@dataclass(frozen=True)
class Branch:
    """One smooth branch of a model.

    Attributes
    ----------
    label
        Short label: ``"a"``, ``"b"``, ... in Gray-code order (``"smooth"`` for a smooth model).
    switching
        The switching functions, in order.
    signs
        The sign (+1 or -1) of each switching function in this branch.
    model
        The smooth model valid in this branch (no sign/Abs/Heaviside/Piecewise/Max/Min left).
    witness
        A point (name -> value) inside the branch, found while checking feasibility (empty when undecided).
    undecided
        Empty for a branch with a witness; else why its feasibility is not decided (no point was found and
        none was proved impossible): such a branch is returned only on request
        (``split_branches(..., undecided=True)``), and :func:`obsnl.analyze` reports it as inconclusive.
    """

    label: str
    switching: tuple[sp.Expr, ...]
    signs: tuple[int, ...]
    model: Model
    witness: Mapping[str, float] = field(default_factory=dict, compare=False)
    undecided: str = field(default="", compare=False)

    @property
    def relations(self) -> tuple[sp.Rel, ...]:
        """The guard as sympy relations, e.g. ``(sigma - eta > 0, x2 < 0)``."""
        return tuple(
            sp.StrictGreaterThan(g, 0) if s > 0 else sp.StrictLessThan(g, 0) for g, s in zip(self.switching, self.signs)
        )

    @property
    def guard(self) -> sp.Basic:
        """The guard as one sympy boolean over the model's symbols (``True`` for a smooth model)."""
        return sp.And(*self.relations) if self.switching else sp.true

    @property
    def guard_text(self) -> str:
        """The guard as text that sympy reads back, e.g. ``"(sigma - eta > 0) & (x2 < 0)"``.

        ``"true"`` for a smooth model; a single relation has no parentheses (``"v > 0"``).
        """
        if not self.switching:
            return "true"
        rels = [f"{expr_text(g)} {'>' if s > 0 else '<'} 0" for g, s in zip(self.switching, self.signs)]
        return rels[0] if len(rels) == 1 else " & ".join(f"({r})" for r in rels)

    def contains(self, point: Mapping[str, float]) -> bool:
        """True when ``point`` (name -> value) lies strictly inside this branch."""
        for g, s in zip(self.switching, self.signs):
            val = float(g.xreplace({sym: point[sym.name] for sym in g.free_symbols}))
            if not s * val > 0:
                return False
        return True


@dataclass(frozen=True)
class DroppedPattern:
    """A sign pattern with no point in it (why it was dropped); ``proved`` False: no point was found but
    none was proved impossible either (the pattern is undecided, see :attr:`Branch.undecided`)."""

    switching: tuple[sp.Expr, ...]
    signs: tuple[int, ...]
    reason: str
    proved: bool = True


def gray_code(k: int) -> list[tuple[int, ...]]:
    """The sign patterns of ``k`` switching functions in reflected Gray-code order.

    Neighbouring patterns differ in one sign (across one switching surface); the all-positive pattern is
    first and the first function's sign changes slowest.

    Parameters
    ----------
    k : int
        The number of switching functions (0 or more).

    Returns
    -------
    list[tuple[int, ...]]
        All ``2**k`` patterns, each a tuple of ``k`` signs (+1 or -1).

    Examples
    --------
    >>> gray_code(2)
    [(1, 1), (1, -1), (-1, -1), (-1, 1)]
    >>> gray_code(0)
    [()]
    """
    out = []
    for i in range(2**k):
        g = i ^ (i >> 1)
        out.append(tuple(-1 if (g >> (k - 1 - j)) & 1 else 1 for j in range(k)))
    return out


# --------------------------------------------------------------------------- splitting
def derived_model(base: Model, **changes: Any) -> Model:
    """``base.replace(**changes)`` for changes made of ``base``'s own validated parts, without re-parsing.

    :meth:`Model.replace` validates every expression again, and validation prints each one (about
    15 ms per branch of the seed model, as much as analysing the branch). The models derived here
    only substitute signs into ``base``'s expressions (branches) or keep subsets of its names and
    expressions (blocks of :mod:`obsnl.observability.engines.decompose`): the symbols are ``base``'s own and no
    non-smooth function or undeclared name can appear, so re-validation cannot fail. Mappings are
    keyed like the validated model's (``equations`` and ``initial_condition_values`` by symbol,
    ``outputs`` by name) and frozen the same way; tests compare every field with ``replace``.
    """
    new = copy.copy(base)
    for key, value in changes.items():
        if key not in _FIELDS:
            raise TypeError(f"derived_model: unknown field {key!r}")
        if isinstance(value, Mapping):
            value = MappingProxyType(dict(value))
        elif isinstance(value, list):
            value = tuple(value)
        object.__setattr__(new, key, value)
    return new


def _labels(n: int) -> list[str]:
    """``a, ..., z, aa, ..., az, ba, ..., zz, aaa, ...`` (bijective base 26: a label for any count)."""
    out = []
    for i in range(n):
        k, label = i + 1, ""
        while k:
            k, r = divmod(k - 1, 26)
            label = string.ascii_lowercase[r] + label
        out.append(label)
    return out


@overload
def split_branches(
    model: Model,
    *,
    seed: int = ...,
    with_dropped: Literal[False] = ...,
    max_seconds: float | None = ...,
    undecided: bool = ...,
) -> tuple[Branch, ...]: ...


@overload
def split_branches(
    model: Model,
    *,
    seed: int = ...,
    with_dropped: Literal[True],
    max_seconds: float | None = ...,
    undecided: bool = ...,
) -> tuple[tuple[Branch, ...], tuple[DroppedPattern, ...]]: ...


@overload
def split_branches(
    model: Model,
    *,
    seed: int = ...,
    with_dropped: bool,
    max_seconds: float | None = ...,
    undecided: bool = ...,
) -> tuple[Branch, ...] | tuple[tuple[Branch, ...], tuple[DroppedPattern, ...]]: ...


def split_branches(
    model: Model,
    *,
    seed: int = 0,
    with_dropped: bool = False,
    max_seconds: float | None = None,
    undecided: bool = False,
) -> tuple[Branch, ...] | tuple[tuple[Branch, ...], tuple[DroppedPattern, ...]]:
    """Split ``model`` into its smooth branches.

    Parameters
    ----------
    model : Model
        Any model; a smooth one gives a single branch labelled ``"smooth"``.
    seed : int
        Seed of the witness search used for non-affine switching functions.
    with_dropped : bool
        Also return the sign patterns dropped as contradictory (and, without ``undecided``, those whose
        feasibility is undecided, with ``proved=False``).
    max_seconds : float or None
        Time limit of the split (None: none; a budget of :func:`obsnl.model.bounds.budget.time_budget` holds too).
    undecided : bool
        Also return the branches whose feasibility is not decided (:attr:`Branch.undecided`: no point was
        found in them, none was proved impossible). Labels count them either way, so that a label names
        the same branch with and without them.

    Returns
    -------
    tuple[Branch, ...] or (tuple[Branch, ...], tuple[DroppedPattern, ...])

    Raises
    ------
    NotSupportedError
        More than 12 switching functions in all (nested ones included), more than 1024 branches, or
        an unsupported Piecewise condition.
    AnalysisError
        The split took longer than ``max_seconds``.

    References
    ----------
    .. [1] M. N. Chatzis, E. N. Chatzi and A. W. Smyth, "On the observability and identifiability of nonlinear
       structural and mechanical systems", Structural Control and Health Monitoring 22(3), 574-593, 2015.
       doi:10.1002/stc.1690

    Examples
    --------
    >>> from obsnl import Model
    >>> from obsnl.model import split_branches
    >>> m = Model(name="coulomb", states=["x", "v"], parameters=["k", "mu"], inputs=["u"],
    ...           equations={"x": "v", "v": "u - k*x - mu*sign(v)"}, outputs={"y": "x"})
    >>> [(b.label, b.guard_text) for b in split_branches(m)]
    [('a', 'v > 0'), ('b', 'v < 0')]
    """
    if not isinstance(model, Model):  # an AttributeError deep in the split otherwise
        raise ModelError(
            f"split_branches takes an obsnl Model, got {type(model).__name__}; read a file with obsnl.read_model"
        )
    return split_by(
        model,
        switching_structure(model),
        seed=seed,
        with_dropped=with_dropped,
        max_seconds=max_seconds,
        undecided=undecided,
    )


@overload
def split_by(
    model: Model,
    level: Switching,
    *,
    seed: int = ...,
    with_dropped: Literal[False] = ...,
    max_seconds: float | None = ...,
    undecided: bool = ...,
) -> tuple[Branch, ...]: ...


@overload
def split_by(
    model: Model,
    level: Switching,
    *,
    seed: int = ...,
    with_dropped: Literal[True],
    max_seconds: float | None = ...,
    undecided: bool = ...,
) -> tuple[tuple[Branch, ...], tuple[DroppedPattern, ...]]: ...


@overload
def split_by(
    model: Model,
    level: Switching,
    *,
    seed: int = ...,
    with_dropped: bool,
    max_seconds: float | None = ...,
    undecided: bool = ...,
) -> tuple[Branch, ...] | tuple[tuple[Branch, ...], tuple[DroppedPattern, ...]]: ...


def split_by(
    model: Model,
    level: Switching,
    *,
    seed: int = 0,
    with_dropped: bool = False,
    max_seconds: float | None = None,
    undecided: bool = False,
) -> tuple[Branch, ...] | tuple[tuple[Branch, ...], tuple[DroppedPattern, ...]]:
    """:func:`split_branches` of ``model`` whose outermost switching structure ``level``
    (:func:`obsnl.model.branching.switching.switching_structure`, which checks a flat model's declared switching
    functions) is already found.

    Parameters
    ----------
    model : Model
        Any model.
    level : Switching
        Its outermost switching structure.
    seed : int
        Seed of the witness search.
    with_dropped, undecided : bool
        As in :func:`split_branches`.
    max_seconds : float or None
        Time limit of the split.

    Returns
    -------
    tuple[Branch, ...] or (tuple[Branch, ...], tuple[DroppedPattern, ...])
    """
    if not level.nodes:
        branches = (Branch("smooth", (), (), derived_model(model, switching=()), {}),)
        return (branches, ()) if with_dropped else branches
    deadline = None if max_seconds is None else time.perf_counter() + float(max_seconds)
    found, dropped, seen = sides_of(level, None, np.random.default_rng(seed), deadline=deadline)
    smooth: list[Branch] = []
    for label, side in zip(_labels(len(found)), found):
        if side.undecided and not undecided:
            dropped.append(DroppedPattern(side.switching, side.signs, side.undecided, proved=False))
            continue
        smooth.append(
            smooth_branch(model, label, side.switching, side.signs, side.exprs, side.witness, undecided=side.undecided)
        )
    if level.nested:  # the declared functions may switch at an inner level only (a flat model's are checked)
        check_declared(model, seen)
    result = tuple(smooth)
    return (result, tuple(dropped)) if with_dropped else result


class Side(NamedTuple):
    """One side of the switching surfaces that a sign pattern holds on, with its smooth field."""

    switching: tuple[sp.Expr, ...]  # every level's switching functions
    signs: tuple[int, ...]
    exprs: list[sp.Expr]  # the smooth right-hand sides, then outputs
    witness: dict[str, float]
    undecided: str  # why its feasibility is not decided ("" when a witness was found)


def sides_of(
    level: Switching,
    patterns: Iterable[tuple[int, ...]] | None,
    rng: np.random.Generator,
    *,
    deadline: float | None = None,
    undecided: bool = True,
) -> tuple[list[Side], list[DroppedPattern], tuple[sp.Expr, ...]]:
    """The sides of ``level``'s sign ``patterns`` (None: every pattern, in Gray-code order), nested non-smooth
    functions resolved level by level; the patterns with no point (with those whose feasibility is undecided,
    ``proved=False``, unless ``undecided``: then such a side is kept, marked); every level's switching functions.

    Parameters
    ----------
    level : Switching
        The outermost switching structure.
    patterns : iterable of tuple of int or None
        Sign patterns of ``level``'s functions (None: all of them).
    rng : numpy.random.Generator
        Random source of the witness search.
    deadline : float or None
        A ``time.perf_counter()`` time past which the split stops.
    undecided : bool
        Keep the sides whose feasibility is undecided (marked), or drop them.

    Raises
    ------
    NotSupportedError
        Every pattern of more than 12 switching functions in all, or more than 1024 sides of them.
    AnalysisError
        Past ``deadline`` (or a :func:`obsnl.model.bounds.budget.time_budget`).
    """
    found: list[Side] = []
    dropped: list[DroppedPattern] = []
    seen: dict = {}
    _split_level(level, (), (), ({}, ""), rng, found, dropped, seen, deadline, undecided, patterns)
    return found, dropped, tuple(seen)


def _split_level(
    level: Switching,
    outer_sw: tuple[sp.Expr, ...],
    outer_signs: tuple[int, ...],
    witness: tuple[dict[str, float], str],
    rng: np.random.Generator,
    found: list[Side],
    dropped: list[DroppedPattern],
    seen: dict,
    deadline: float | None,
    undecided: bool,
    patterns: Iterable[tuple[int, ...]] | None = None,
) -> None:
    """Split one nesting level; ``witness`` is the outer pattern's (point, why undecided), a leaf's is its own;
    ``seen`` collects every level's switching functions, in order."""
    if not level.nodes:
        found.append(Side(outer_sw, outer_signs, list(level.exprs), *witness))
        return
    sw = level.functions
    seen.update(dict.fromkeys(sw))
    if patterns is None and len(outer_sw) + len(sw) > MAX_SWITCHING:
        n = len(outer_sw) + len(sw)
        raise NotSupportedError(
            f"{n} switching functions{' (nested ones included)' if outer_sw else ''} ({2**n} sign patterns); "
            f"at most {MAX_SWITCHING} are supported. Smooth some of them (e.g. tanh(v/eps) for sign(v))"
        )
    for signs in gray_code(len(sw)) if patterns is None else patterns:
        if deadline is not None and time.perf_counter() > deadline:
            raise AnalysisError(
                "splitting the model into branches ran past the time limit; raise max_seconds= "
                "or smooth some switching functions"
            )
        check_time("splitting the model into branches", "raise max_seconds= or smooth some switching functions")
        if patterns is None and len(found) >= _MAX_BRANCHES:  # an enumeration (patterns asked for are all made)
            raise NotSupportedError(
                f"the model has more than {_MAX_BRANCHES} smooth branches; smooth some "
                f"switching functions (e.g. tanh(v/eps) for sign(v))"
            )
        all_sw = outer_sw + sw
        all_signs = outer_signs + tuple(signs)
        point, reason, proved = feasible(list(zip(all_sw, all_signs)), rng, level.memo, bounds=level.bounds)
        if point is None and (proved or not undecided):
            dropped.append(DroppedPattern(all_sw, all_signs, reason, proved))
            continue
        inner = Switching.of(level.field_at(signs), level.declared, level.memo, level.bounds)
        # undecided (no point found, none proved impossible): kept, marked, and decided again one level down
        _split_level(
            inner,
            all_sw,
            all_signs,
            (point or {}, reason if point is None else ""),
            rng,
            found,
            dropped,
            seen,
            deadline,
            undecided,
        )


def smooth_branch(
    model: Model,
    label: str,
    switching: Sequence[sp.Expr],
    signs: Sequence[int],
    exprs: Sequence[sp.Expr],
    witness: Mapping[str, float],
    *,
    undecided: str = "",
) -> Branch:
    """The branch of ``model`` where ``switching`` have ``signs``, ``exprs`` being its smooth right-hand sides, then
    its outputs; a branch whose feasibility is decided is refused where it divides by zero (:func:`check_finite`).

    Parameters
    ----------
    model : Model
        The non-smooth model.
    label : str
        The branch's label.
    switching, signs : sequence
        The switching functions and their signs in the branch.
    exprs : sequence of sympy.Expr
        The branch's smooth right-hand sides, then its outputs (in the model's order).
    witness : mapping of str to float
        A point inside the branch (empty when undecided).
    undecided : str
        Why its feasibility is not decided ("" when it is).

    Returns
    -------
    Branch
    """
    if not undecided:  # an undecided branch is not analysed: a division by zero there may be in no point at all
        check_finite(model, exprs, switching, signs)
    n_rhs = len(model.states)
    sub = derived_model(
        model,
        name=f"{model.name}[{label}]",
        equations=dict(zip(model.states, exprs[:n_rhs])),
        outputs=dict(zip(model.output_names, exprs[n_rhs:])),
        switching=(),
    )
    return Branch(label, tuple(switching), tuple(signs), sub, witness, undecided=undecided)


def check_finite(model: Model, exprs: Sequence[sp.Expr], switching: Sequence[sp.Expr], signs: Sequence[int]) -> None:
    """Refuse a branch where an equation or output divides by zero (``1/(1 - sign(v))`` where ``v > 0``).

    Parameters
    ----------
    model : Model
        The non-smooth model.
    exprs : sequence of sympy.Expr
        The branch's right-hand sides, then its outputs (in the model's order).
    switching, signs : sequence
        The switching functions and their signs in the branch.

    Raises
    ------
    ModelError
        Naming the equation or output as the user wrote it, the branch and the fix.
    """
    bad = (sp.zoo, sp.nan, sp.oo, -sp.oo)
    names = [f"the equation of {s}" for s in model.states] + [f"output {y}" for y in model.output_names]
    for name, before, after in zip(names, list(model.rhs) + list(model.output_exprs), exprs):
        if after.has(*bad):
            where = " and ".join(f"{expr_text(g)} {'>' if s > 0 else '<'} 0" for g, s in zip(switching, signs))
            raise ModelError(
                f"{name}, {shorten(str(before))!r}, divides by zero where {where}; rewrite it so that "
                f"it is finite on both sides of every switching surface"
            )
