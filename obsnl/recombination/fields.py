"""Fields of functions, decided modulo a large prime: :func:`same_field` and :func:`jacobian_mod_p`.

Two finite sets of functions ``A``, ``B`` of the variables ``z`` generate the same field up to
algebraic closure (each is locally a function of the other) exactly when
``rank J_A = rank J_B = rank [J_A; J_B]`` for the generic Jacobians. The ranks are taken at one
random point of GF(p), ``p = 2**62 - 57`` (:data:`obsnl.algebra.modp.PRIME`). A rank can only drop at a
special point: a nonzero maximal minor (a polynomial of degree ``D`` after clearing denominators)
vanishes at a uniformly random point with probability at most ``D/p`` (Schwartz-Zippel);
:func:`same_field` reports that bound.

Non-rational terms are evaluated the way the engines do: rewritten over atoms with random
stand-ins and chain-rule gradients (:mod:`obsnl.algebra.augment`, where the exactness argument, Ax's
theorem, is; the evaluator is :mod:`obsnl.algebra.jets`). The degree ``D`` is counted on that rational
form, atoms counting as variables.
"""

from __future__ import annotations

import random
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import sympy as sp

from obsnl._text import block, one_line
from obsnl.algebra.jets import Expressions
from obsnl.algebra.modp import PRIME, Resample, nullspace_mod_p, rank_mod_p, rational_reconstruction
from obsnl.errors import ModelError

__all__ = [
    "PRIME",
    "FieldComparison",
    "same_field",
    "jacobian_mod_p",
    "rank_mod_p",
    "nullspace_mod_p",
    "rational_reconstruction",
]


def jacobian_mod_p(
    exprs: Sequence[sp.Expr],
    variables: Sequence[sp.Symbol],
    *,
    seed: int = 0,
    point: Mapping[sp.Symbol, int] | None = None,
) -> list[list[int]]:
    """The Jacobian of ``exprs`` w.r.t. ``variables`` at a random point mod :data:`PRIME` (rows = exprs).

    Symbols that are not ``variables`` take random values too (they are constants here).

    Parameters
    ----------
    exprs : sequence of sympy.Expr
        The functions.
    variables : sequence of sympy.Symbol
        The differentiation variables (columns).
    seed : int
        Seed of the random point.
    point : mapping of sympy.Symbol to int or None
        Values to use instead of random ones.

    Returns
    -------
    list of list of int
        Residues mod :data:`PRIME`.
    """
    return _jacobian(_compile(exprs, variables), variables, seed, point)


def _compile(exprs: Sequence[sp.Expr], variables: Sequence[sp.Symbol]) -> Expressions:
    exprs = [sp.sympify(e) for e in exprs]
    return Expressions(exprs, sorted(set(variables).union(*(e.free_symbols for e in exprs)), key=lambda s: s.name))


def _jacobian(
    compiled: Expressions, variables: Sequence[sp.Symbol], seed: int, point: Mapping[sp.Symbol, int] | None
) -> list[list[int]]:
    rng = random.Random(seed)
    for _ in range(20):
        pt = dict(point) if point is not None else {}
        pt.update({s: rng.randrange(1, PRIME) for s in compiled.symbols if s not in pt})
        try:
            return [g for _, g in compiled.jets(pt, list(variables), PRIME, rng)]
        except Resample:
            if point is not None:
                raise
    raise ModelError("every random point hit a zero denominator; are the expressions well defined?")


