"""Truncated power series of first-order jets modulo a prime (the arithmetic of the randomized test).

A *jet* is a value with its gradient with respect to the unknowns ``z`` (unknown initial states,
parameters, coefficients of unknown inputs). Every node of a straight-line program
(:mod:`obsnl.slp`) holds a truncated power series in ``t`` of jets, one int64 row
``[value, gradient]`` per coefficient, in GF(p). The solution of ``x' = f(x)`` is built in Taylor
mode: at step ``k`` every node gets its coefficient ``k`` and then ``x[k+1] = f[k]/(k+1)``
(algorithms.md §3.5). Products of series are convolutions, quotients the usual recursion, and the
atoms of :mod:`obsnl.augment` have their own recursions (``E' = E g'``, ``g l' = g'``, Miller's
recurrence for roots, the ``sin``/``cos`` pair).

This module prepares a problem (columns, order bound, program and its point-independent
:class:`Layout`), draws the random point, computes the order-0 jets of every node in plain Python
integers, and drives :class:`obsnl.taylor.Stepper`, which computes each further order for all
nodes at once through the program's tangent map.

Arithmetic is exact: residues are integers in ``[0, p)`` with ``p < 2**50``; array products use
:mod:`obsnl.modp` (a floating-point quotient estimate corrected in integers). No float ever decides
a rank.
"""

from __future__ import annotations

import math
import random
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from .errors import AnalysisError, NotSupportedError
from .problem import Layout, Problem, make_problem
from .slp import Program
from .taylor import Stepper

__all__ = ["Problem", "make_problem", "Field", "random_prime", "Point", "SeriesRun", "run_series", "Resample"]

PRIME_BITS = 50


class Resample(Exception):
    """The random point (or prime) hit a zero denominator or a non-residue; draw another."""


class TimeUp(Exception):
    """The time limit was reached."""


