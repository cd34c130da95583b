"""Fields of functions, decided modulo a large prime: Jacobians at random points and :func:`same_field`.

Two finite sets of functions ``A``, ``B`` of the variables ``z`` generate the same field up to
algebraic closure (each is locally a function of the other) exactly when
``rank J_A = rank J_B = rank [J_A; J_B]`` for the generic Jacobians. The ranks are taken at one
random point of GF(p), ``p = 2**62 - 57``. A rank can only drop at a special point: a nonzero
maximal minor (a polynomial of degree ``D`` after clearing denominators) vanishes at a uniformly
random point with probability at most ``D/p`` (Schwartz-Zippel); :func:`same_field` reports that bound.

Non-rational terms are evaluated the way the engines do (algorithms.md §3.6): every power
``b**e`` with a non-integer exponent becomes ``prod_f f**(k*c*m)`` over the factors ``f`` of
``b`` and the monomials ``m`` of ``e``; each ``f**m`` and each ``log f`` takes an independent
random value and differentiates by the chain rule, and ``exp`` likewise. By Ax's theorem these
values are algebraically independent of the rational functions for generic points, so the ranks
are the generic ones. Numeric fractional powers use an exact modular root.

This module also holds the small compiler shared with the power-series Jacobian of
:mod:`obsnl.jets`: sympy expressions -> a straight-line program of ``add/mul/powi/inv/atom``.
"""

from __future__ import annotations

import functools
import random
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import flint
import sympy as sp

from .errors import ModelError, NotSupportedError
from .model import NONSMOOTH_FUNCTIONS

__all__ = ["PRIME", "FieldComparison", "same_field", "jacobian_mod_p", "rank_mod_p", "nullspace_mod_p",
           "rational_reconstruction"]

#: The prime of every modular computation (62 bits, so that flint's nmod types hold it).
PRIME = 2**62 - 57


class Redraw(Exception):
    """The random point hit a zero denominator or a non-residue; draw another point."""


# --------------------------------------------------------------------------- canonical form
_TPow = sp.Function("_tpow")   # _tpow(f, m) = f**m, f a factor, m a monomial exponent (or a rational)
_TExp = sp.Function("_texp")   # _texp(m) = exp(m)
_TLog = sp.Function("_tlog")   # _tlog(f) = log(f)


def canonical(expr: sp.Expr) -> sp.Expr:
    """Rewrite non-integer powers, ``exp`` and ``log`` into independent atoms (see module doc)."""
    return _canonical(sp.sympify(expr))


@functools.lru_cache(maxsize=8192)
def _canonical(expr: sp.Expr) -> sp.Expr:
    if expr.has(*NONSMOOTH_FUNCTIONS):
        raise NotSupportedError(f"{expr} is not smooth; split the model into branches first (obsnl.split_branches)")

    def walk(e: sp.Basic) -> sp.Basic:
        if e.is_Atom:
            return e
        args = [walk(a) for a in e.args]
        if isinstance(e, sp.Pow):
            b, x = args
            if x.is_Integer:
                return b**x
            return _power(b, x)
        if isinstance(e, sp.exp):
            return _exponential(args[0])
        if isinstance(e, sp.log):
            return _logarithm(args[0])
        if isinstance(e, (sp.tanh, sp.sinh, sp.cosh)):
            return walk(e.rewrite(sp.exp))
        if isinstance(e, sp.Function) and not isinstance(e, sp.core.function.AppliedUndef):
            raise NotSupportedError(f"{type(e).__name__} is not supported by the modular evaluator; "
                                    f"rewrite it with exp/log or powers")
        return e.func(*args)

    return walk(expr)


@functools.lru_cache(maxsize=8192)
def _factors(b: sp.Expr) -> tuple[tuple[sp.Expr, int], ...]:
    """``b = prod f**k`` with numeric content and irreducible (or atom) factors ``f``."""
    out: list[tuple[sp.Expr, int]] = []
    for part, sign in zip(sp.fraction(sp.together(b)), (1, -1)):
        try:
            c, fl = sp.factor_list(part)
        except sp.PolynomialError:
            c, fl = 1, [(f, 1) for f in sp.Mul.make_args(part)]
        c = sp.Rational(c)
        out += [(sp.Integer(c.p), sign), (sp.Integer(c.q), -sign)]
        out += [(f, sign * int(k)) for f, k in fl]
    return tuple((f, k) for f, k in out if f != 1)


