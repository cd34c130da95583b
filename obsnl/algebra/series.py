"""Truncated power series of first-order jets modulo a prime (the arithmetic of the randomized test).

A *jet* is a value with its gradient with respect to the unknowns ``z`` (unknown initial states,
parameters, coefficients of unknown inputs). Every node of a straight-line program
(:mod:`obsnl.algebra.slp`) holds a truncated power series in ``t`` of jets, one int64 row
``[value, gradient]`` per coefficient, in GF(p). The solution of ``x' = f(x)`` is built in Taylor
mode: at step ``k`` every node gets its coefficient ``k`` and then ``x[k+1] = f[k]/(k+1)``
(algorithms.md §3.5). Products of series are convolutions, quotients the usual recursion, and the
atoms of :mod:`obsnl.algebra.augment` have their own recursions (``E' = E g'``, ``g l' = g'``, Miller's
recurrence for roots, the ``sin``/``cos`` pair).

This module draws the random point of a prepared problem (:mod:`obsnl.algebra.problem`), computes the
order-0 jets of every node in plain Python integers (:func:`obsnl.algebra.jets.evaluate`), and drives
:class:`obsnl.algebra.taylor.Stepper`, which computes each further order for all nodes at once through
the program's tangent map.

Arithmetic is exact: residues are integers in ``[0, p)`` with ``p < 2**50``; array products use
:mod:`obsnl.algebra.modp` (a floating-point quotient estimate corrected in integers). No float ever decides
a rank.
"""

from __future__ import annotations

import math
import random
import time
from collections.abc import Callable, Mapping, MutableMapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from obsnl.algebra.jets import AtomJet, evaluate
from obsnl.algebra.modp import Field, Resample, random_prime
from obsnl.algebra.problem import Problem, make_problem
from obsnl.algebra.taylor import Stepper
from obsnl.errors import AnalysisError

__all__ = [
    "Problem",
    "make_problem",
    "Field",
    "random_prime",
    "Point",
    "SeriesRun",
    "run_series",
    "Resample",
    "draw_prime",
    "prime_density",
]


class TimeUp(Exception):
    """The time limit was reached."""


#: A drawn point as :func:`_random_point` returns it: values, input series, unknown-input coefficients, atom
#: stand-ins and, for each sine, the parameter of its point of the circle.
_Drawn = tuple[
    dict[sp.Symbol, int],
    dict[sp.Symbol, list[int]],
    dict[sp.Symbol, list[int]],
    dict[sp.Symbol, int],
    dict[sp.Symbol, int],
]


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
    values: list[np.ndarray] = field(default_factory=list)  # values[k][i]: value of coefficient k of output i


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
    states: Mapping[sp.Symbol, int] | None = None,
    input_series: Mapping[sp.Symbol, Sequence[int]] | None = None,
    atom_values: MutableMapping[tuple, tuple[int, int]] | None = None,
) -> SeriesRun:
    """Evaluate the output series of ``problem`` to ``K`` terms at a random point.

    ``stop(rows, p)`` is called after each order and may end the computation early (full rank,
    or a stalled rank, see :mod:`obsnl.observability.engines.sedoglavic`); ``full_rank_at`` records where it did.
    ``fixed`` forces the values of some parameters or known constants (the ORC's second point).
    The joint verdict (:mod:`obsnl.observability.joint.verdict`) evaluates several smooth models at one
    point: ``states`` forces the values of free initial states, ``input_series`` the coefficients of
    known inputs (missing ones are 0), and ``atom_values`` is a table shared by such calls, keyed
    ``(kind, argument, q, time_varying)``, giving each atom the stand-in (and angle) already drawn
    for the same atom, or recording the one drawn now. Every value is drawn first and then replaced,
    so the random stream, and without these arguments the point, are unchanged.
    The run also records the values of the output coefficients (``values``).
    Raises :class:`AnalysisError` when every point makes a denominator vanish.

    Parameters
    ----------
    problem : Problem
        The compiled smooth model (:func:`obsnl.algebra.problem.make_problem`).
    rng : random.Random
        Source of the random prime and point.
    K : int
        Number of series terms (orders) to compute.
    p : int or None
        The prime to use; None draws one with :func:`draw_prime`.
    deadline : float or None
        ``time.perf_counter()`` value after which the computation stops; None: no limit.
    stop : callable or None
        ``stop(rows, p) -> bool``, called after each order; True ends the run early.
    max_resample : int
        How many random points are tried before giving up.
    fixed, states, input_series, atom_values : mapping or None
        Forced parameter/constant values, free initial states, known-input coefficients and the
        shared atom table (all values mod p), as described above.

    Returns
    -------
    SeriesRun
        The prime, Jacobian rows per order, point, ``full_rank_at`` and output coefficient values.

    Raises
    ------
    AnalysisError
        When every point tried makes a denominator vanish.
    """
    last: Exception | None = None
    forced = (states or {}, input_series or {}, atom_values)
    for _ in range(max_resample):
        prime = p if p is not None else draw_prime(problem, rng)
        try:
            return _run_once(problem, Field(prime), rng, K, deadline, stop, fixed or {}, forced)
        except Resample as exc:
            last = exc
            if _ >= 2:  # a non-residue of a fixed number needs another prime
                p = None
            continue
    raise AnalysisError(
        f"model {problem.model.name!r}: a denominator (or the argument of a root/log) vanishes at every "
        f"random point tried ({last}); check the model and the given initial conditions"
    )


