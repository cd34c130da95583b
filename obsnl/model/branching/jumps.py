"""Where the vector field of a non-smooth model jumps: for each switching function, whether the smooth fields
on its two sides may differ on the surface (the discrete steps of :mod:`obsnl.estimation.numeric` refine only
the crossings where it does), and whether the jump may have a component across the surface, the only kind
that can hold a trajectory on it (a sliding mode in Filippov's sense: a mass that sticks under dry friction),
which the located substep of :mod:`obsnl.estimation.crossing` then resolves.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import sympy as sp

from obsnl.errors import ModelError, NotSupportedError
from obsnl.model.bounds.work import can_expand, can_factor, same_up_to_sign
from obsnl.model.branching.branches import Branch, split_branches
from obsnl.model.core import Model

__all__ = ["field_jumps", "field_slides", "output_jumps"]

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
    return _across(model, switching, _jump)


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
    return _across(model, switching, _normal_jump)


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
    jumping = field_jumps(model, switching)
    out = []
    for o in model.outputs:

        def differences(g: sp.Expr, a: Model, b: Model, states: Sequence[sp.Symbol], o: str = o) -> list[sp.Expr]:
            return [a.outputs[o] - b.outputs[o]]

        across = _across(model, switching, differences)
        out.append(any(j and c for j, c in zip(jumping, across)))
    return tuple(out)


def _jump(g: sp.Expr, a: Model, b: Model, states: Sequence[sp.Symbol]) -> list[sp.Expr]:
    """The differences to prove zero on ``g = 0`` for a continuous field: every component's."""
    return [fa - fb for fa, fb in zip(a.rhs, b.rhs)]


def _normal_jump(g: sp.Expr, a: Model, b: Model, states: Sequence[sp.Symbol]) -> list[sp.Expr]:
    """The difference to prove zero on ``g = 0`` for a jump along the surface only: ``grad g . (fa - fb)``."""
    return [sum((sp.diff(g, s) * (fa - fb) for s, fa, fb in zip(states, a.rhs, b.rhs)), sp.Integer(0))]


def _across(model: Model, switching: Sequence[sp.Expr], differences: _Differences) -> tuple[bool, ...]:
    """For each switching function: not proved that ``differences`` vanish on its surface for every pair of
    neighbouring branches (True also when the model cannot be split or has too many switching functions)."""
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
        out.append(True if j is None else not _vanish_across(g, j, by_signs, model, differences))
    return tuple(out)


def _vanish_across(
    g: sp.Expr, j: int, by_signs: Mapping[tuple[int, ...], Branch], model: Model, differences: _Differences
) -> bool:
    """Whether ``differences(g, fa, fb, states)`` of the branch fields on the two sides of ``g = 0`` (``g`` the
    ``j``-th switching function) vanish identically on ``g = 0`` for every pair of neighbouring branches."""
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
        other = by_signs.get(signs[:j] + (-1,) + signs[j + 1 :]) if signs[j] > 0 else None
        if other is None:
            continue
        pairs += 1
        for d in differences(g, b.model, other.model, list(model.states)):
            if not can_expand(d) or sp.cancel(sp.together(d.subs(*sol))) != 0:
                return False
    return pairs > 0
