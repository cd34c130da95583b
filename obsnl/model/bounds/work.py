"""Bounds on the work of expanding and factoring an expression, decided before the work starts.

Expanding ``(a + b + c + d + e + k + x + v)**30`` makes 10 million terms (2 GB), factoring
``x**100 - v**100`` or ``(x + v + 1)**60 - (x - v + 2)**60`` runs for minutes in sympy, although each is
a short expression. The size of an expression says nothing about that work; its *expanded size* does.
:func:`expanded_size` bounds, without expanding, the number of terms, the total degree and the digits
of the coefficients that :func:`sympy.expand` would produce, and :func:`can_expand` /
:func:`can_factor` compare them with the bounds below (measured here: factoring within
:data:`MAX_FACTOR_TERMS` terms of total degree :data:`MAX_FACTOR_DEGREE` takes at most about 0.2 s,
expanding :data:`MAX_EXPANDED_TERMS` terms about 0.1 s). Callers that are refused the work keep the
expression as it is (an unfactored switching function is still a correct one) or refuse it with one line.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import sympy as sp

__all__ = [
    "Size",
    "expanded_size",
    "can_expand",
    "can_factor",
    "MAX_EXPANDED_TERMS",
    "MAX_FACTOR_TERMS",
    "MAX_FACTOR_DEGREE",
    "MAX_EXACT_DIGITS",
    "exact_digits",
    "same_up_to_sign",
    "degree_in",
]

#: Most terms an expansion may produce.
MAX_EXPANDED_TERMS = 5000
#: Most terms (after expansion) of a polynomial that is factored.
MAX_FACTOR_TERMS = 200
#: Highest total degree of a polynomial that is factored (multivariate factoring grows steeply with it).
MAX_FACTOR_DEGREE = 12
#: Most decimal digits of the numerator or denominator of an exact constant (``(1 + 1e-100)**100`` has
#: 10 001; Python refuses to print integers over 4300 digits).
MAX_EXACT_DIGITS = 1000

_CAP = 1e30  # estimates are clipped here (they only need to be compared with the bounds)


class Size(NamedTuple):
    """Upper bounds of what :func:`sympy.expand` would make of an expression.

    Attributes
    ----------
    terms : float
        Terms of the expansion (clipped at 1e30).
    degree : int
        Total degree in the symbols and in the non-polynomial sub-expressions (``exp(x)`` counts as one
        variable).
    digits : float
        Decimal digits of the largest numerator or denominator of a coefficient.
    variables : int
        Symbols and non-polynomial sub-expressions the expansion is a polynomial in.
    """

    terms: float
    degree: int
    digits: float
    variables: int


def exact_digits(n: sp.Basic) -> float:
    """Decimal digits of the larger of the numerator and denominator of the number ``n`` (no printing:
    ``str`` of an integer over 4300 digits raises).

    Examples
    --------
    >>> exact_digits(sp.Rational(1, 1000))
    4.0
    """
    if not n.is_Rational:
        return 17.0  # a float or a number symbol such as pi: its digits do not grow the expansion
    big = max(abs(int(n.p)), int(n.q))
    return float(math.floor(big.bit_length() * math.log10(2)) + 1)


def _multinomial(t: float, k: int) -> float:
    """Terms of ``(t terms)**k`` at most: C(t + k - 1, k)."""
    if t <= 1:
        return 1.0
    if t > _CAP or k > 10**6:
        return _CAP
    out = math.lgamma(t + k) - math.lgamma(k + 1) - math.lgamma(t)
    return min(_CAP, math.exp(out)) if out < 69 else _CAP


def expanded_size(expr: sp.Basic) -> Size:
    """Bounds of the expansion of ``expr`` (:class:`Size`), computed without expanding.

    Parameters
    ----------
    expr : sympy.Basic
        Any expression.

    Returns
    -------
    Size

    Examples
    --------
    >>> x, v = sp.symbols("x v")
    >>> s = expanded_size((x + v + 1)**60 - (x - v + 2)**60)
    >>> round(s.terms), s.degree
    (1891, 60)
    """
    memo: dict[sp.Basic, tuple[float, int, float, frozenset]] = {}

    def walk(e: sp.Basic) -> tuple[float, int, float, frozenset]:
        if e in memo:
            return memo[e]
        out: tuple[float, int, float, frozenset]
        if e.is_Number or e.is_NumberSymbol:
            out = (1.0, 0, exact_digits(e), frozenset())
        elif e.is_Symbol:
            out = (1.0, 1, 0.0, frozenset([e]))
        elif isinstance(e, sp.Add):
            parts = [walk(a) for a in e.args]
            out = (
                min(_CAP, sum(p[0] for p in parts)),
                max(p[1] for p in parts),
                max(p[2] for p in parts) + math.log10(len(parts)),
                frozenset().union(*(p[3] for p in parts)),
            )
        elif isinstance(e, sp.Mul):
            parts = [walk(a) for a in e.args]
            terms = 1.0
            for p in parts:
                terms = min(_CAP, terms * p[0])
            out = (terms, sum(p[1] for p in parts), sum(p[2] for p in parts), frozenset().union(*(p[3] for p in parts)))
        elif isinstance(e, sp.Pow) and e.exp.is_Integer:
            t, d, g, vs = walk(e.base)
            k = abs(int(e.exp))
            out = (_multinomial(t, k), d * k, g * k + k * math.log10(max(t, 1.0)), vs)
        else:  # a function or a non-integer power: one variable, its arguments expanded inside it
            inner = [walk(a) for a in e.args]
            terms = max([1.0] + [p[0] for p in inner])
            digits = max([0.0] + [p[2] for p in inner])
            out = (terms if terms > MAX_EXPANDED_TERMS else 1.0, 1, digits, frozenset([e]))
        memo[e] = out
        return out

    terms, degree, digits, variables = walk(sp.sympify(expr))
    n = len(variables)
    if n and degree < 10**6:  # no more terms than monomials of that degree in those variables
        terms = min(terms, _multinomial(n + 1, degree))
    return Size(terms, degree, digits, n)


def can_expand(expr: sp.Basic) -> bool:
    """Whether expanding ``expr`` stays within :data:`MAX_EXPANDED_TERMS` terms and coefficients of
    :data:`MAX_EXACT_DIGITS` digits.

    Examples
    --------
    >>> x, v = sp.symbols("x v")
    >>> can_expand((x + v)**10), can_expand(sp.Add(*sp.symbols("a:h"))**30)
    (True, False)
    """
    s = expanded_size(expr)
    return s.terms <= MAX_EXPANDED_TERMS and s.digits <= MAX_EXACT_DIGITS


def can_factor(expr: sp.Basic) -> bool:
    """Whether factoring ``expr`` is cheap: at most :data:`MAX_FACTOR_TERMS` terms once expanded, total
    degree at most :data:`MAX_FACTOR_DEGREE`, coefficients of at most :data:`MAX_EXACT_DIGITS` digits.

    Examples
    --------
    >>> x, v = sp.symbols("x v")
    >>> can_factor(x**2 - v**2), can_factor(x**100 - v**100)
    (True, False)
    """
    s = expanded_size(expr)
    return s.terms <= MAX_FACTOR_TERMS and s.degree <= MAX_FACTOR_DEGREE and s.digits <= MAX_EXACT_DIGITS


def same_up_to_sign(f: sp.Expr, g: sp.Expr) -> bool:
    """Whether ``f = g`` or ``f = -g``: structurally, else by expanding the difference when that is cheap
    (:func:`can_factor`); two large expressions that differ in form only count as different.

    Parameters
    ----------
    f, g : sympy.Expr
        The expressions compared.

    Returns
    -------
    bool

    Examples
    --------
    >>> x, v = sp.symbols("x v")
    >>> same_up_to_sign((x - v)*(x + v), v**2 - x**2), same_up_to_sign(x, v)
    (True, False)
    """
    if f == g or f == -g:
        return True
    return any(can_factor(d) and sp.expand(d) == 0 for d in (f - g, f + g))


def degree_in(expr: sp.Basic, sym: sp.Symbol) -> float:
    """An upper bound of the degree of ``expr`` in ``sym``, without expanding (``inf`` when ``sym`` is inside a
    function, a denominator or a non-integer power).

    Parameters
    ----------
    expr : sympy.Basic
        The expression.
    sym : sympy.Symbol
        The symbol.

    Returns
    -------
    float

    Examples
    --------
    >>> x, v = sp.symbols("x v")
    >>> degree_in((x + v)**30 * v + 1, v), degree_in(x / v, v)
    (31, inf)
    """
    if sym not in expr.free_symbols:
        return 0
    if expr == sym:
        return 1
    if isinstance(expr, sp.Add):
        return max(degree_in(a, sym) for a in expr.args)
    if isinstance(expr, sp.Mul):
        return sum(degree_in(a, sym) for a in expr.args)
    if isinstance(expr, sp.Pow) and expr.exp.is_Integer and expr.exp > 0:
        return degree_in(expr.base, sym) * int(expr.exp)
    return math.inf