def _number_roots(problem: Problem) -> list[tuple[int, int]]:
    return [(int(a.arg), a.q) for a in problem.rational.atoms if a.kind == "root" and a.arg.is_Integer]


def _admissible(p: int, roots: list[tuple[int, int]]) -> bool:
    h = (p - 1) // 2
    return p % 4 == 3 and all(math.gcd(q, h) == 1 and pow(r, h, p) == 1 for r, q in roots)


def draw_prime(problem: Problem, rng: random.Random, *, tries: int = 20000) -> int:
    """A random prime for ``problem``: any prime, or, when the model has roots of numbers
    (:meth:`obsnl.algebra.atoms.Rewriter.number_power`), one in which each of them exists and is taken
    as the root that is a square mod p (:meth:`obsnl.algebra.modp.Field.root`): ``p = 3 mod 4``, every
    root's prime a square mod p, and every degree prime to ``(p-1)/2``. Such a prime is a prime of
    degree one of the roots' number field, so the computation stays exact; :func:`prime_density`
    says how many primes qualify.

    Parameters
    ----------
    problem : Problem
        The compiled model whose roots of numbers constrain the prime.
    rng : random.Random
        Source of the random primes.
    tries : int
        How many random primes are tested before giving up.

    Returns
    -------
    int
        A prime of :data:`obsnl.algebra.modp.PRIME_BITS` bits admissible for ``problem``.

    Raises
    ------
    AnalysisError
        When no admissible prime is found in ``tries`` draws.
    """
    roots = _number_roots(problem)
    if not roots:
        return random_prime(rng)
    for _ in range(tries):
        p = random_prime(rng)
        if _admissible(p, roots):
            return p
    raise AnalysisError(
        f"model {problem.model.name!r}: no prime found in which the roots of numbers "
        f"{sorted(set(roots))} exist; write these constants as rational numbers"
    )


def prime_density(problem: Problem) -> float:
    """Density among all primes of those :func:`draw_prime` accepts (1 without roots of numbers).

    By Dirichlet and quadratic reciprocity, ``p = 3 mod 4`` and each of ``k`` distinct primes being a
    square mod p are independent conditions of density 1/2 each; an odd prime ``l`` dividing a degree
    must not divide ``(p-1)/2``, density ``(l-2)/(l-1)``.
    """
    roots = _number_roots(problem)
    if not roots:
        return 1.0
    dens = 0.5 ** (1 + len({r for r, _ in roots}))
    odd = {int(l) for _, q in roots for l in sp.primefactors(q) if l != 2}
    for l in odd:
        dens *= (l - 2) / (l - 1)
    return dens


