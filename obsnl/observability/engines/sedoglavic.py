"""Sedoglavic's probabilistic observability test (J. Symbolic Comput. 33(5):735-755, 2002).

At a random point of GF(p) (random prime ``p < 2**50``, random parameters, initial states,
input series and unknown-input coefficients) the truncated power-series solution of the model
and its sensitivities to the unknowns are computed in Taylor mode on first-order jets
(:mod:`obsnl.algebra.series`, algorithms.md §3.5). Row ``(k, i)`` of the Jacobian is the gradient of the
``t**k`` coefficient of output ``i``; its rank and kernel over GF(p) (an echelon basis grown row by
row, :class:`obsnl.algebra.modp.Echelon`) give the observable and unobservable unknowns and the
transcendence degree (rank deficit), see :mod:`obsnl.algebra.bounds`.

- **Order.** ``K = dim`` series terms (states + parameters + augmented functions + unknown-input
  derivatives; Lie derivatives of order ``0..K-1``), which suffices with generic initial values,
  and ``K = min(dim, M)`` (``M`` unknowns) when no initial condition is known (the rank then grows
  at every order until it stops for good, see :meth:`obsnl.algebra.problem.Problem.order_bound`); the
  computation stops earlier as soon as the rank is full. With specific initial values
  (``x(0) = 0``) ``2*dim + n`` terms are used (see :meth:`obsnl.algebra.series.Problem.order_bound`).
- **Known inputs** are generic: random series with every coefficient random (or the first
  ``input_derivatives + 1`` only). **Unknown inputs** ``w`` are polynomials of degree
  ``unknown_input_derivatives`` with unknown coefficients (STRIKE-GOLDD's ``nnzDerW``), or, when
  arbitrary, have as many unknown Taylor coefficients as series terms are read
  (:func:`obsnl.algebra.problem.arbitrary_terms`); ``w`` is observable when its value ``w(0)`` is.
- **Known initial conditions** are not unknowns: without a value they are generic (random), with a
  value (a number, or an expression in parameters and known constants) they take it exactly.
  Known constants are generic (random).
- **Non-rational terms** are augmented as in :mod:`obsnl.algebra.augment` (exact, not conservative).
- **Probability.** Sedoglavic's Prop. 3.3 for the prime drawn, one-sided: full rank is certain;
  an unobservable verdict is confirmed by a second independent run (:mod:`obsnl.algebra.bounds`).
"""

from __future__ import annotations

import random

import numpy as np

from obsnl.algebra.bounds import BlockOutcome, failure_bound
from obsnl.algebra.modp import Echelon
from obsnl.algebra.series import Problem, SeriesRun, TimeUp, prime_density, run_series

__all__ = ["sedoglavic_block", "RankTracker", "stall_safe"]

_MAX_RUNS = 4


class RankTracker:
    """Rank of the Jacobian rows seen so far (an incremental echelon basis mod p); stops at full rank,
    and, when ``stall`` holds, at the first order that adds no rank.

    The stall rule (``stall=True``) is used only when every initial state is an unknown, no initial
    value is specific and there is no unknown input: then the rank of the Jacobian grows at every
    order until it stops for good (:meth:`obsnl.algebra.problem.Problem.order_bound`: if the outputs'
    ``j``-th coefficients depend on the lower ones, differentiating along the flow gives the same for
    ``j + 1``), so an order that adds nothing ends the growth. A stall at a special point could only
    make the rank look smaller; such a verdict is unobservable and, as every unobservable verdict,
    needs a second independent run that agrees.
    """

    def __init__(self, M: int, *, stall: bool = False) -> None:
        self.M = M
        self.basis: Echelon | None = None
        self.seen = 0
        self.stall = stall
        self.stalled = False

    def __call__(self, rows: list[np.ndarray], p: int) -> bool:
        if self.basis is None or self.basis.p != p:  # a new prime after a resample
            self.basis, self.seen = Echelon(self.M, p), 0
        before = self.basis.rank
        for block in rows[self.seen :]:
            for r in block:
                self.basis.add(r)
        grew = self.basis.rank > before
        new_orders = len(rows) - self.seen
        self.seen = len(rows)
        if self.basis.rank == self.M:
            return True
        if self.stall and len(rows) >= 2 and new_orders == 1 and not grew:
            self.stalled = True
            return True
        return False


