"""Where the vector field of a non-smooth model jumps: for each switching function, whether the smooth fields
on its two sides may differ on the surface (the discrete steps of :mod:`obsnl.estimation.numeric` refine only
the crossings where it does).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import sympy as sp

from obsnl.errors import ModelError, NotSupportedError
from obsnl.model.bounds.work import can_expand, can_factor, same_up_to_sign
from obsnl.model.branching.branches import Branch, split_branches
from obsnl.model.core import Model

__all__ = ["field_jumps"]

#: Above this many switching functions :func:`field_jumps` does not split the model (all may jump).
_MAX_JUMP_CHECK = 6


def field_jumps(model: Model, switching: Sequence[sp.Expr]) -> tuple[bool, ...]:
    """For each switching function ``g``: may the vector field jump where ``g`` crosses 0?

    ``False`` only when it is proved continuous there: for every two branches whose sign patterns
    differ in ``g`` alone, the difference of their vector fields vanishes identically on ``g = 0``
    (``g`` solved for one of its states or parameters, then cancelled). Anything not proved, a
    nested split, a switching function that cannot be solved, or a model with more than
    ``_MAX_JUMP_CHECK`` switching functions (the check splits the model), counts as a jump. Used by the
    discrete steps to refine only the substeps where the field really jumps (for the seed model
    ``r - eta'``, where the healing term switches, but not ``x2``, where every switched term
    carries a factor ``x2``).

    Parameters
    ----------
    model : Model
        The non-smooth model.
    switching : sequence of sympy.Expr
        Switching functions (the model's own, or a branch table's), in any orientation.

    Returns
    -------
    tuple of bool
        One per switching function: True where the field may jump.
    """
    switching = list(switching)
    if len(switching) > _MAX_JUMP_CHECK:
        return (True,) * len(switching)
    try:
        branches = split_branches(model)
    except (ModelError, NotSupportedError):
        return (True,) * len(switching)
    if len(branches) < 2 or any(b.switching != branches[0].switching for b in branches):
        return (True,) * len(switching)
    sw = list(branches[0].switching)
    by_signs = {b.signs: b for b in branches}
    out = []
    for g in switching:
        j = next((i for i, s in enumerate(sw) if same_up_to_sign(s, g)), None)
        out.append(True if j is None else not _continuous_across(g, j, by_signs, model))
    return tuple(out)


def _continuous_across(g: sp.Expr, j: int, by_signs: Mapping[tuple[int, ...], Branch], model: Model) -> bool:
    """Whether the branch fields on the two sides of ``g = 0`` (``g`` the ``j``-th switching
    function) agree identically on ``g = 0`` for every pair of neighbouring branches."""
    sol = None
    if not can_factor(g):  # solving it could run for minutes: not proved continuous, counted as a jump
        return False
    for s in [s for s in list(model.states) + list(model.parameters) if s in g.free_symbols]:
        try:
            roots = sp.solve(g, s)
        except NotImplementedError:  # pragma: no cover - sympy cannot solve it
            continue
        if len(roots) == 1:
            sol = (s, roots[0])
            break
    if sol is None:
        return False
    pairs = 0
    for signs, b in by_signs.items():
        other = by_signs.get(signs[:j] + (-1,) + signs[j + 1:]) if signs[j] > 0 else None
        if other is None:
            continue
        pairs += 1
        for fa, fb in zip(b.model.rhs, other.model.rhs):
            if not can_expand(fa - fb) or sp.cancel(sp.together((fa - fb).subs(*sol))) != 0:
                return False
    return pairs > 0