def _power(b: sp.Expr, x: sp.Expr) -> sp.Expr:
    out = sp.Integer(1)
    terms = sp.Add.make_args(sp.expand(x))
    for f, k in _factors(b):
        for t in terms:
            c, m = t.as_coeff_Mul()
            if m == 1:  # numeric part of the exponent
                kc = k * c
                out *= f**kc if kc.is_Integer else _TPow(f, kc)
            elif (k * c).is_Integer:
                out *= _TPow(f, m) ** (k * c)
            else:
                out *= _TPow(f, k * c * m)
    return out


def _exponential(g: sp.Expr) -> sp.Expr:
    out = sp.Integer(1)
    for t in sp.Add.make_args(sp.expand(g)):
        c, m = t.as_coeff_Mul()
        if m == 1:
            out *= _TExp(c)
        else:
            out *= _TExp(m) ** c if c.is_Integer else _TExp(c * m)
    return out


def _logarithm(g: sp.Expr) -> sp.Expr:
    return sp.Add(*[k * _TLog(f) for f, k in _factors(g)])


# --------------------------------------------------------------------------- straight-line programs
@dataclass(frozen=True)
class Program:
    """Expressions compiled to instructions ``(op, args)`` over registers; outputs are registers."""

    instructions: tuple[tuple, ...]
    outputs: tuple[int, ...]
    symbols: tuple[sp.Symbol, ...]   # registers 0..len-1 hold these symbols' values


def compile_program(exprs: Sequence[sp.Expr], symbols: Sequence[sp.Symbol]) -> Program:
    """Compile ``exprs`` (over ``symbols``) into a :class:`Program`; common subexpressions are shared."""
    symbols = tuple(symbols)
    index: dict[sp.Basic, int] = {s: i for i, s in enumerate(symbols)}
    instrs: list[tuple] = []

    def reg(e: sp.Basic) -> int:
        if e in index:
            return index[e]
        if isinstance(e, sp.Symbol):
            raise ModelError(f"{e} is not declared where this expression is evaluated")
        if e.is_Rational:
            ins: tuple = ("const", int(e.p), int(e.q))
        elif isinstance(e, sp.Add):
            ins = ("add", tuple(reg(a) for a in e.args))
        elif isinstance(e, sp.Mul):
            ins = ("mul", tuple(reg(a) for a in e.args))
        elif isinstance(e, sp.Pow) and e.exp.is_Integer:
            ins = ("powi", reg(e.base), int(e.exp))
        elif e.func == _TPow:
            f, m = e.args
            ins = ("tpow", reg(f), reg(m), (f, m), (int(m.p), int(m.q)) if m.is_Rational else None)
        elif e.func == _TExp:
            ins = ("texp", reg(e.args[0]), e.args[0])
        elif e.func == _TLog:
            ins = ("tlog", reg(e.args[0]), e.args[0])
        else:
            raise NotSupportedError(f"cannot evaluate {e} modulo a prime")
        instrs.append(ins)
        index[e] = len(symbols) + len(instrs) - 1
        return index[e]

    outs = tuple(reg(canonical(sp.sympify(e))) for e in exprs)
    return Program(tuple(instrs), outs, symbols)


def _inv(a: int, p: int = PRIME) -> int:
    if a % p == 0:
        raise Redraw("zero denominator")
    return pow(a, -1, p)


def _root(a: int, q: int, p: int = PRIME) -> int:
    from sympy.ntheory.residue_ntheory import nthroot_mod

    r = nthroot_mod(a % p, q, p)
    if r is None:
        raise Redraw("no modular root")
    return int(r)


