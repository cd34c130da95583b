"""Values and gradients (first-order jets) of straight-line programs at one point mod p.

The one evaluator of the exact side of the package. A *jet* is a value in GF(p) with its gradient
with respect to chosen variables (a dual number). Expressions are rewritten over atoms
(:mod:`obsnl.algebra.atoms`) and compiled into a straight-line program (:mod:`obsnl.algebra.slp`) whose leaves
are the symbols and the atoms. Arithmetic nodes follow the rules of dual numbers. An atom's
value is its stand-in (random), or exact where it is algebraic (a ``q``-th root of its argument;
``sin``/``cos`` from a random rational point ``(2t, 1 - t^2)/(1 + t^2)`` of the circle) or fixed by
given initial conditions; its gradient is the chain rule. The table of rules and why the ranks
are the generic ones (Ax's theorem) are in :mod:`obsnl.algebra.augment`.

Users: :mod:`obsnl.algebra.series` (order-0 jets of every node of a problem, where the Taylor steps
start), :mod:`obsnl.observability.engines.jacobian` (gradients of further expressions at the point of an observability
Jacobian) and :class:`Expressions` (free expressions at random points: ``same_field``, the
determining equations of the symmetry search, values of generators).
"""

from __future__ import annotations

import random
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import sympy as sp

from obsnl.algebra.atom_table import Atom
from obsnl.algebra.atoms import rewrite
from obsnl.algebra.modp import Field
from obsnl.algebra.slp import Op, compile_program
from obsnl.errors import NotSupportedError

__all__ = ["AtomJet", "atom_expressions", "atom_roots", "topological_order", "evaluate", "Expressions"]

Jet = tuple[int, list[int]]


@dataclass(frozen=True)
class AtomJet:
    """How the jet of one atom leaf is formed (node indices; -1 for none).

    Attributes
    ----------
    kind
        The atom's kind (:class:`obsnl.algebra.atom_table.Atom`).
    arg, den
        Nodes of the argument ``g`` and, for ``atan``, of ``1 + g**2``.
    partner
        For a sine: the node of its cosine (set together).
    q
        Degree of a root.
    fixed
        Node of a value fixed by given initial conditions.
    value, tau
        The stand-in; for a sine the parameter ``t`` of its point of the circle.
    """

    kind: str
    arg: int = -1
    den: int = -1
    partner: int = -1
    q: int = 0
    fixed: int = -1
    value: int = 0
    tau: int = 0


def atom_expressions(atoms: Sequence[Atom]) -> list[sp.Expr]:
    """What the atoms' jets need besides the leaves: the arguments, then ``1 + g**2`` per ``atan``."""
    return [a.arg for a in atoms if a.kind != "const"] + [1 + a.arg**2 for a in atoms if a.kind == "atan"]


def atom_roots(atoms: Sequence[Atom], roots: Sequence[int]) -> tuple[dict[sp.Symbol, int], dict[sp.Symbol, int]]:
    """The nodes computing :func:`atom_expressions` (``roots`` in that order): arguments, atan denominators.

    Parameters
    ----------
    atoms : sequence of Atom
        The atoms, in the order given to :func:`atom_expressions`.
    roots : sequence of int
        The program nodes of those expressions, in the same order.

    Returns
    -------
    tuple of dict
        ``(argument node per atom symbol, atan denominator node per atan symbol)``.
    """
    it = iter(roots)
    arg = {a.symbol: next(it) for a in atoms if a.kind != "const"}
    den = {a.symbol: next(it) for a in atoms if a.kind == "atan"}
    return arg, den


def topological_order(ops: Sequence[Op], leaf_deps: Mapping[int, Sequence[int]]) -> list[int]:
    """Every node after the nodes it needs: its operands, and for a leaf ``leaf_deps[leaf]`` (an atom
    after its argument, a state after its given initial value, a cosine after its sine).

    Parameters
    ----------
    ops : sequence of Op
        The program's nodes.
    leaf_deps : mapping of int to sequence of int
        For a leaf node, the nodes that must be computed before it.

    Returns
    -------
    list of int
        Every node index once, each after its dependencies.
    """
    n = len(ops)
    deps = [
        list(leaf_deps.get(i, ())) if op.kind == "leaf" else [j for j in (op.a, op.b) if j >= 0]
        for i, op in enumerate(ops)
    ]
    topo: list[int] = []
    mark = [0] * n
    for start in range(n):
        if mark[start]:
            continue
        stack = [(start, 0)]
        while stack:
            node, it = stack.pop()
            if it == 0:
                if mark[node] == 2:
                    continue
                mark[node] = 1
            if it < len(deps[node]):
                stack.append((node, it + 1))
                d = deps[node][it]
                if mark[d] == 0:
                    stack.append((d, 0))
                elif mark[d] == 1:  # pragma: no cover - programs are acyclic
                    raise NotSupportedError("internal: cyclic program")
            else:
                mark[node] = 2
                topo.append(node)
    return topo


