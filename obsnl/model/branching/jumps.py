"""Where the vector field of a non-smooth model jumps: for each switching function, whether the smooth fields
on its two sides may differ on the surface (the discrete steps of :mod:`obsnl.estimation.numeric` refine only
the crossings where it does), and whether the jump may have a component across the surface, the only kind
that can hold a trajectory on it (a sliding mode in Filippov's sense: a mass that sticks under dry friction),
which the located substep of :mod:`obsnl.estimation.crossing` then resolves; and for each output, whether it may
jump where the field does. :func:`discontinuities` answers the three in one pass over one split of the model.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import sympy as sp

from obsnl.errors import ModelError, NotSupportedError
from obsnl.model.bounds.work import can_expand, can_factor, same_up_to_sign
from obsnl.model.branching.branches import Branch, split_branches
from obsnl.model.core import Model

__all__ = ["Discontinuities", "discontinuities", "field_jumps", "field_slides", "output_jumps"]

#: ``differences(g, a, b, states)``: the expressions to prove zero on ``g = 0`` between two neighbouring branches'
#: models ``a`` and ``b``.
_Differences = Callable[[sp.Expr, Model, Model, Sequence[sp.Symbol]], list[sp.Expr]]

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
    return discontinuities(model, switching).jumps


def field_slides(model: Model, switching: Sequence[sp.Expr]) -> tuple[bool, ...]:
    """For each switching function ``g``: may a trajectory slide along ``g = 0``?

    A sliding mode needs the fields of the two sides to push towards the surface from both sides, so
    their jump must have a component along ``grad g`` (the states' gradient). ``False`` only when it is
    proved that ``grad g . (f_a - f_b)`` vanishes identically on ``g = 0`` for every two branches that
    differ in ``g`` alone (the jump, if any, is tangential: every crossing is transversal or grazing);
    anything not proved counts as may slide, as in :func:`field_jumps`.

    Parameters
    ----------
    model : Model
        The non-smooth model.
    switching : sequence of sympy.Expr
        Switching functions (the model's own, or a branch table's), in any orientation.

    Returns
    -------
    tuple of bool
        One per switching function: True where a sliding mode may form.

    Examples
    --------
    Coulomb friction may hold the mass at ``v = 0`` (the jump ``-2 F_c`` is along ``v``); a switch of
    the field's first row alone (``x' = |v|``-like) jumps along the surface only:

    >>> from obsnl.model.core import Model
    >>> from obsnl.model.branching.switching import switching_functions
    >>> m = Model(name="dry", states=["x", "v"], parameters=["k", "F"], inputs=["u"],
    ...           equations={"x": "v", "v": "u - k*x - F*sign(v)"}, outputs={"y": "x"})
    >>> field_slides(m, switching_functions(m))
    (True,)
    >>> m2 = Model(name="tangent", states=["x", "v"], parameters=["k", "F"], inputs=["u"],
    ...            equations={"x": "v + F*sign(v)", "v": "u - k*x"}, outputs={"y": "x"})
    >>> g = switching_functions(m2)
    >>> field_jumps(m2, g), field_slides(m2, g)
    ((True,), (False,))
    """
    return discontinuities(model, switching).slides


def output_jumps(model: Model, switching: Sequence[sp.Expr]) -> tuple[bool, ...]:
    """For each output: may it jump where a switching function across which the field jumps crosses 0?

    As :func:`field_jumps`, with the outputs in place of the field: an output is continuous across ``g = 0`` when
    the outputs of every two branches that differ in ``g`` alone agree on the surface. An accelerometer on a mass
    with Coulomb friction jumps with the friction force; a displacement sensor does not. The likelihood fit leaves
    out the samples of a jumping output next to such a crossing (:func:`obsnl.identification.refine.refine`): its
    value there hangs on the crossing's time to within a sample.

    Parameters
    ----------
    model : Model
        The non-smooth model.
    switching : sequence of sympy.Expr
        Switching functions, in any orientation.

    Returns
    -------
    tuple of bool
        One per output (in ``model.outputs`` order): True where it may jump.

    Examples
    --------
    >>> from obsnl.model.core import Model
    >>> from obsnl.model.branching.switching import switching_functions
    >>> m = Model(name="dry", states=["x", "v"], parameters=["k", "F"], inputs=["u"],
    ...           equations={"x": "v", "v": "u - k*x - F*sign(v)"}, outputs={"y": "x", "a": "u - k*x - F*sign(v)"})
    >>> output_jumps(m, switching_functions(m))
    (False, True)
    """
    return discontinuities(model, switching).output_jumps


@dataclass(frozen=True)
class Discontinuities:
    """Where a model's vector field and outputs may jump, proved in one pass (:func:`discontinuities`).

    Attributes
    ----------
    jumps : tuple of bool
        Per switching function: the field may jump where it crosses 0 (:func:`field_jumps`).
    slides : tuple of bool
        Per switching function: a trajectory may slide along its surface (:func:`field_slides`).
    output_jumps : tuple of bool
        Per output, in ``model.outputs`` order: it may jump where the field does (:func:`output_jumps`).
    """

    jumps: tuple[bool, ...]
    slides: tuple[bool, ...]
    output_jumps: tuple[bool, ...]


def discontinuities(model: Model, switching: Sequence[sp.Expr]) -> Discontinuities:
    """Where the field and the outputs of ``model`` may jump across ``switching``: one split of the model, each
    switching function solved once, and every neighbouring pair of branches compared once for all three questions
    (:func:`field_jumps`, :func:`field_slides`, :func:`output_jumps` read their answer from here).

    Parameters
    ----------
    model : Model
        The non-smooth model.
    switching : sequence of sympy.Expr
        Switching functions (the model's own, or a branch table's), in any orientation.

    Returns
    -------
    Discontinuities
        What is not proved continuous counts as may jump (a model that cannot be split, a nested split, more than
        ``_MAX_JUMP_CHECK`` switching functions, a switching function that cannot be solved).

    Examples
    --------
    >>> from obsnl.model.core import Model
    >>> from obsnl.model.branching.switching import switching_functions
    >>> m = Model(name="dry", states=["x", "v"], parameters=["k", "F"], inputs=["u"],
    ...           equations={"x": "v", "v": "u - k*x - F*sign(v)"}, outputs={"y": "x", "a": "u - k*x - F*sign(v)"})
    >>> discontinuities(m, switching_functions(m))
    Discontinuities(jumps=(True,), slides=(True,), output_jumps=(False, True))
    """
    switching = list(switching)
    kinds: list[_Differences] = [_jump, _normal_jump] + [_output_difference(o) for o in model.outputs]
    unproved = [[True] * len(switching) for _ in kinds]  # per kind, per switching function: may jump
    branches = _split(model) if len(switching) <= _MAX_JUMP_CHECK else None
    if branches is not None:
        sw = list(branches[0].switching)
        by_signs = {b.signs: b for b in branches}
        for i, g in enumerate(switching):
            j = next((k for k, s in enumerate(sw) if same_up_to_sign(s, g)), None)
            if j is not None:
                for k, vanish in enumerate(_vanish_across(g, j, by_signs, model, kinds)):
                    unproved[k][i] = not vanish
    jumps, slides, *per_output = (tuple(u) for u in unproved)
    return Discontinuities(
        jumps,
        slides,
        tuple(any(j and c for j, c in zip(jumps, across)) for across in per_output),
    )


def _output_difference(o: str) -> _Differences:
    """The difference to prove zero on ``g = 0`` for the output ``o`` to be continuous there."""

    def differences(g: sp.Expr, a: Model, b: Model, states: Sequence[sp.Symbol]) -> list[sp.Expr]:
        return [a.outputs[o] - b.outputs[o]]

    return differences


def _jump(g: sp.Expr, a: Model, b: Model, states: Sequence[sp.Symbol]) -> list[sp.Expr]:
    """The differences to prove zero on ``g = 0`` for a continuous field: every component's."""
    return [fa - fb for fa, fb in zip(a.rhs, b.rhs)]