def eval_dual(prog: Program, values: Mapping[sp.Symbol, int], variables: Sequence[sp.Symbol],
              rng: random.Random, atoms: dict | None = None) -> list[tuple[int, list[int]]]:
    """Values and gradients (w.r.t. ``variables``) of the outputs of ``prog`` at one point mod p.

    ``values`` gives every symbol of the program; atoms (``f**m``, ``log f``, ``exp m``) draw
    independent random values from ``rng``, remembered in ``atoms`` (pass the same dict to give
    the same atom the same value in several evaluations at one point).
    """
    p = PRIME
    n = len(variables)
    col = {v: j for j, v in enumerate(variables)}
    zero = [0] * n
    regs: list[tuple[int, list[int]]] = []
    for s in prog.symbols:
        g = list(zero)
        if s in col:
            g[col[s]] = 1
        regs.append((values[s] % p, g))
    atoms = {} if atoms is None else atoms

    def atom(key: Any) -> int:
        if key not in atoms:
            atoms[key] = rng.randrange(1, p)
        return atoms[key]

    for ins in prog.instructions:
        op = ins[0]
        if op == "const":
            regs.append((ins[1] * _inv(ins[2]) % p, zero))
        elif op == "add":
            v = sum(regs[a][0] for a in ins[1]) % p
            g = [sum(c) % p for c in zip(*(regs[a][1] for a in ins[1]))]
            regs.append((v, g))
        elif op == "mul":
            v, g = regs[ins[1][0]]
            for a in ins[1][1:]:
                w, h = regs[a]
                g = [(v * hj + w * gj) % p for gj, hj in zip(g, h)]
                v = v * w % p
            regs.append((v, g))
        elif op == "powi":
            v, g = regs[ins[1]]
            k = ins[2]
            if k < 0:
                v, k = _inv(v), -k
                g = [(-gj * v * v) % p for gj in g]
            vk1 = pow(v, k - 1, p)
            regs.append((vk1 * v % p, [(k * vk1 * gj) % p for gj in g]))
        elif op == "tpow":
            (fv, fg), (mv, mg), key, rat = regs[ins[1]], regs[ins[2]], ins[3], ins[4]
            if rat is not None:   # f**(a/q) exactly: a modular q-th root of f**a
                w = _root(pow(fv, rat[0], p) if rat[0] >= 0 else pow(_inv(fv), -rat[0], p), rat[1])
                lg = 0
            else:
                w = atom(("pow", key))
                lg = atom(("log", key[0]))
            fi = _inv(fv)
            regs.append((w, [w * (mgj * lg + mv * fgj * fi) % p for mgj, fgj in zip(mg, fg)]))
        elif op == "texp":
            w = atom(("exp", ins[2]))
            regs.append((w, [w * gj % p for gj in regs[ins[1]][1]]))
        elif op == "tlog":
            fv, fg = regs[ins[1]]
            fi = _inv(fv)
            regs.append((atom(("log", ins[2])), [gj * fi % p for gj in fg]))
        else:  # pragma: no cover
            raise NotSupportedError(op)
    return [regs[o] for o in prog.outputs]


# --------------------------------------------------------------------------- linear algebra mod p
def rank_mod_p(rows: Sequence[Sequence[int]], ncols: int) -> int:
    """Rank of an integer matrix modulo :data:`PRIME`."""
    if not rows or ncols == 0:
        return 0
    return flint.nmod_mat([list(r) for r in rows], PRIME).rank()


def nullspace_mod_p(rows: Sequence[Sequence[int]], ncols: int) -> list[list[int]]:
    """A basis of the right kernel ``{x : rows x = 0}`` mod :data:`PRIME`, as lists (rref-normalised)."""
    if ncols == 0:
        return []
    if not rows:
        return [[int(i == j) for i in range(ncols)] for j in range(ncols)]
    X, nullity = flint.nmod_mat([list(r) for r in rows], PRIME).nullspace()
    if not nullity:
        return []
    table = X.tolist()
    return [[int(table[i][j]) for i in range(ncols)] for j in range(nullity)]