def evaluate(
    ops: Sequence[Op],
    topo: Iterable[int],
    F: Field,
    M: int,
    given: Mapping[int, Jet | int],
    atoms: Mapping[int, AtomJet],
) -> tuple[list[int], list[list[int]]]:
    """Values and gradients (``M`` entries) of the nodes in ``topo``, in plain Python integers.

    ``given[leaf]`` is the jet of a leaf, or the node whose jet it copies (a state with a given
    initial value); ``atoms[leaf]`` says how an atom's jet is formed. Other leaves are 0.
    Raises :class:`obsnl.algebra.modp.Resample` on a zero denominator or a root of a non-residue.

    Parameters
    ----------
    ops : sequence of Op
        The program's nodes.
    topo : iterable of int
        The nodes to compute, in dependency order (:func:`topological_order`).
    F : Field
        The prime field of the computation.
    M : int
        Length of each gradient (number of unknowns).
    given : mapping of int to Jet or int
        Leaf jets ``(value, gradient)``, or the node a leaf copies.
    atoms : mapping of int to AtomJet
        How each atom leaf's jet is formed.

    Returns
    -------
    tuple of list
        ``(values, gradients)`` per node, residues mod ``F.p``.
    """
    p = F.p
    zero = [0] * M
    V = [0] * len(ops)
    G: list[list[int]] = [zero] * len(ops)

    def scal(c: int, g: list[int]) -> list[int]:
        return [c * x % p for x in g]

    def comb(a: int, x: list[int], b: int, y: list[int]) -> list[int]:
        return [(a * u + b * v) % p for u, v in zip(x, y)]

    for i in topo:
        op = ops[i]
        kind = op.kind
        if kind == "leaf":
            if i in atoms:
                _atom(i, atoms[i], V, G, F)
            elif i in given:
                x = given[i]
                V[i], G[i] = (V[x], G[x]) if isinstance(x, int) else x
        elif kind == "const":
            V[i] = F.el(op.arg)
        elif kind == "neg":
            V[i], G[i] = (-V[op.a]) % p, [(-x) % p for x in G[op.a]]
        elif kind == "scale":
            c = F.el(op.arg)
            V[i], G[i] = c * V[op.a] % p, scal(c, G[op.a])
        elif kind == "shift":
            V[i], G[i] = (V[op.a] + F.el(op.arg)) % p, G[op.a]
        elif kind in ("add", "sub"):
            sg = 1 if kind == "add" else p - 1
            V[i], G[i] = (V[op.a] + sg * V[op.b]) % p, comb(1, G[op.a], sg, G[op.b])
        elif kind == "mul":
            a, b = op.a, op.b
            V[i], G[i] = V[a] * V[b] % p, comb(V[a], G[b], V[b], G[a])
        elif kind == "div":
            a, b = op.a, op.b
            binv = F.inv(V[b])
            c = V[a] * binv % p
            V[i], G[i] = c, comb(binv, G[a], (p - c) * binv % p, G[b])
        else:  # pragma: no cover
            raise NotSupportedError(f"internal: op {kind}")
    return V, G