# --------------------------------------------------------------------------- same_field
@dataclass(frozen=True)
class FieldComparison:
    """Ranks of two sets of functions and of their union; true (as a bool) when the fields agree.

    Attributes
    ----------
    rank_a, rank_b, rank_joint
        Ranks of ``J_A``, ``J_B`` and ``[J_A; J_B]`` at the random point.
    error_bound
        Upper bound on the probability that a rank is lower than the generic one (Schwartz-Zippel,
        ``D/p``), for the rational part; atoms of non-rational terms are generic by Ax's theorem.
    seed
        Seed of the random point.
    """

    rank_a: int
    rank_b: int
    rank_joint: int
    error_bound: float
    seed: int

    @property
    def same(self) -> bool:
        return self.rank_a == self.rank_b == self.rank_joint

    @property
    def a_contains_b(self) -> bool:
        """Every function of B is (locally) a function of those of A."""
        return self.rank_joint == self.rank_a

    @property
    def b_contains_a(self) -> bool:
        return self.rank_joint == self.rank_b

    def __repr__(self) -> str:
        return one_line(
            "FieldComparison",
            f"same={self.same}",
            f"rank_a={self.rank_a}",
            f"rank_b={self.rank_b}",
            f"rank_joint={self.rank_joint}",
            f"error_bound={self.error_bound:.1e}",
        )

    def summary(self) -> str:
        """One or two lines of plain text: same field or not, and which contains which."""
        rel = (
            "the same field"
            if self.same
            else "A contains B"
            if self.a_contains_b
            else "B contains A"
            if self.b_contains_a
            else "neither field contains the other"
        )
        return block(
            f"{rel} (ranks A {self.rank_a}, B {self.rank_b}, together {self.rank_joint})",
            f"wrong with probability <= {self.error_bound:.1e} (seed {self.seed})",
        )

    def __bool__(self) -> bool:
        return self.same

    def to_dict(self) -> dict[str, Any]:
        return {
            "same": self.same,
            "rank_a": self.rank_a,
            "rank_b": self.rank_b,
            "rank_joint": self.rank_joint,
            "a_contains_b": self.a_contains_b,
            "b_contains_a": self.b_contains_a,
            "error_bound": self.error_bound,
            "seed": self.seed,
        }


def _as_exprs(exprs: Iterable[Any], names: Mapping[str, sp.Symbol], where: str) -> list[sp.Expr]:
    from obsnl.model.reading.parse import parse_expression

    return [parse_expression(e, names, where=where) for e in exprs]


def degree_bound(rational: Sequence[sp.Expr]) -> int:
    """Total degree of numerator plus denominator, maximised over rewritten expressions (atoms count 1)."""
    best = 1
    for e in rational:
        num, den = sp.fraction(sp.together(e))
        deg = 0
        for part in (num, den):
            try:
                deg += sp.Poly(
                    part, *sorted(part.atoms(sp.Symbol, sp.Function), key=sp.default_sort_key)
                ).total_degree()
            except (sp.PolynomialError, sp.GeneratorsError):
                deg += sp.count_ops(part) + 1
        best = max(best, deg)
    return best


def same_field(
    exprs_a: Iterable[Any],
    exprs_b: Iterable[Any],
    variables: Sequence[Any],
    *,
    constants: Sequence[Any] = (),
    seed: int = 0,
) -> FieldComparison:
    """Whether two sets of functions generate the same field (each locally a function of the other).

    Parameters
    ----------
    exprs_a, exprs_b : iterable
        Expressions (strings or sympy) in ``variables`` (and possibly other symbols, held constant).
    variables : sequence
        The variables (names or symbols) the functions depend on, e.g. states and parameters.
    constants : sequence
        Further names the expressions may use, held constant (known constants, inputs).
    seed : int
        Seed of the random point mod p.

    Returns
    -------
    FieldComparison
        Truthy when ``rank J_A == rank J_B == rank [J_A; J_B]``. The test is local (it compares
        algebraic closures): ``{a*b, a + b}`` and ``{a, b}`` generate the same field here.
        A false "same" needs the random point to be special: probability at most ``error_bound``.

    Examples
    --------
    >>> from obsnl.recombination import same_field
    >>> bool(same_field(["k/m", "c/m", "1/m"], ["m", "c", "k"], ["m", "c", "k"]))
    True
    >>> bool(same_field(["a*b"], ["a", "b"], ["a", "b"]))
    False
    """
    from obsnl.model.reading.parse import make_symbol

    vs = [v if isinstance(v, sp.Symbol) else make_symbol(str(v)) for v in variables]
    names = {v.name: make_symbol(v.name) for v in vs}
    names.update({str(c): make_symbol(str(c)) for c in constants})
    a, b = list(exprs_a), list(exprs_b)
    extra = set()
    for e in a + b:
        if isinstance(e, sp.Basic):
            extra |= {s.name for s in e.free_symbols}
    names.update({n: make_symbol(n) for n in extra if n not in names})
    ea = _as_exprs(a, names, "same_field (first set)")
    eb = _as_exprs(b, names, "same_field (second set)")
    var_syms = [names[v.name] for v in vs]
    compiled = _compile(ea + eb, var_syms)
    J = _jacobian(compiled, var_syms, seed, None)
    n = len(var_syms)
    ra, rb, rj = rank_mod_p(J[: len(ea)], n), rank_mod_p(J[len(ea) :], n), rank_mod_p(J, n)
    D = 2 * max(rj, 1) * degree_bound(compiled.rational)
    return FieldComparison(ra, rb, rj, min(1.0, D / PRIME), seed)
