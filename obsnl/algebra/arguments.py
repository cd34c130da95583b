"""Helpers of the atom rewriter (:mod:`obsnl.algebra.atoms`): factoring a logarithm's argument (within a
bound on the work), exact numbers, and the user's own form of a rewritten expression for messages."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import sympy as sp

from obsnl.errors import ModelError
from obsnl.model.bounds.work import can_factor

__all__ = ["user_form"]


#: A numerator's or denominator's constant and factors with their multiplicities.
_Factored = tuple[sp.Rational, tuple[tuple[sp.Expr, int], ...]]


def _factor_fraction(g: sp.Expr) -> sp.Rational | tuple[_Factored, ...]:
    """``g`` as a rational number, or ((c, factors) of the numerator, (c, factors) of the denominator).

    A part too large to factor cheaply (:func:`obsnl.model.bounds.work.can_factor`) is kept whole: ``log|part|``
    is then one atom, which is still exact.
    """
    g = sp.together(g)
    if g == 0:
        raise ModelError("log(0) in the model")
    if g.is_Rational:
        return sp.Rational(g)
    out: list[_Factored] = []
    for part in sp.fraction(g):
        if part.is_Rational:
            out.append((sp.Rational(part), ()))
            continue
        if not can_factor(part):
            out.append((sp.Integer(1), ((part, 1),)))
            continue
        try:
            c, factors = sp.factor_list(sp.expand(part))
        except (sp.PolynomialError, NotImplementedError):  # pragma: no cover - defensive
            c, factors = sp.Integer(1), [(part, 1)]
        out.append((sp.Rational(c), tuple(factors)))
    return tuple(out)


def _rational_gcd(values: Sequence[sp.Rational]) -> sp.Rational:
    nums = [abs(int(v.p)) for v in values]
    dens = [int(v.q) for v in values]
    g = 0
    for n in nums:
        g = math.gcd(g, n)
    lcm = 1
    for d in dens:
        lcm = lcm * d // math.gcd(lcm, d)
    return sp.Rational(g, lcm)


def _to_exact(e: sp.Expr) -> sp.Expr:
    if e.has(sp.Float):
        return e.xreplace({f: sp.nsimplify(f, rational=True) for f in e.atoms(sp.Float)})
    return e


def user_form(
    e: sp.Expr,
    prov_exp: Mapping[sp.Symbol, tuple[sp.Expr, sp.Rational]],
    prov_trig: Mapping[tuple[str, sp.Expr, sp.Rational], sp.Symbol],
    atoms: Mapping[sp.Symbol, Any],
) -> sp.Expr:
    """``e`` with the rewriter's provisional and atom symbols (``_pexp0``, ``_log1``, ...) swapped back for
    what they stand for: how a message shows the user's own expression.

    Parameters
    ----------
    e : sympy.Expr
        An expression of the rewriter.
    prov_exp : mapping
        Provisional exponential symbol -> (monomial, coefficient).
    prov_trig : mapping
        (``"sin"`` or ``"cos"``, monomial, coefficient) -> provisional symbol.
    atoms : mapping
        Atom symbol -> :class:`obsnl.algebra.atom_table.Atom`.

    Returns
    -------
    sympy.Expr

    Examples
    --------
    >>> x, p = sp.Symbol("x"), sp.Symbol("_pexp0")
    >>> user_form(p + 1, {p: (x, sp.Integer(2))}, {}, {})
    exp(2*x) + 1
    """
    back: dict[sp.Symbol, sp.Expr] = {s: sp.exp(c * m) for s, (m, c) in prov_exp.items()}
    for (kind, m, c), s in prov_trig.items():
        back[s] = (sp.sin if kind == "sin" else sp.cos)(c * m)
    for s, a in atoms.items():
        back[s] = (
            a.arg ** sp.Rational(1, a.q)
            if a.kind == "root"
            else a.arg
            if a.kind == "const"
            else sp.log(a.arg)
            if a.kind == "log"
            else getattr(sp, a.kind)(a.arg)
        )
    for _ in range(len(back) + 1):  # an atom's argument may hold earlier atoms
        if not e.free_symbols & set(back):
            break
        e = e.xreplace(back)
    return e