def _atom(i: int, a: AtomJet, V: list[int], G: list[list[int]], F: Field) -> None:
    """Jet of an atom at node ``i``: its value a stand-in (or exact, see the module doc), its gradient the true one."""
    p = F.p
    if a.kind == "const":
        V[i] = a.value
        return
    if a.kind == "cos":
        return  # set together with its sine
    g0, dg = V[a.arg], G[a.arg]
    fixed = a.fixed
    v = V[fixed] if fixed >= 0 and fixed != i else a.value
    if a.kind == "exp":
        V[i], G[i] = v, [v * x % p for x in dg]
    elif a.kind == "log":
        c = F.inv(g0)
        V[i], G[i] = v, [c * x % p for x in dg]
    elif a.kind == "atan":
        c = F.inv(V[a.den])
        V[i], G[i] = v, [c * x % p for x in dg]
    elif a.kind == "root":
        if fixed < 0 or fixed == i:
            v = F.root(g0, a.q)
        c = v * F.inv(a.q * g0 % p) % p
        V[i], G[i] = v, [c * x % p for x in dg]
    elif a.kind == "sin":
        if fixed >= 0:  # sin(0) = 0, cos(0) = 1
            s0, c0 = 0, 1
        else:
            t = a.tau
            d = F.inv((1 + t * t) % p)
            s0, c0 = 2 * t * d % p, (1 - t * t) * d % p
        V[i], G[i] = s0, [c0 * x % p for x in dg]
        V[a.partner], G[a.partner] = c0, [(p - s0) * x % p for x in dg]
    else:  # pragma: no cover
        raise NotSupportedError(f"atom kind {a.kind}")


def atom_deps(
    atoms: Sequence[Atom], leaf: Mapping[sp.Symbol, int], arg: Mapping[sp.Symbol, int], den: Mapping[sp.Symbol, int]
) -> dict[int, list[int]]:
    """The leaf dependencies of atoms for :func:`topological_order`."""
    deps: dict[int, list[int]] = {}
    for a in atoms:
        d = [t[a.symbol] for t in (arg, den) if a.symbol in t]
        if a.kind == "cos":
            d.append(leaf[a.partner])
        deps[leaf[a.symbol]] = d
    return deps


class Expressions:
    """Free expressions, rewritten and compiled once, evaluated at any point modulo any prime.

    Parameters
    ----------
    exprs : iterable of sympy.Expr
        sympy expressions (rational, or with the non-rational terms of :mod:`obsnl.algebra.augment`).
    symbols : iterable of sympy.Symbol
        Every symbol the expressions may use.

    Attributes
    ----------
    rational, atoms
        The expressions rewritten over the atoms (:func:`obsnl.algebra.atoms.rewrite`), and the atoms.

    Examples
    --------
    >>> import random, sympy as sp
    >>> x, y = sp.symbols("x y")
    >>> Expressions([x**2 * y, x / y], [x, y]).jets({x: 5, y: 11}, [x, y], 101, random.Random(0))
    [(73, [9, 25]), (28, [46, 25])]
    """

    def __init__(self, exprs: Iterable[sp.Expr], symbols: Iterable[sp.Symbol]) -> None:
        self.symbols = tuple(symbols)
        self.rational, self.atoms = rewrite([sp.sympify(e) for e in exprs], self.symbols)
        self.program = compile_program(
            self.rational + atom_expressions(self.atoms), self.symbols + tuple(a.symbol for a in self.atoms)
        )
        self._n = len(self.rational)
        self._arg, self._den = atom_roots(self.atoms, self.program.roots[self._n :])
        self._topo = topological_order(
            self.program.ops, atom_deps(self.atoms, self.program.leaves, self._arg, self._den)
        )

    def jets(
        self, values: Mapping[sp.Symbol, int], variables: Sequence[sp.Symbol], p: int, rng: random.Random
    ) -> list[Jet]:
        """Values and gradients (w.r.t. ``variables``) at the point ``values`` (every symbol) mod ``p``.

        The atoms take independent random stand-ins from ``rng``.
        Raises :class:`obsnl.algebra.modp.Resample` when the point makes a denominator vanish.
        """
        col = {v: j for j, v in enumerate(variables)}
        M = len(variables)
        leaf = self.program.leaves
        given: dict[int, Jet] = {}
        for s in self.symbols:
            g = [0] * M
            if s in col:
                g[col[s]] = 1
            given[leaf[s]] = (values[s] % p, g)
        atoms = {
            leaf[a.symbol]: AtomJet(
                a.kind,
                self._arg.get(a.symbol, -1),
                self._den.get(a.symbol, -1),
                leaf[a.partner] if a.partner is not None else -1,
                a.q,
                value=rng.randrange(1, p),
                tau=rng.randrange(p) if a.kind == "sin" else 0,
            )
            for a in self.atoms
        }
        V, G = evaluate(self.program.ops, self._topo, Field(p), M, given, atoms)
        return [(V[r], G[r]) for r in self.program.roots[: self._n]]

    def values(self, values: Mapping[sp.Symbol, int], p: int, rng: random.Random) -> list[int]:
        """Values only (see :meth:`jets`)."""
        return [v for v, _ in self.jets(values, (), p, rng)]
