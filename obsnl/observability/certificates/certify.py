"""Certificates of jointly unobservable verdicts, and what a verdict over some branches does not decide.

:func:`undecided_beyond_visits`: over representative branches (not every branch), a jointly
unobservable variable is not decided for the model. :func:`certify_by_symmetry`: certificates of
jointly unobservable variables by symmetries shared by every visited branch.

A Lie symmetry of one branch (:func:`obsnl.observability.certificates.symmetry.symmetries`, verified symbolically)
that is verified symbolically in every other visited branch too
(:func:`obsnl.observability.certificates.proofs.verify_generator`) and that keeps every switching surface in place
(a scaling under which the switching function is weighted homogeneous, or a field ``X`` with
``X(g) = c g``) maps trajectories of the switched system to trajectories with the same output, crossing
the same surfaces at the same instants: every variable it moves is jointly unobservable, whatever the
visits could not evaluate (a surface on which the field is singular, e.g. ``|g|**N`` with ``N``
unknown). This certifies verdicts that the rank computation left undecided.

With representative branches (:mod:`obsnl.model.branching.representatives`) only scalings and translations
count: their proof is equation by equation (each equation weighted homogeneous, or unchanged by the
shift), every equation of any branch depends on one group's signs only, and every form it takes in
a feasible branch occurs in some representative branch, so the proof holds in every branch.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import sympy as sp

from obsnl.errors import ObsnlError
from obsnl.model.bounds.work import can_expand
from obsnl.model.branching.branches import Branch
from obsnl.model.core import Model
from obsnl.observability.certificates.generators import Symmetry
from obsnl.observability.certificates.proofs import ANY, is_zero, verify_generator, weight
from obsnl.observability.certificates.symmetry import symmetries_of
from obsnl.observability.joint.result import JointResult

__all__ = ["shared_symmetries", "certify_by_symmetry", "undecided_beyond_visits"]


def _keeps_surface(gen: Symmetry, comp: dict[sp.Symbol, sp.Expr], g: sp.Expr) -> bool:
    if gen.kind == "scaling":
        ws = {s: sp.cancel(c / s) for s, c in comp.items()}
        return weight(g, ws) is not None or weight(g, ws) is ANY
    xg = sum(c * sp.diff(g, s) for s, c in comp.items())
    if xg == 0:
        return True
    if not (can_expand(xg) and can_expand(g)):  # too large to decide cheaply: not proved to keep it
        return False
    xg = sp.expand(xg)
    if is_zero(xg):
        return True
    ratio = sp.cancel(xg / g)
    return not sp.fraction(ratio)[1].free_symbols


def shared_symmetries(
    model: Model, branches: Sequence[Branch], *, seed: int = 0, kinds: Sequence[str] | None = None
) -> tuple[Symmetry, ...]:
    """Generators found in the first branch that are symmetries of every branch and keep every surface.

    The search does not check the model's limits again
    (:func:`~obsnl.observability.certificates.symmetry.symmetries_of`): its callers have, :func:`obsnl.analyze` before
    it chose the branches, the sensor search in the analyses that found the targets hidden.

    Parameters
    ----------
    model : Model
        The non-smooth model (its switching functions are the surfaces).
    branches : sequence of Branch
        The visited branches (at least one).
    seed : int
        Seed of the symmetry search.
    kinds : sequence of str or None
        Kinds of generators allowed (default: every kind).

    Returns
    -------
    tuple of Symmetry
        Each verified symbolically in every branch, each keeping every switching surface in place.

    Examples
    --------
    >>> from obsnl import Model
    >>> from obsnl.model import split_branches
    >>> m = Model(name="friction", states=["x", "v"], parameters=["m", "c", "k", "F"], inputs=["ag"],
    ...           equations={"x": "v", "v": "-ag - (c*v + k*x + F*sign(v))/m"}, outputs={"y": "x"})
    >>> [str(s) for s in shared_symmetries(m, split_branches(m))]
    ['m*d/dm + c*d/dc + k*d/dk + F*d/dF']
    """
    if not branches:
        return ()
    syms = model.symbols
    surfaces = list(branches[0].switching)
    try:
        found = symmetries_of(branches[0].model, seed=seed)
    except ObsnlError:
        return ()
    out = []
    for gen in found.generators:
        if kinds is not None and gen.kind not in kinds:
            continue
        comp = {syms[k]: v for k, v in gen.components.items() if k in syms}
        if len(comp) != len(gen.components):
            continue
        if not all(verify_generator(b.model, gen.kind, comp) for b in branches[1:]):
            continue
        if not all(_keeps_surface(gen, comp, g) for g in surfaces):
            continue
        out.append(gen)
    return tuple(out)


def certify_by_symmetry(
    result: JointResult, model: Model, branches: Sequence[Branch], *, seed: int = 0, kinds: Sequence[str] | None = None
) -> JointResult:
    """Move the variables that a shared symmetry moves from ``inconclusive`` to ``unobservable``.

    Parameters
    ----------
    result : JointResult
        A joint verdict with undecided variables.
    model : Model
        The model.
    branches : sequence of Branch
        The visited branches.
    seed : int
        Seed of the symmetry search.
    kinds : sequence of str or None
        Kinds of generators allowed (``("scaling", "translation")`` for representative branches).

    Returns
    -------
    JointResult
        With the certified variables unobservable and the certificate named in ``assumptions``.
    """
    if not result.inconclusive:
        return result
    gens = shared_symmetries(model, branches, seed=seed, kinds=kinds)
    moved = {k for gen in gens for k, v in gen.components.items() if v != 0}
    certified = [v for v in result.inconclusive if v in moved]
    if not certified:
        return result
    left = tuple(v for v in result.inconclusive if v not in moved)
    order = list(result.observable) + list(result.unobservable) + list(result.inconclusive)
    unobs = set(result.unobservable) | set(certified)
    names = [s.name for s in model.states] + [p.name for p in model.parameters]
    certificates = tuple(str(g) for g in gens)
    assumptions = (
        None if result.assumptions is None else replace(result.assumptions, symmetry_certificates=certificates)
    )
    reason = result.reason if left else ""
    return replace(
        result,
        unobservable=tuple(v for v in names if v in unobs) + tuple(v for v in order if v in unobs and v not in names),
        inconclusive=left,
        reason=reason,
        assumptions=assumptions,
    )


def undecided_beyond_visits(result: JointResult, why: str) -> JointResult:
    """The verdict over branches that are not every branch of the model: a jointly unobservable
    variable there is not decided for the model (other branches might reveal it), so it moves to
    ``inconclusive`` with ``why``; observable verdicts stand (the joint rank only grows with visits).

    Parameters
    ----------
    result : JointResult
        A joint verdict over some of the model's branches.
    why : str
        How the branches were chosen (said in the reason).

    Returns
    -------
    JointResult
    """
    if not result.unobservable:
        return result
    reason = (
        f"unobservable over the visited branches only ({why}); other sign patterns were not visited, "
        f"so {', '.join(result.unobservable)} are not decided for the model"
    )
    pending = set(result.unobservable) | set(result.inconclusive)
    order = list(result.observable) + list(result.unobservable) + list(result.inconclusive)
    return replace(
        result,
        unobservable=(),
        inconclusive=tuple(v for v in order if v in pending),
        reason="; ".join(r for r in (result.reason, reason) if r),
    )
