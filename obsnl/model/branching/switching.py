"""Switching functions of a non-smooth model, and the analytic field on one side of them.

A *switching function* is the argument of ``sign``/``Abs``/``Heaviside``, the difference of the
two sides of a ``Piecewise`` condition, or a pairwise difference of ``Max``/``Min`` arguments.
Each is factored; the sign of a product or power follows from its factors, so
``sign((sigma - eta)*x2)`` adds no switching function beyond ``sigma - eta`` and ``x2``.
Given a sign for every switching function, :func:`resolve` replaces every non-smooth function by
its analytic extension (``sign(g) -> ±1``, ``Abs(g) -> ±g``, ...).
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import cast

import sympy as sp

from obsnl.errors import ModelError, NotSupportedError
from obsnl.model.bounds.budget import check_time
from obsnl.model.bounds.work import can_factor
from obsnl.model.branching.feasibility import Memo, bound_conditions
from obsnl.model.core import NONSMOOTH_FUNCTIONS, Model
from obsnl.model.reading.parse import shorten

__all__ = [
    "Switching",
    "switching_structure",
    "expr_text",
    "switching_functions",
    "switching_of",
    "innermost_nonsmooth",
    "resolve",
    "check_declared",
]


def expr_text(g: sp.Expr) -> str:
    """Plain text of ``g`` with positive terms first (``sigma - eta``, not ``-eta + sigma``)."""
    if not isinstance(g, sp.Add):
        return sp.sstr(g)
    terms = sorted(g.args, key=lambda t: (t.could_extract_minus_sign(), sp.default_sort_key(t)))
    out = ""
    for i, t in enumerate(terms):
        if t.could_extract_minus_sign():
            body = sp.sstr(-t)
            body = f"({body})" if isinstance(-t, sp.Add) else body
            out += f" - {body}" if i else f"-{body}"
        else:
            out += f" + {sp.sstr(t)}" if i else sp.sstr(t)
    return out


def innermost_nonsmooth(exprs: Sequence[sp.Basic]) -> list[sp.Basic]:
    """Non-smooth function applications whose arguments are smooth, in order of appearance."""
    found: list[sp.Basic] = []
    seen: set[sp.Basic] = set()
    for e in exprs:
        for node in sp.preorder_traversal(e):
            if isinstance(node, NONSMOOTH_FUNCTIONS) and node not in seen:
                if not any(a.has(*NONSMOOTH_FUNCTIONS) for a in _arguments(node)):
                    seen.add(node)
                    found.append(node)
    return found


def _arguments(node: sp.Basic) -> list[sp.Basic]:
    if isinstance(node, sp.Piecewise):
        out: list[sp.Basic] = []
        for e, c in node.args:
            out.extend([e, c])
        return out
    if isinstance(node, sp.Heaviside):
        return [node.args[0]]
    return list(node.args)


def _raw_switching(node: sp.Basic) -> list[sp.Expr]:
    """The raw switching expressions of one non-smooth application."""
    if isinstance(node, (sp.sign, sp.Abs, sp.Heaviside)):
        return [node.args[0]]
    if isinstance(node, (sp.Max, sp.Min)):
        return [a - b for a, b in itertools.combinations(node.args, 2)]
    if isinstance(node, sp.Piecewise):
        out = []
        for _, cond in node.args:
            out.extend(_relations_of(cond))
        return out
    raise NotSupportedError(f"cannot split at {node}")  # pragma: no cover - guarded by callers


def _relations_of(cond: sp.Basic) -> list[sp.Expr]:
    if cond in (sp.true, sp.false) or isinstance(cond, bool):
        return []
    if isinstance(cond, (sp.StrictGreaterThan, sp.GreaterThan, sp.StrictLessThan, sp.LessThan)):
        return [cond.lhs - cond.rhs]
    if isinstance(cond, (sp.Eq, sp.Ne)):
        raise NotSupportedError(
            f"Piecewise condition {cond} is an equality; equalities hold on a set of measure zero and "
            f"are not switching surfaces; write the condition with < or >"
        )
    if isinstance(cond, (sp.And, sp.Or, sp.Not)):
        out = []
        for a in cond.args:
            out.extend(_relations_of(a))
        return out
    raise NotSupportedError(f"Piecewise condition {cond} is not a combination of <, >, <=, >=")


@functools.lru_cache(maxsize=4096)
def _canonical(f: sp.Expr) -> tuple[int, sp.Expr]:
    """(sign, f') with f = sign * f' and f' in a canonical orientation (expanded when it is small enough to
    factor, :func:`obsnl.model.bounds.work.can_factor`; as written otherwise: an expansion could be huge, and a
    guard of thousands of terms says less than the expression the user wrote)."""
    f = sp.expand(f) if f.is_Add and can_factor(f) else f
    if f.could_extract_minus_sign():
        return -1, -f
    return 1, f


def _factor_signs(g: sp.Expr) -> tuple[int, list[sp.Expr]]:
    """Write sign(g) = c * prod(sign(f_j)) with canonical irreducible factors f_j (odd powers only).

    A ``g`` too large to factor cheaply (:func:`obsnl.model.bounds.work.can_factor`: ``x**100 - v**100``,
    ``(a + b + ... + v)**30 - 1``) is not factored, nor expanded: it is its own switching function, which is
    just as correct (the branches are the sides of ``g = 0``) and only forgoes merging it with its factors.
    Inside a time budget (:func:`obsnl.model.bounds.budget.time_budget`) the budget is checked first.
    """
    check_time(
        f"factoring the switching function {shorten(expr_text(g), 60)!r}",
        "raise max_seconds=, or smooth some switching functions (tanh(g/eps) for sign(g))",
    )
    if not can_factor(g):
        s, fc = _canonical(g)
        return s, [fc]
    g = sp.together(g)
    num, den = sp.fraction(g)
    const = 1
    factors: list[sp.Expr] = []
    for part in (num, den):
        try:
            c, flist = sp.factor_list(part)
        except (sp.PolynomialError, NotImplementedError, TypeError, ValueError):
            c, flist = 1, [(p, 1) for p in sp.Mul.make_args(sp.factor_terms(part))]
        c = sp.sympify(c)
        if c.is_number:
            if c == 0:
                raise ModelError(f"the switching function {g} is identically zero")
            const *= 1 if c > 0 else -1
        else:  # pragma: no cover - factor_list returns numeric content
            flist = [(c, 1)] + list(flist)
        for f, k in flist:
            if f.is_number:
                const *= 1 if (f > 0 or k % 2 == 0) else -1
                continue
            if isinstance(f, sp.Pow) and f.exp.is_number and f.exp.is_integer:
                base, k = f.base, k * int(f.exp)
                f = base
            if f.is_positive:
                continue
            if k % 2 == 0:
                continue  # an even power has a known sign off the surface f = 0
            s, fc = _canonical(f)
            const *= s
            if fc not in factors:
                factors.append(fc)
            else:  # f appears twice with odd powers: sign squared
                factors.remove(fc)
    return const, factors


def switching_functions(model: Model) -> tuple[sp.Expr, ...]:
    """The switching functions of the outermost level of ``model`` (empty for a smooth model).

    Declared ``model.switching`` come first, in their order and orientation; others follow in
    order of appearance.
    """
    return switching_of(list(model.rhs) + list(model.output_exprs), model.switching)


def _factored(g: sp.Expr, memo: Memo | None) -> tuple[int, list[sp.Expr]]:
    """:func:`_factor_signs` remembered for one split (the same arguments recur in every branch)."""
    if memo is None:
        return _factor_signs(g)
    if g not in memo:
        memo[g] = _factor_signs(g)
    c, factors = cast("tuple[int, list[sp.Expr]]", memo[g])
    return c, list(factors)


def switching_of(
    exprs: Sequence[sp.Basic], declared: Sequence[sp.Expr], memo: Memo | None = None
) -> tuple[sp.Expr, ...]:
    """The distinct switching functions of the non-smooth nodes of ``exprs``, declared ones first.

    Each switching function is factored and reduced to a canonical form; those matching ``declared``
    come first, in the declared order, then the others in the order found.

    Parameters
    ----------
    exprs : sequence of sympy.Basic
        The expressions (right-hand sides, outputs) to scan.
    declared : sequence of sympy.Expr
        Switching functions the model declares, fixing the order.
    memo : Memo or None
        Cache of factorizations shared between calls.

    Returns
    -------
    tuple of sympy.Expr
    """
    found: list[sp.Expr] = []
    for node in innermost_nonsmooth(exprs):
        for raw in _raw_switching(node):
            _, factors = _factored(raw, memo)
            for f in factors:
                if f not in found:
                    found.append(f)
    order = [d for d in declared if _canonical(d)[1] in found]
    taken = {_canonical(d)[1] for d in order}
    order.extend(f for f in found if f not in taken)
    return tuple(order)


@dataclass(frozen=True)
class Switching:
    """The switching functions of one nesting level, found once and handed to whatever splits there.

    Attributes
    ----------
    exprs
        The expressions scanned (right-hand sides, then outputs).
    functions
        The switching functions (:func:`switching_of`: declared ones first).
    nodes
        The innermost non-smooth applications (:func:`innermost_nonsmooth`), which a sign pattern resolves.
    nested
        Whether some non-smooth function has a non-smooth argument (a split resolves it level by level).
    declared
        The model's declared switching functions (their order holds at every level).
    memo
        The factorizations made, shared with the split and the feasibility search that follow, which add their
        own kinds of entry (:data:`obsnl.model.branching.feasibility.Memo`).
    bounds
        The model's declared bounds as sign conditions
        (:func:`obsnl.model.branching.feasibility.bound_conditions`), which every sign pattern must meet too.
    """

    exprs: tuple[sp.Expr, ...]
    functions: tuple[sp.Expr, ...]
    nodes: tuple[sp.Basic, ...]
    nested: bool
    declared: tuple[sp.Expr, ...] = ()
    memo: Memo = field(default_factory=dict, compare=False, repr=False)
    bounds: tuple[tuple[sp.Expr, int], ...] = ()

    @staticmethod
    def of(
        exprs: Sequence[sp.Expr],
        declared: Sequence[sp.Expr],
        memo: Memo | None = None,
        bounds: Sequence[tuple[sp.Expr, int]] = (),
    ) -> Switching:
        """The switching structure of ``exprs``, ``declared`` fixing the order of the functions, ``bounds`` the
        declared bounds as sign conditions."""
        exprs, declared, memo, bounds = tuple(exprs), tuple(declared), {} if memo is None else memo, tuple(bounds)
        if not any(e.has(*NONSMOOTH_FUNCTIONS) for e in exprs):
            return Switching(exprs, (), (), False, declared, memo, bounds)
        nested = any(
            a.has(*NONSMOOTH_FUNCTIONS)
            for e in exprs
            for node in sp.preorder_traversal(e)
            if isinstance(node, NONSMOOTH_FUNCTIONS)
            for a in _arguments(node)
        )
        return Switching(
            exprs,
            switching_of(exprs, declared, memo),
            tuple(innermost_nonsmooth(exprs)),
            nested,
            declared,
            memo,
            bounds,
        )

    def field_at(self, signs: Sequence[int]) -> list[sp.Expr]:
        """The expressions where the functions have ``signs``: every innermost non-smooth node replaced by its
        analytic extension (:func:`resolve`)."""
        repl = {node: resolve(node, self.functions, signs, self.memo) for node in self.nodes}
        return [e.xreplace(repl) for e in self.exprs]

    @functools.cached_property
    def members(self) -> tuple[tuple[int, ...], ...]:
        """Per expression, the indices of the functions it switches on (found when first asked; not nested)."""
        if self.nested:
            raise NotSupportedError("nested non-smooth functions: use obsnl.model.split_branches")
        index = {_canonical(f)[1]: j for j, f in enumerate(self.functions)}
        return tuple(
            tuple(sorted({index[_canonical(f)[1]] for f in switching_of([e], (), self.memo)})) for e in self.exprs
        )


def switching_structure(model: Model) -> Switching:
    """The switching structure of the outermost level of ``model`` (no functions for a smooth model); without
    nested non-smooth functions these are all, and a declared one that is none of them is refused here
    (:func:`check_declared`; a split checks a nested model's). The model's declared bounds go with it.

    Examples
    --------
    >>> m = Model(name="two", states=["x", "y"], parameters=["a"], equations={"x": "-a*sign(x)", "y": "Abs(y - 1)"},
    ...           outputs={"o": "x + y"})
    >>> s = switching_structure(m)
    >>> [expr_text(g) for g in s.functions], s.members, s.nested
    (['x', 'y - 1'], ((0,), (1,), ()), False)
    >>> switching_structure(m.replace(equations={"x": "-a*sign(x + Abs(y))", "y": "-y"})).nested
    True
    """
    level = Switching.of(
        list(model.rhs) + list(model.output_exprs),
        model.switching,
        bounds=bound_conditions(model.bounds, model.symbols),
    )
    if not level.nested:
        check_declared(model, level.functions)
    return level


def check_declared(model: Model, found: Sequence[sp.Expr]) -> None:
    """Refuse a declared switching function (``model.switching``) that is none of those ``found`` in the model
    (at any nesting level): it would be dropped from the branch order without a word.

    Parameters
    ----------
    model : Model
        The model whose ``switching`` was declared.
    found : sequence of sympy.Expr
        Every switching function the split met.

    Raises
    ------
    ModelError
        Naming the declared function and the model's switching functions.

    Examples
    --------
    >>> m = Model(name="f", states=["x", "v"], parameters=["k"], switching=["v", "x - 3"],
    ...           equations={"x": "v", "v": "-k*sign(v)"}, outputs={"y": "x"})
    >>> check_declared(m, switching_functions(m))
    Traceback (most recent call last):
    ...
    obsnl.errors.ModelError: the declared switching function 'x - 3' does not occur in model 'f' (its switching functions: v); remove it from 'switching' or correct it
    """
    canon = {_canonical(f)[1] for f in found}
    for d in model.switching:
        if _canonical(d)[1] not in canon:
            have = ", ".join(expr_text(f) for f in found) or "none, the model is smooth"
            raise ModelError(
                f"the declared switching function {expr_text(d)!r} does not occur in model "
                f"{model.name!r} (its switching functions: {have}); remove it from 'switching' or "
                f"correct it"
            )


# --------------------------------------------------------------------------- resolution in a branch
def _sign_in(g: sp.Expr, switching: Sequence[sp.Expr], signs: Sequence[int], memo: Memo | None = None) -> int:
    """The sign of ``g`` in the branch where ``switching`` have ``signs``."""
    c, factors = _factored(g, memo)
    canon = {_canonical(sw)[1]: (_canonical(sw)[0], s) for sw, s in zip(switching, signs)}
    out = c
    for f in factors:
        if f not in canon:  # pragma: no cover - every factor is a switching function
            raise ModelError(f"internal: {f} is not among the switching functions")
        orient, s = canon[f]
        out *= orient * s
    return out


def _truth(cond: sp.Basic, switching: Sequence[sp.Expr], signs: Sequence[int], memo: Memo | None = None) -> bool:
    if cond is sp.true or cond is True:
        return True
    if cond is sp.false or cond is False:
        return False
    if isinstance(cond, (sp.StrictGreaterThan, sp.GreaterThan)):
        return _sign_in(cond.lhs - cond.rhs, switching, signs, memo) > 0
    if isinstance(cond, (sp.StrictLessThan, sp.LessThan)):
        return _sign_in(cond.lhs - cond.rhs, switching, signs, memo) < 0
    if isinstance(cond, sp.And):
        return all(_truth(a, switching, signs, memo) for a in cond.args)
    if isinstance(cond, sp.Or):
        return any(_truth(a, switching, signs, memo) for a in cond.args)
    if isinstance(cond, sp.Not):
        return not _truth(cond.args[0], switching, signs, memo)
    raise NotSupportedError(f"Piecewise condition {cond} is not supported")  # pragma: no cover


def resolve(node: sp.Basic, switching: Sequence[sp.Expr], signs: Sequence[int], memo: Memo | None = None) -> sp.Expr:
    """The smooth expression a non-smooth ``node`` takes where the switching functions have ``signs``.

    Parameters
    ----------
    node : sympy.Basic
        A ``sign``, ``Abs``, ``Heaviside``, ``Max``, ``Min`` or ``Piecewise`` node.
    switching : sequence of sympy.Expr
        The model's switching functions.
    signs : sequence of int
        The sign (+1 or -1) of each switching function on the branch.
    memo : Memo or None
        Cache of factorizations shared between calls.

    Returns
    -------
    sympy.Expr

    Raises
    ------
    ModelError
        When a ``Piecewise`` has no piece for the sign pattern.
    """
    if isinstance(node, sp.sign):
        return sp.Integer(_sign_in(node.args[0], switching, signs, memo))
    if isinstance(node, sp.Abs):
        return _sign_in(node.args[0], switching, signs, memo) * node.args[0]
    if isinstance(node, sp.Heaviside):
        return sp.Integer(1 if _sign_in(node.args[0], switching, signs, memo) > 0 else 0)
    if isinstance(node, (sp.Max, sp.Min)):
        want = 1 if isinstance(node, sp.Max) else -1
        for a in node.args:
            if all(want * _sign_in(a - b, switching, signs, memo) > 0 for b in node.args if b is not a):
                return a
        raise ModelError(f"cannot resolve {node} in a branch")  # pragma: no cover
    if isinstance(node, sp.Piecewise):
        for e, c in node.args:
            if _truth(c, switching, signs, memo):
                return e
        raise ModelError(
            f"Piecewise {node} has no branch for the sign pattern "
            f"{dict(zip(map(str, switching), signs))}; add a final (value, True) pair"
        )
    raise NotSupportedError(f"cannot resolve {node}")  # pragma: no cover