def _random_point(
    problem: Problem,
    F: Field,
    rng: random.Random,
    K: int,
    fixed: Mapping[sp.Symbol, int],
    forced: tuple = ({}, {}, None),
) -> _Drawn:
    """Draw parameters, constants, free initial states, input series, unknown-input coefficients and
    atom stand-ins (always in this order, so that a seed gives the same point for any engine), then
    apply the values forced by ``forced = (states, input series, atom table)`` (see :func:`run_series`)."""
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
    w_coeffs = {
        w: [rng.randrange(p) for _ in range(problem.unknown_input_derivatives + 1)] for w in model.unknown_inputs
    }
    stand_in = {a.symbol: rng.randrange(p) for a in rat.atoms}
    tau = {a.symbol: rng.randrange(p) for a in rat.atoms if a.kind == "sin"}
    f_states, f_inputs, table = forced
    for s, v in f_states.items():
        if s in values and s not in rat.ic_values:
            values[s] = int(v) % p
    for u in model.inputs:
        if u in f_inputs:
            given = [int(c) % p for c in list(f_inputs[u])[: K + 1]]
            inputs[u] = given + [0] * (K + 1 - len(given))
    if table is not None:
        for a in rat.atoms:
            key = (a.kind, a.arg, a.q, a.time_varying)
            if key in table:
                stand_in[a.symbol], t = table[key]
                if a.kind == "sin":
                    tau[a.symbol] = t
            else:
                table[key] = (stand_in[a.symbol], tau.get(a.symbol, 0))
    return values, inputs, w_coeffs, stand_in, tau


def _initial_jets(problem: Problem, F: Field, point: tuple) -> np.ndarray:
    """Order-0 jets of every node, ``(n_nodes, M + 1)`` (:func:`obsnl.algebra.jets.evaluate` on the drawn point)."""
    values, inputs, w_coeffs, stand_in, tau = point
    model, rat, lay, prog = problem.model, problem.rational, problem.layout, problem.program
    p, M = F.p, problem.size
    col = {name: j for j, name in enumerate(problem.columns)}
    leaf = prog.leaves
    zero = [0] * M

    def unit(j: int) -> list[int]:
        g = [0] * M
        g[j] = 1
        return g

    given: dict[int, tuple[int, list[int]] | int] = {}
    for s in model.states:
        if s in rat.ic_values:
            given[leaf[s]] = lay.ic_root[s]
        else:
            given[leaf[s]] = (values[s], zero if s in model.known_initial_conditions else unit(col[s.name]))
    for s in model.parameters:
        given[leaf[s]] = (values[s], unit(col[s.name]))
    for s in model.known_constants:
        given[leaf[s]] = (values[s], zero)
    for u in model.inputs:
        given[leaf[u]] = (inputs[u][0], zero)
    for w in model.unknown_inputs:  # w(0) = c0, gradient on its column 0
        given[leaf[w]] = (w_coeffs[w][0] % p, unit(problem.input_columns[w.name][0]))
    atoms = {
        leaf[a.symbol]: AtomJet(
            a.kind,
            lay.atom_arg_root.get(a.symbol, -1),
            lay.atan_q_root.get(a.symbol, -1),
            leaf[a.partner] if a.partner is not None else -1,
            a.q,
            lay.init_root.get(a.symbol, -1),
            stand_in[a.symbol],
            tau.get(a.symbol, 0),
        )
        for a in rat.atoms
    }
    V, G = evaluate(prog.ops, lay.topo, F, M, given, atoms)
    X0 = np.zeros((len(V), M + 1), dtype=np.int64)
    X0[:, 0] = V
    if M:
        X0[:, 1:] = G
    return X0


def _run_once(
    problem: Problem,
    F: Field,
    rng: random.Random,
    K: int,
    deadline: float | None,
    stop: Callable[[list[np.ndarray], int], bool] | None,
    fixed: Mapping[sp.Symbol, int],
    forced: tuple = ({}, {}, None),
) -> SeriesRun:
    model, lay, p, M = problem.model, problem.layout, F.p, problem.size
    drawn = _random_point(problem, F, rng, K, fixed, forced)
    values, inputs, w_coeffs, _, _ = drawn
    X0 = _initial_jets(problem, F, drawn)
    init = {s: (int(X0[i, 0]), X0[i, 1:].copy()) for s, i in problem.program.leaves.items()}
    point = Point(p=p, values=values, input_series=inputs, unknown_inputs=w_coeffs)
    rows: list[np.ndarray] = [X0[list(lay.out_roots), 1:].copy()]
    vals: list[np.ndarray] = [X0[list(lay.out_roots), 0].copy()]
    if stop is not None and stop(rows, p):
        return SeriesRun(p, rows, init, point, 1, full_rank_at=1, values=vals)
    if K <= 1:
        return SeriesRun(p, rows, init, point, len(rows), values=vals)
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
        vals.append(stepper.values(lay.out_roots, k))
        if stop is not None and stop(rows, p):
            full_at = k + 1
            break
    return SeriesRun(p, rows, init, point, len(rows), full_rank_at=full_at, values=vals)