def _normal_jump(g: sp.Expr, a: Model, b: Model, states: Sequence[sp.Symbol]) -> list[sp.Expr]:
    """The difference to prove zero on ``g = 0`` for a jump along the surface only: ``grad g . (fa - fb)``."""
    return [sum((sp.diff(g, s) * (fa - fb) for s, fa, fb in zip(states, a.rhs, b.rhs)), sp.Integer(0))]


def _split(model: Model) -> Sequence[Branch] | None:
    """The branches of a one-level split of ``model`` with the same switching functions in each; None where the
    model cannot be split so (nothing is then proved continuous)."""
    try:
        branches = split_branches(model)
    except (ModelError, NotSupportedError):
        return None
    if len(branches) < 2 or any(b.switching != branches[0].switching for b in branches):
        return None
    return branches


def _vanish_across(
    g: sp.Expr, j: int, by_signs: Mapping[tuple[int, ...], Branch], model: Model, kinds: Sequence[_Differences]
) -> list[bool]:
    """For each kind of differences, whether ``differences(g, fa, fb, states)`` of the branches on the two sides of
    ``g = 0`` (``g`` the ``j``-th switching function) vanish identically on ``g = 0`` for every pair of neighbouring
    branches: ``g`` solved once, each pair compared once for every kind."""
    none = [False] * len(kinds)
    sol = None
    if not can_factor(g):  # solving it could run for minutes: not proved continuous, counted as a jump
        return none
    for s in [s for s in list(model.states) + list(model.parameters) if s in g.free_symbols]:
        try:
            roots = sp.solve(g, s)
        except NotImplementedError:  # pragma: no cover - sympy cannot solve it
            continue
        if len(roots) == 1:
            sol = (s, roots[0])
            break
    if sol is None:
        return none
    pairs = 0
    vanish = [True] * len(kinds)
    for signs, b in by_signs.items():
        other = by_signs.get(signs[:j] + (-1,) + signs[j + 1 :]) if signs[j] > 0 else None
        if other is None:
            continue
        pairs += 1
        for k, differences in enumerate(kinds):
            if vanish[k]:
                vanish[k] = all(
                    can_expand(d) and sp.cancel(sp.together(d.subs(*sol))) == 0
                    for d in differences(g, b.model, other.model, list(model.states))
                )
    return vanish if pairs else none
