"""Proofs that a switching function never takes a sign: a guard that can never hold, found before any search.

``h > 0`` holds nowhere when ``h <= 0`` everywhere. Two exact tests decide that:

1. **By its form**: sympy's sign rules over real symbols (a sum of squares of real expressions plus a positive
   constant, negated, as written: ``-((x - v)**2 + v**2 + 1)``).
2. **A quadratic of definite sign**: ``h`` expanded is a polynomial in its symbols and real sub-expressions
   (``sin(x)``, ``exp(v)``, each an unknown of its own). Where every generator appears only with exponents
   ``0, d, 2d`` (``d`` its own), ``h`` is a quadratic ``z' A z + b' z + c`` in the powers ``z_i = g_i**d_i``,
   and such a quadratic is ``<= 0`` for every real ``z`` if and only if the symmetric matrix
   ``[[A, b/2], [b'/2, c]]`` is negative semidefinite (Hilbert: a non-negative quadratic is a sum of squares).
   The matrix is built from the exact coefficients (a float as the rational it stores) and tested in exact
   rational arithmetic (sympy). Letting every ``z_i`` range over all reals only enlarges the set, so the proof
   holds for the values the generators really take. ``x**2 - 2*x*v + 2*v**2 + 1`` is ``(x - v)**2 + v**2 + 1``:
   its matrix ``[[1, -1, 0], [-1, 2, 0], [0, 0, 1]]`` is positive definite, so it is never negative.

Neither test searches: a guard they do not settle is left to the linear programs and the witness search of
:mod:`obsnl.model.branching.feasibility`.
"""

from __future__ import annotations

import math

import sympy as sp

from obsnl.model.bounds.work import can_expand

__all__ = ["MAX_GENERATORS", "never_positive"]

#: Most generators (symbols and real sub-expressions) of a quadratic tested (an exact matrix of that size).
MAX_GENERATORS = 40


def never_positive(h: sp.Expr) -> str:
    """Why ``h > 0`` holds at no real point, or ``""`` when neither exact test shows it.

    Parameters
    ----------
    h : sympy.Expr
        An expression over real symbols (a switching function times its wanted sign).

    Returns
    -------
    str
        The proof in words (empty: not shown; ``h`` may or may not take positive values).

    Examples
    --------
    >>> x, v = sp.symbols("x v", real=True)
    >>> never_positive(-(x**2 - 2*x*v + 2*v**2 + 1))
    'it is a quadratic in x, v whose symmetric matrix is negative semidefinite (exact rational arithmetic)'
    >>> never_positive(-(x**4 - 2*x**2*v + v**2 + 1))
    'it is a quadratic in x**2, v whose symmetric matrix is negative semidefinite (exact rational arithmetic)'
    >>> never_positive(x**2 - 2*x*v + 2*v**2 + 1), never_positive(-(x**2 - 3*x*v + 2*v**2 + 1))
    ('', '')
    """
    if h.is_extended_nonpositive:
        return "its sign is fixed by its form (a sum of squares and positive terms, negated)"
    found = _quadratic(h)
    if found is None:
        return ""
    gens, matrix = found
    if (-matrix).is_positive_semidefinite:
        return (
            f"it is a quadratic in {', '.join(gens)} whose symmetric matrix is negative semidefinite "
            f"(exact rational arithmetic)"
        )
    return ""


def _quadratic(h: sp.Expr) -> tuple[list[str], sp.Matrix] | None:
    """(the lifted generators as text, the symmetric matrix of ``h`` in them, constant last), or None when ``h`` is
    not a quadratic with exact real coefficients in powers of real generators."""
    if not can_expand(h):
        return None
    try:
        poly = sp.Poly(sp.expand(h))
    except (sp.PolynomialError, sp.GeneratorsError, sp.CoercionFailed):
        return None
    n = len(poly.gens)
    if not poly.domain.is_Numerical or not 0 < n <= MAX_GENERATORS:
        return None
    if any(g.is_extended_real is not True for g in poly.gens):  # sqrt(x) may be complex: not a real unknown
        return None
    terms = poly.terms()
    lift = [math.gcd(*(int(m[i]) for m, _ in terms)) for i in range(n)]
    entries: dict[tuple[int, int], sp.Rational] = {}
    for monomial, coeff in terms:
        if isinstance(coeff, sp.Float):  # the rational it stores, exactly
            c = sp.Rational(*float(coeff).as_integer_ratio())
        elif getattr(coeff, "is_Rational", False):
            c = coeff
        else:  # an algebraic number (sqrt(2)): not tested
            return None
        index = [i for i in range(n) for _ in range(int(monomial[i]) // lift[i] if lift[i] else 0)]
        if len(index) > 2:
            return None
        i, j = (index + [n, n])[:2]
        half = c if i == j else c / 2
        for key in {(i, j), (j, i)}:
            entries[key] = entries.get(key, sp.Integer(0)) + half
    matrix = sp.Matrix(n + 1, n + 1, lambda i, j: entries.get((i, j), sp.Integer(0)))
    gens = [sp.sstr(g if d == 1 else g**d) for g, d in zip(poly.gens, lift)]
    return gens, matrix