# --------------------------------------------------------------------------- the field
@dataclass(frozen=True)
class Field:
    """GF(p) for a prime p < 2**50: exact scalar inverses, rationals and roots (arrays: :mod:`obsnl.modp`)."""

    p: int

    def __post_init__(self) -> None:
        if not 2 < self.p < 2**PRIME_BITS:
            raise ValueError(f"prime must be below 2**{PRIME_BITS}")

    def inv(self, x: int) -> int:
        x = int(x) % self.p
        if x == 0:
            raise Resample("division by zero")
        return pow(x, -1, self.p)

    def el(self, c: sp.Rational) -> int:
        c = sp.Rational(c)
        return int(c.p) % self.p * self.inv(int(c.q)) % self.p

    def root(self, x: int, q: int) -> int:
        """A q-th root of x in GF(p) (Resample when there is none)."""
        x = int(x) % self.p
        if x == 0:
            raise Resample("root of zero")
        g = math.gcd(q, self.p - 1)
        if g == 1:
            return pow(x, pow(q, -1, self.p - 1), self.p)
        if q == 2:
            from flint import nmod

            if pow(x, (self.p - 1) // 2, self.p) != 1:
                raise Resample("non-residue")
            return int(nmod(x, self.p).sqrt())
        from sympy.ntheory import nthroot_mod

        r = nthroot_mod(x, q, self.p)
        if r is None:
            raise Resample("non-residue")
        return int(r)


def random_prime(rng: random.Random, bits: int = PRIME_BITS) -> int:
    """A random prime in [2**(bits-1), 2**bits)."""
    lo = 2 ** (bits - 1)
    start = rng.randrange(lo, 2**bits - 2**20)
    return int(sp.nextprime(start))


# --------------------------------------------------------------------------- evaluation
@dataclass
class Point:
    """The random choices of one run (for reproducibility and for the ORC's initial jets)."""

    p: int
    values: dict[sp.Symbol, int]
    input_series: dict[sp.Symbol, list[int]]
    unknown_inputs: dict[sp.Symbol, list[int]] = field(default_factory=dict)


@dataclass
class SeriesRun:
    """Output of :func:`run_series`: Jacobian rows per order, and the initial jets."""

    p: int
    rows: list[np.ndarray]  # rows[k] has shape (n_outputs, M): gradient of coefficient k of each output
    init: dict[sp.Symbol, tuple[int, np.ndarray]]  # t^0 jet of every leaf (states, atoms, ...)
    point: Point
    orders: int
    full_rank_at: int | None = None


def run_series(
    problem: Problem,
    rng: random.Random,
    *,
    K: int,
    p: int | None = None,
    deadline: float | None = None,
    stop: Callable[[list[np.ndarray], int], bool] | None = None,
    max_resample: int = 12,
    fixed: Mapping[sp.Symbol, int] | None = None,
) -> SeriesRun:
    """Evaluate the output series of ``problem`` to ``K`` terms at a random point.

    ``stop(rows, p)`` is called after each order and may end the computation early (full rank,
    or a stalled rank, see :mod:`obsnl.sedoglavic`); ``full_rank_at`` records where it did.
    ``fixed`` forces the values of some parameters or known constants (the ORC's second point).
    Raises :class:`AnalysisError` when every point makes a denominator vanish.
    """
    last: Exception | None = None
    for _ in range(max_resample):
        prime = p if p is not None else random_prime(rng)
        try:
            return _run_once(problem, Field(prime), rng, K, deadline, stop, fixed or {})
        except Resample as exc:
            last = exc
            if _ >= 2:  # a non-residue of a fixed number needs another prime
                p = None
            continue
    raise AnalysisError(
        f"model {problem.model.name!r}: a denominator (or the argument of a root/log) vanishes at every "
        f"random point tried ({last}); check the model and the given initial conditions"
    )


def _random_point(problem: Problem, F: Field, rng: random.Random, K: int, fixed: Mapping[sp.Symbol, int]):
    """Draw parameters, constants, free initial states, input series, unknown-input coefficients and
    atom stand-ins (always in this order, so that a seed gives the same point for any engine)."""
    model, rat, p = problem.model, problem.rational, F.p
    values: dict[sp.Symbol, int] = {}
    for s in model.parameters + model.known_constants:
        values[s] = rng.randrange(p)
        if s in fixed:
            values[s] = fixed[s] % p
    for s in model.states:
        if s not in rat.ic_values:
            values[s] = rng.randrange(p)
    inputs: dict[sp.Symbol, list[int]] = {}
    for u in model.inputs:
        nz = K + 1 if problem.input_derivatives is None else min(K + 1, problem.input_derivatives + 1)
        inputs[u] = [rng.randrange(p) for _ in range(nz)] + [0] * (K + 1 - nz)
    w_coeffs = {w: [rng.randrange(p) for _ in range(problem.unknown_input_derivatives + 1)]
                for w in model.unknown_inputs}
    stand_in = {a.symbol: rng.randrange(p) for a in rat.atoms}
    tau = {a.symbol: rng.randrange(p) for a in rat.atoms if a.kind == "sin"}
    return values, inputs, w_coeffs, stand_in, tau


def _initial_jets(problem: Problem, F: Field, point: tuple) -> np.ndarray:
    """Order-0 jets of every node, ``(n_nodes, M + 1)`` (plain Python integers while computing)."""
    values, inputs, w_coeffs, stand_in, tau = point
    model, rat, lay, prog = problem.model, problem.rational, problem.layout, problem.program
    p, M = F.p, problem.size
    col = {name: j for j, name in enumerate(problem.columns)}
    known = set(model.known_initial_conditions)
    atoms = {a.symbol: a for a in rat.atoms}
    params, consts = set(model.parameters), set(model.known_constants)
    state_set, inputs_set = set(model.states), set(model.inputs)
    zero = [0] * M
    V = [0] * len(prog.ops)
    G: list[list[int]] = [zero] * len(prog.ops)

    def unit(j: int) -> list[int]:
        g = [0] * M
        g[j] = 1
        return g

    def scal(c: int, g: list[int]) -> list[int]:
        return [c * x % p for x in g]

    def comb(a: int, x: list[int], b: int, y: list[int]) -> list[int]:
        return [(a * u + b * v) % p for u, v in zip(x, y)]

    for i in lay.topo:
        op = prog.ops[i]
        kind = op.kind
        if kind == "leaf":
            s = op.arg
            if s in state_set:
                if s in rat.ic_values:
                    V[i], G[i] = V[lay.ic_root[s]], G[lay.ic_root[s]]
                else:
                    V[i] = values[s]
                    if s not in known:
                        G[i] = unit(col[s.name])
            elif s in params:
                V[i], G[i] = values[s], unit(col[s.name])
            elif s in consts:
                V[i] = values[s]
            elif s in inputs_set:
                V[i] = inputs[s][0]
            elif s in atoms:
                _atom0(i, atoms[s], V, G, F, lay, prog, stand_in, tau)
            else:  # unknown input: w(0) = c0, gradient on its column 0
                V[i], G[i] = w_coeffs[s][0] % p, unit(problem.input_columns[s.name][0])
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
    X0 = np.zeros((len(V), M + 1), dtype=np.int64)
    X0[:, 0] = V
    if M:
        X0[:, 1:] = G
    return X0


def _atom0(i, a, V, G, F: Field, lay: Layout, prog: Program, stand_in, tau) -> None:
    """Order-0 jet of atom ``a`` at node ``i`` (its value is a stand-in, its gradient the true one)."""
    p = F.p
    if a.kind == "const":
        V[i] = stand_in[a.symbol]
        return
    if a.kind == "cos":
        return  # set together with its sine
    g = lay.atom_arg_root[a.symbol]
    g0, dg = V[g], G[g]
    fixed = lay.init_root.get(a.symbol)
    v = V[fixed] if fixed is not None and fixed != i else stand_in[a.symbol]
    if a.kind == "exp":
        V[i], G[i] = v, [v * x % p for x in dg]
    elif a.kind == "log":
        c = F.inv(g0)
        V[i], G[i] = v, [c * x % p for x in dg]
    elif a.kind == "atan":
        c = F.inv(V[lay.atan_q_root[a.symbol]])
        V[i], G[i] = v, [c * x % p for x in dg]
    elif a.kind == "root":
        if fixed is None or fixed == i:
            v = F.root(g0, a.q)
        c = v * F.inv(a.q * g0 % p) % p
        V[i], G[i] = v, [c * x % p for x in dg]
    elif a.kind == "sin":
        c_node = prog.leaves[a.partner]
        if fixed is not None:  # sin(0) = 0, cos(0) = 1
            s0, c0 = 0, 1
        else:
            t = tau[a.symbol]
            d = F.inv((1 + t * t) % p)
            s0, c0 = 2 * t * d % p, (1 - t * t) * d % p
        V[i], G[i] = s0, [c0 * x % p for x in dg]
        V[c_node], G[c_node] = c0, [(p - s0) * x % p for x in dg]
    else:  # pragma: no cover
        raise NotSupportedError(f"atom kind {a.kind}")


def _run_once(
    problem: Problem, F: Field, rng: random.Random, K: int, deadline: float | None,
    stop: Callable[[list[np.ndarray], int], bool] | None,
    fixed: Mapping[sp.Symbol, int],
) -> SeriesRun:
    model, lay, p, M = problem.model, problem.layout, F.p, problem.size
    drawn = _random_point(problem, F, rng, K, fixed)
    values, inputs, w_coeffs, _, _ = drawn
    X0 = _initial_jets(problem, F, drawn)
    init = {s: (int(X0[i, 0]), X0[i, 1:].copy()) for s, i in problem.program.leaves.items()}
    point = Point(p=p, values=values, input_series=inputs, unknown_inputs=w_coeffs)
    rows: list[np.ndarray] = [X0[list(lay.out_roots), 1:].copy()]
    if stop is not None and stop(rows, p):
        return SeriesRun(p, rows, init, point, 1, full_rank_at=1)
    if K <= 1:
        return SeriesRun(p, rows, init, point, len(rows))
    # coefficients k >= 1 of the given sources: known inputs (values only), unknown inputs
    # w = sum_j c_j t^j / j! (value and the gradient on column j)
    given = np.zeros((K, len(lay.input_nodes) + len(lay.winput_nodes), M + 1), dtype=np.int64)
    for r, u in enumerate(model.inputs):
        given[:, r, 0] = inputs[u][:K]
    base = len(lay.input_nodes)
    for r, w in enumerate(model.unknown_inputs):
        fact = 1
        for j, c in enumerate(w_coeffs[w]):
            if j:
                fact = fact * j % p
            if 1 <= j < K:
                ifact = F.inv(fact)
                given[j, base + r, 0] = c * ifact % p
                given[j, base + r, 1 + problem.input_columns[w.name][j]] = ifact
    stepper = Stepper(lay.plan, X0, p, K, lay.rhs_roots, lambda k: given[k], lay.tv)
    full_at = None
    for k in range(1, K):
        if deadline is not None and time.perf_counter() > deadline:
            raise TimeUp(f"time limit reached after {k} of {K} series terms")
        stepper.step(k)
        rows.append(stepper.gradients(lay.out_roots, k))
        if stop is not None and stop(rows, p):
            full_at = k + 1
            break
    return SeriesRun(p, rows, init, point, len(rows), full_rank_at=full_at)
