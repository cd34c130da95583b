"""Straight-line programs: rational sympy expressions -> a flat list of binary operations.

Equal subexpressions are computed once (hash-consing of sympy subtrees), products with a
rational coefficient become one scaling, integer powers become products by binary powering and
negative powers one division. The program is evaluated by :mod:`obsnl.algebra.series` on truncated power
series of first-order jets modulo a prime.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import sympy as sp

from obsnl.errors import NotSupportedError

__all__ = ["Op", "Program", "compile_program"]


@dataclass(frozen=True)
class Op:
    """One instruction ``out = kind(args)``.

    Kinds: ``leaf`` (``arg`` is the symbol), ``const`` (``arg`` is a Rational), ``add``, ``sub``,
    ``mul``, ``div`` (``a``, ``b`` node indices), ``scale`` (``arg`` Rational times node ``a``),
    ``shift`` (``arg`` Rational plus node ``a``), ``neg``.
    """

    kind: str
    a: int = -1
    b: int = -1
    arg: object = None


@dataclass(frozen=True)
class Program:
    """A straight-line program; ``roots[i]`` is the node computing ``exprs[i]``."""

    ops: tuple[Op, ...]
    roots: tuple[int, ...]
    leaves: Mapping[sp.Symbol, int]

    def __len__(self) -> int:
        return len(self.ops)


class _Compiler:
    def __init__(self, leaves: Sequence[sp.Symbol]) -> None:
        self.ops: list[Op] = []
        self.memo: dict[sp.Basic, int] = {}
        self.leaf_set = set(leaves)
        self.leaf_index: dict[sp.Symbol, int] = {}
        for s in leaves:
            self.leaf_index[s] = self._emit(Op("leaf", arg=s))
            self.memo[s] = self.leaf_index[s]

    def _emit(self, op: Op) -> int:
        self.ops.append(op)
        return len(self.ops) - 1

    def const(self, c: sp.Rational) -> int:
        key = ("const", c)
        if key not in self.memo:
            self.memo[key] = self._emit(Op("const", arg=sp.Rational(c)))
        return self.memo[key]

    def node(self, e: sp.Expr) -> int:
        if e in self.memo:
            return self.memo[e]
        idx = self._build(e)
        self.memo[e] = idx
        return idx

    def _bin(self, kind: str, a: int, b: int) -> int:
        key = (kind, a, b) if kind in ("sub", "div") else (kind, min(a, b), max(a, b))
        if key not in self.memo:
            self.memo[key] = self._emit(Op(kind, a, b))
        return self.memo[key]

    def _un(self, kind: str, a: int, arg: object = None) -> int:
        key = (kind, a, arg)
        if key not in self.memo:
            self.memo[key] = self._emit(Op(kind, a, arg=arg))
        return self.memo[key]

    def _build(self, e: sp.Expr) -> int:
        if e.is_Symbol:
            raise NotSupportedError(f"internal: symbol {e} is not a declared leaf")
        if e.is_Rational:
            return self.const(e)
        if e.is_Add:
            coeff, rest = e.as_coeff_Add()
            terms = list(sp.Add.make_args(rest))
            pos = [t for t in terms if not t.could_extract_minus_sign()]
            neg = [-t for t in terms if t.could_extract_minus_sign()]
            acc: int | None = None
            for t in pos:
                n = self.node(t)
                acc = n if acc is None else self._bin("add", acc, n)
            for t in neg:
                n = self.node(t)
                acc = self._un("neg", n) if acc is None else self._bin("sub", acc, n)
            assert acc is not None  # an Add has a term besides its constant
            if coeff != 0:
                acc = self._un("shift", acc, sp.Rational(coeff))
            return acc
        if e.is_Mul:
            coeff, rest = e.as_coeff_Mul()
            num, den = [], []
            for f in sp.Mul.make_args(rest):
                if f.is_Pow and f.exp.is_Integer and f.exp < 0:
                    den.append(f.base ** (-f.exp))
                else:
                    num.append(f)
            acc = None
            for f in num:
                n = self.node(f)
                acc = n if acc is None else self._bin("mul", acc, n)
            if den:
                d: int | None = None
                for f in den:
                    n = self.node(f)
                    d = n if d is None else self._bin("mul", d, n)
                assert d is not None  # den is not empty
                if acc is None:
                    acc = self.const(sp.Integer(1))
                acc = self._bin("div", acc, d)
            if coeff != 1:
                acc = self.const(coeff) if acc is None else self._un("scale", acc, sp.Rational(coeff))
            assert acc is not None  # a Mul has a factor besides its coefficient
            return acc
        if e.is_Pow and e.exp.is_Integer:
            n = int(e.exp)
            base = self.node(e.base)
            if n == 0:
                return self.const(sp.Integer(1))
            if n < 0:
                return self._bin("div", self.const(sp.Integer(1)), self.node(e.base ** (-n)))
            result: int | None = None
            sq = base
            while n:
                if n & 1:
                    result = sq if result is None else self._bin("mul", result, sq)
                n >>= 1
                if n:
                    sq = self._bin("mul", sq, sq)
            assert result is not None  # n > 0 has a set bit
            return result
        raise NotSupportedError(
            f"{e} is not a rational expression; non-rational terms must be rewritten first (obsnl.algebra.augment)"
        )


def compile_program(exprs: Sequence[sp.Expr], leaves: Sequence[sp.Symbol]) -> Program:
    """Compile rational ``exprs`` over the symbols ``leaves`` into one :class:`Program`.

    The first ``len(leaves)`` nodes are the leaves, in order.

    Parameters
    ----------
    exprs : sequence of sympy.Expr
        Rational expressions to compute; their nodes become ``Program.roots`` in this order.
    leaves : sequence of sympy.Symbol
        The input symbols, one leaf node each.

    Returns
    -------
    Program
        The straight-line program (shared subexpressions computed once).

    Examples
    --------
    >>> import sympy as sp
    >>> x, k = sp.symbols("x k")
    >>> prog = compile_program([k*x**2 + 1, k*x**2/(x + 1)], [x, k])
    >>> [op.kind for op in prog.ops]
    ['leaf', 'leaf', 'mul', 'mul', 'shift', 'shift', 'div']
    """
    c = _Compiler(leaves)
    roots = tuple(c.node(sp.sympify(e)) for e in exprs)
    return Program(ops=tuple(c.ops), roots=roots, leaves=dict(c.leaf_index))