def stall_safe(problem: Problem) -> bool:
    """True when the stall rule of :class:`RankTracker` holds for ``problem`` (every initial state
    unknown, none specific, no unknown input)."""
    model = problem.model
    return not (model.known_initial_conditions or problem.specific or model.unknown_inputs)


def _one_run(problem: Problem, rng: random.Random, deadline: float | None) -> tuple[SeriesRun, int, list[bool]]:
    """One run: rank and per-column classes of the Jacobian at one random point (exact, mod p)."""
    tracker = RankTracker(problem.size, stall=stall_safe(problem))
    run = run_series(problem, rng, K=problem.order_bound(), deadline=deadline, stop=tracker)
    tracker(run.rows, run.p)  # rows the stop rule has not seen (none, unless it was never called)
    basis = tracker.basis
    assert basis is not None  # the call above set it
    return run, basis.rank, basis.unobservable()


def sedoglavic_block(
    problem: Problem,
    *,
    seed: object,
    deadline: float | None = None,
    bound_args: dict | None = None,
    target: float = 0.01,
) -> BlockOutcome:
    """Run the randomized test on one block (a smooth, decomposed model) and confirm it.

    ``seed`` is any value fixing the random streams (``f"sedoglavic:{seed}:{run}"``);
    ``bound_args`` are the sizes for :func:`obsnl.algebra.bounds.failure_bound` (without ``p``); runs are
    added (up to four) until two or more agree and their combined failure bound is at most
    ``target``.

    Parameters
    ----------
    problem : Problem
        The compiled block.
    seed : object
        Seed of the random streams.
    deadline : float or None
        ``time.perf_counter()`` value after which the block is abandoned.
    bound_args : dict or None
        Model sizes for the failure bound.
    target : float
        Largest accepted combined failure probability.

    Returns
    -------
    BlockOutcome
        Rank, unobservable columns, runs and failure bound (or a reason when undecided).

    References
    ----------
    .. [1] A. Sedoglavic, "A probabilistic algorithm to test local algebraic observability in polynomial time", J.
       Symbolic Computation 33(5), 735-755, 2002. doi:10.1006/jsco.2002.0532
    """
    M = problem.size
    out = BlockOutcome(method="sedoglavic", columns=problem.columns)
    if M == 0:
        return out
    results: list[tuple[object, int, tuple[bool, ...]]] = []
    try:
        for run_no in range(_MAX_RUNS):
            rng = random.Random(f"sedoglavic:{seed}:{run_no}")
            run, r, unobs = _one_run(problem, rng, deadline)
            out.runs += 1
            if r == M:  # a nonzero maximal minor at one point: a certificate
                out.rank, out.unobservable, out.order, out.failure = r, frozenset(), run.orders, 0.0
                return out
            results.append((run, r, tuple(unobs)))
            best = max(x[1] for x in results)
            groups: dict[tuple[bool, ...], list] = {}
            for x in results:
                if x[1] == best:
                    groups.setdefault(x[2], []).append(x[0])
            classes, runs = max(groups.items(), key=lambda kv: len(kv[1]))
            if len(runs) < 2:
                continue
            failure = 1.0
            for rr in runs:  # primes restricted to those with the model's roots of numbers: divide by their density
                failure *= min(1.0, failure_bound(rr.p, nfuncs=M, **(bound_args or {})) / prime_density(problem))
            if failure <= target or run_no == _MAX_RUNS - 1:
                out.rank = best
                out.unobservable = frozenset(c for c, u in zip(problem.columns, classes) if u)
                out.order = runs[0].orders
                out.failure = failure
                return out
    except TimeUp as exc:
        out.reason = f"time limit reached ({exc}); no verdict from a truncated computation"
        return out
    out.reason = f"{_MAX_RUNS} random points gave different ranks or classes; no verdict"
    return out
