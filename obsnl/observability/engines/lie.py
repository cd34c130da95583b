"""Lie derivatives of a model's outputs along its vector field, symbolic and bounded in size and time."""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

import sympy as sp

from obsnl.algebra.augment import atom_rates
from obsnl.algebra.series import Problem, TimeUp
from obsnl.errors import NotSupportedError

if TYPE_CHECKING:
    from flint import nmod_mpoly

__all__ = ["lie_derivatives", "ModularSystem", "OutOfInputs"]


class ModularSystem:
    """The augmented rational system of a problem as flint polynomials modulo a prime.

    The coordinates (``coords``) are the dynamic ones (states, time-varying atoms, the unknown inputs and their
    derivatives), then the constant ones (parameters, known constants without a given value, time-invariant atoms);
    ``symbols`` adds each known input and its derivatives. ``P[v] / Q`` is the rate of a dynamic coordinate ``v``
    over the common denominator ``Q``, and ``outputs`` holds each output as a (numerator, denominator) pair.

    Parameters
    ----------
    problem : Problem
        The compiled smooth model (:func:`obsnl.algebra.problem.make_problem`).
    p : int
        The prime modulus.
    n_input_derivs : int
        How many derivatives of each known input get a symbol (a Lie derivative that needs one more raises
        :class:`OutOfInputs`).
    deadline : float or None
        ``time.perf_counter()`` time limit (None: none).
    known : dict or None
        Values of known constants (symbol -> integer), replaced before differentiating (None: none).

    Raises
    ------
    TimeUp
        On the deadline while converting the vector field to polynomials.

    Examples
    --------
    >>> from obsnl import Model
    >>> from obsnl.algebra.augment import rationalize
    >>> from obsnl.algebra.problem import make_problem
    >>> m = Model(name="m", states=["x"], parameters=["a"], equations={"x": "-a*x"}, outputs={"y": "x"})
    >>> system = ModularSystem(make_problem(rationalize(m)), 101, 1)
    >>> system.coords, system.P
    ([x, a], {x: 100*v0*v1})
    """

    def __init__(
        self, problem: Problem, p: int, n_input_derivs: int, deadline: float | None = None, known: dict | None = None
    ) -> None:
        import flint

        self.deadline = deadline
        # known constants are replaced by their (generic, random) values before differentiating
        self.known = {c: sp.Integer(v) for c, v in (known or {}).items()}
        rat = problem.rational
        model = rat.model
        self.p = p
        # coordinates: dynamic ones first, then constants, then input derivative symbols
        self.w_chain: dict[sp.Symbol, list[sp.Symbol]] = {}
        for w in model.unknown_inputs:
            chain = [w] + [
                sp.Symbol(f"{w.name}_d{j}", real=True) for j in range(1, problem.unknown_input_derivatives + 1)
            ]
            self.w_chain[w] = chain
        tv_atoms = [a.symbol for a in rat.atoms if a.time_varying]
        ti_atoms = [a.symbol for a in rat.atoms if not a.time_varying]
        self.dynamic = list(model.states) + tv_atoms + [s for ch in self.w_chain.values() for s in ch]
        self.constant = list(model.parameters) + [c for c in model.known_constants if c not in self.known] + ti_atoms
        self.coords = self.dynamic + self.constant
        self.u_chain: dict[sp.Symbol, list[sp.Symbol]] = {
            u: [u] + [sp.Symbol(f"{u.name}_d{j}", real=True) for j in range(1, n_input_derivs + 1)]
            for u in model.inputs
        }
        self.inputs = [s for ch in self.u_chain.values() for s in ch]
        self.symbols = self.coords + self.inputs
        self.index = {s: i for i, s in enumerate(self.symbols)}
        self.ctx = flint.nmod_mpoly_ctx.get(tuple(f"v{i}" for i in range(len(self.symbols))), modulus=p)
        rates: dict[sp.Symbol, sp.Expr] = dict(rat.rhs)
        input_rates = {u: ch[1] for u, ch in self.u_chain.items() if len(ch) > 1}
        input_rates.update({w: ch[1] if len(ch) > 1 else sp.Integer(0) for w, ch in self.w_chain.items()})
        rates.update(atom_rates(rat, input_rates))
        for _w, ch in self.w_chain.items():
            for j, s in enumerate(ch):
                rates[s] = ch[j + 1] if j + 1 < len(ch) else sp.Integer(0)
        nums, dens = {}, {}
        for v in self.dynamic:
            nums[v], dens[v] = self._frac(rates[v])
        Q = self.ctx.constant(1)
        for d in dens.values():
            g = Q.gcd(d)
            Q = Q * (d // g)
        self.Q = Q
        self.P = {v: nums[v] * (Q // dens[v]) for v in self.dynamic}
        self.Q_const = Q.is_constant()
        self.dQ = self.S(Q) if not self.Q_const else None
        self.outputs = [self._frac(e) for e in rat.outputs.values()]

    def _frac(self, e: sp.Expr) -> tuple[nmod_mpoly, nmod_mpoly]:
        if self.known:
            e = e.xreplace(self.known)
        num, den = sp.fraction(sp.together(e))
        return self._poly(num), self._poly(den)

    def _poly(self, e: sp.Expr) -> nmod_mpoly:
        """``e`` as a flint polynomial mod p, built node by node (a power is taken in flint, never expanded
        by sympy, and the time limit is checked at every node); sympy's Poly only for other node types."""
        tree = self._tree(e)
        return tree if tree is not None else self._poly_sympy(e)

    def _tree(self, e: sp.Expr) -> nmod_mpoly | None:
        if self.deadline is not None and time.perf_counter() > self.deadline:
            raise TimeUp("time limit reached while converting the vector field to polynomials")
        if e.is_Symbol and e in self.index:
            return self.ctx.gens()[self.index[e]]
        if e.is_Rational:
            c = sp.Rational(e)
            return self.ctx.constant(int(c.p) % self.p * pow(int(c.q) % self.p, -1, self.p) % self.p)
        if e.is_Add or e.is_Mul:
            tried = [self._tree(a) for a in e.args]
            parts = [q for q in tried if q is not None]
            if len(parts) < len(tried):
                return None
            out = parts[0]
            for q in parts[1:]:
                out = out + q if e.is_Add else out * q
            return out
        if e.is_Pow and e.exp.is_Integer and e.exp >= 0:
            base = self._tree(e.base)
            return None if base is None else base ** int(e.exp)
        return None

    def _poly_sympy(self, e: sp.Expr) -> nmod_mpoly:
        gens = [s for s in self.symbols]
        free = e.free_symbols
        unknown = [s for s in free if s not in self.index]
        if unknown:  # pragma: no cover - every symbol is a coordinate
            raise NotSupportedError(f"internal: {unknown} not among the ORC variables")
        used = [s for s in gens if s in free]
        poly = sp.Poly(e, *used, domain="QQ") if used else None
        p = self.p
        if poly is None:
            c = sp.Rational(e)
            return self.ctx.constant(int(c.p) % p * pow(int(c.q), -1, p) % p)
        pos = [self.index[s] for s in used]
        n = len(self.symbols)
        d = {}
        for mon, c in poly.terms():
            exps = [0] * n
            for i, k in zip(pos, mon):
                exps[i] = k
            c = sp.Rational(c)
            d[tuple(exps)] = int(c.p) % p * pow(int(c.q) % p, -1, p) % p
        return self.ctx.from_dict(d)

    def _affordable(self, pairs: int) -> None:
        """Refuse a product of ``pairs`` term pairs that cannot finish before the deadline (flint cannot be
        interrupted mid-product; :data:`SECONDS_PER_PAIR` is a measured optimistic cost)."""
        if self.deadline is not None and pairs * SECONDS_PER_PAIR > self.deadline - time.perf_counter():
            raise TimeUp(
                f"time limit reached: a product of {pairs:.2e} term pairs would not finish in time (expression swell)"
            )

    def S(self, X: Any) -> Any:
        """Q times the extended Lie derivative of X."""
        degs = X.degrees()
        out = self.ctx.constant(0)
        for v in self.dynamic:
            i = self.index[v]
            if degs[i]:
                if self.deadline is not None and time.perf_counter() > self.deadline:
                    raise TimeUp("time limit reached while computing Lie derivatives")
                dX = X.derivative(i)
                self._affordable(len(self.P[v]) * len(dX))
                out += self.P[v] * dX
                if len(out) > MAX_TERMS:
                    raise TimeUp(f"a Lie derivative exceeds {MAX_TERMS} terms (expression swell)")
        extra = self.ctx.constant(0)
        for ch in self.u_chain.values():
            for j in range(len(ch) - 1):
                i = self.index[ch[j]]
                if degs[i]:
                    extra += self.ctx.gen(self.index[ch[j + 1]]) * X.derivative(i)
            if degs[self.index[ch[-1]]]:
                raise OutOfInputs()
        if not extra.is_zero():
            out += self.Q * extra
        return out


class OutOfInputs(Exception):
    """A Lie derivative needs a derivative of a known input beyond those :class:`ModularSystem` gave a symbol.

    Examples
    --------
    >>> from obsnl import Model
    >>> from obsnl.algebra.augment import rationalize
    >>> from obsnl.algebra.problem import make_problem
    >>> m = Model(name="m", states=["x"], parameters=["a"], inputs=["u"], equations={"x": "-a*x + u"},
    ...           outputs={"y": "x"})
    >>> system = ModularSystem(make_problem(rationalize(m)), 101, 0)
    >>> H, G = system.outputs[0]
    >>> derivatives = lie_derivatives(system, H, G, deadline=None)
    >>> [next(derivatives)[0] for _ in range(2)]  # y and y' (which holds u)
    [v0, 100*v0*v1 + v2]
    >>> try:  # y'' needs u'
    ...     next(derivatives)
    ... except OutOfInputs:
    ...     print("no symbol for u'")
    no symbol for u'
    """


#: A Lie derivative numerator with more terms than this ends the ORC (INCONCLUSIVE): expression swell.
MAX_TERMS = 2_000_000


#: Optimistic seconds per term pair of a flint product (measured ~2e-7 on a 6-variable product).
SECONDS_PER_PAIR = 5e-8


def lie_derivatives(system: ModularSystem, H: Any, G: Any, *, deadline: float | None) -> Iterator[tuple[Any, int, int]]:
    """Yield ``(N_k, a, b)`` with ``L^k h = N_k / (G**b Q**a)`` for k = 0, 1, ...

    Parameters
    ----------
    system : ModularSystem
        The model over the prime field.
    H, G : flint.nmod_mpoly
        Numerator and denominator of the output, polynomials mod p.
    deadline : float or None
        ``time.perf_counter()`` time limit.

    Yields
    ------
    tuple
        ``(N_k, a, b)``.

    Raises
    ------
    TimeUp
        On the deadline or expression swell.
    """
    N, a, b = H, 0, 1
    G_const = G.is_constant()
    dG = None if G_const else system.S(G)
    while True:
        yield N, a, b
        if deadline is not None and time.perf_counter() > deadline:
            raise TimeUp("time limit reached while computing Lie derivatives")
        SN = system.S(N)
        if len(SN) * max(len(G), 1) * max(len(system.Q), 1) > 3 * MAX_TERMS:
            raise TimeUp(f"a Lie derivative would exceed {3 * MAX_TERMS} terms (expression swell)")
        if G_const and system.Q_const:
            N = SN
        elif G_const:
            N = system.Q * SN - a * N * system.dQ
            a += 2
        elif system.Q_const:
            N = G * SN - b * N * dG
            b += 1
        else:
            N = G * system.Q * SN - b * N * system.Q * dG - a * N * G * system.dQ
            a += 2
            b += 1
        if len(N) > MAX_TERMS:
            raise TimeUp(f"a Lie derivative has {len(N)} terms (expression swell, limit {MAX_TERMS})")