def rational_reconstruction(a: int, p: int = PRIME) -> sp.Rational | None:
    """The rational ``n/d`` with ``n = a d mod p`` and ``|n|, d <= sqrt(p/2)``, or None."""
    a %= p
    bound = int((p // 2) ** 0.5)
    r0, r1, t0, t1 = p, a, 0, 1
    while r1 > bound:
        q = r0 // r1
        r0, r1 = r1, r0 - q * r1
        t0, t1 = t1, t0 - q * t1
    if t1 == 0 or abs(t1) > bound:
        return None
    return sp.Rational(r1 * (1 if t1 > 0 else -1), abs(t1))


def jacobian_mod_p(exprs: Sequence[sp.Expr], variables: Sequence[sp.Symbol], *, seed: int = 0,
                   point: Mapping[sp.Symbol, int] | None = None) -> list[list[int]]:
    """The Jacobian of ``exprs`` w.r.t. ``variables`` at a random point mod :data:`PRIME` (rows = exprs).

    Symbols that are not ``variables`` take random values too (they are constants here).
    """
    exprs = [sp.sympify(e) for e in exprs]
    syms = sorted(set(variables).union(*(e.free_symbols for e in exprs)), key=lambda s: s.name)
    prog = compile_program(exprs, syms)
    rng = random.Random(seed)
    for _ in range(20):
        pt = dict(point) if point is not None else {}
        pt.update({s: rng.randrange(1, PRIME) for s in syms if s not in pt})
        try:
            return [g for _, g in eval_dual(prog, pt, list(variables), rng)]
        except Redraw:
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

    def __bool__(self) -> bool:
        return self.same

    def to_dict(self) -> dict[str, Any]:
        return {"same": self.same, "rank_a": self.rank_a, "rank_b": self.rank_b, "rank_joint": self.rank_joint,
                "a_contains_b": self.a_contains_b, "b_contains_a": self.b_contains_a,
                "error_bound": self.error_bound, "seed": self.seed}


def _as_exprs(exprs: Iterable[Any], names: Mapping[str, sp.Symbol], where: str) -> list[sp.Expr]:
    from .parse import parse_expression

    return [parse_expression(e, names, where=where) for e in exprs]


def degree_bound(exprs: Sequence[sp.Expr]) -> int:
    """Total degree of numerator plus denominator, maximised over ``exprs`` (atoms count 1)."""
    best = 1
    for e in exprs:
        num, den = sp.fraction(sp.together(canonical(e)))
        deg = 0
        for part in (num, den):
            try:
                deg += sp.Poly(part, *sorted(part.atoms(sp.Symbol, sp.Function), key=sp.default_sort_key)).total_degree()
            except (sp.PolynomialError, sp.GeneratorsError):
                deg += sp.count_ops(part) + 1
        best = max(best, deg)
    return best


def same_field(exprs_a: Iterable[Any], exprs_b: Iterable[Any], variables: Sequence[Any], *,
               constants: Sequence[Any] = (), seed: int = 0) -> FieldComparison:
    """Whether two sets of functions generate the same field (each locally a function of the other).

    Parameters
    ----------
    exprs_a, exprs_b
        Expressions (strings or sympy) in ``variables`` (and possibly other symbols, held constant).
    variables
        The variables (names or symbols) the functions depend on, e.g. states and parameters.
    constants
        Further names the expressions may use, held constant (known constants, inputs).
    seed
        Seed of the random point mod p.

    Returns
    -------
    FieldComparison
        Truthy when ``rank J_A == rank J_B == rank [J_A; J_B]``. The test is local (it compares
        algebraic closures): ``{a*b, a + b}`` and ``{a, b}`` generate the same field here.
        A false "same" needs the random point to be special: probability at most ``error_bound``.

    Examples
    --------
    >>> from obsnl import same_field
    >>> bool(same_field(["k/m", "c/m", "1/m"], ["m", "c", "k"], ["m", "c", "k"]))
    True
    >>> bool(same_field(["a*b"], ["a", "b"], ["a", "b"]))
    False
    """
    from .parse import make_symbol

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
    J = jacobian_mod_p(ea + eb, var_syms, seed=seed)
    n = len(var_syms)
    ra, rb, rj = rank_mod_p(J[:len(ea)], n), rank_mod_p(J[len(ea):], n), rank_mod_p(J, n)
    D = 2 * max(rj, 1) * degree_bound(ea + eb)
    return FieldComparison(ra, rb, rj, min(1.0, D / PRIME), seed)
