"""The Hermann-Krener observability rank condition (ORC) with extended Lie derivatives.

The model (rationalized by :mod:`obsnl.algebra.augment`: atoms are augmented states with rational rates)
is written over one common denominator, ``x' = P(x, theta, u)/Q``; unknown inputs ``w`` become
the chain of states ``w, w_d1, ..., w_ds`` with ``w_ds' = 0`` (STRIKE-GOLDD's FISPO); known
inputs enter through the symbols ``u, u_d1, u_d2, ...`` (extended Lie derivatives,
algorithms.md §1.3). For each output ``h = H/G`` the Lie derivatives are kept as
``N_k / (G**b Q**a)`` with the numerators exact polynomials over GF(p) (python-flint
``nmod_mpoly``, symbolic in every variable):

    N_{k+1} = G Q S(N_k) - b N_k Q S(G) - a N_k G S(Q),   S(X) = Q L_f(X),   b -> b+1, a -> a+2

so the denominators never square. The gradient of every derivative is evaluated exactly at a
random point of GF(p) (random prime below ``2**50``); atoms' initial values and their gradients
come from :mod:`obsnl.algebra.series` (the same rules as the randomized test). Derivatives are added
until the rank over all augmented coordinates stops growing (the stabilisation lemma, evaluated at
a random point), or, with specific initial values, up to :meth:`obsnl.algebra.series.Problem.order_bound`.
The unobservable unknowns come from the kernel of the projected Jacobian and are confirmed at a
second random point. The probability bound is Sedoglavic's Prop. 3.3 for the prime drawn
(:mod:`obsnl.algebra.bounds`). The symbolic work swells with the order: this engine is the exact
cross-check with a time limit; the fast path is :mod:`obsnl.observability.engines.sedoglavic`.
"""

from __future__ import annotations

import random
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from obsnl.algebra.bounds import BlockOutcome, classify, failure_bound
from obsnl.algebra.modp import nmod_matrix, rank_mod_p
from obsnl.algebra.series import Problem, Resample, TimeUp, draw_prime, run_series
from obsnl.observability.engines.lie import ModularSystem, OutOfInputs, lie_derivatives

if TYPE_CHECKING:
    from flint import nmod_mpoly

__all__ = ["orc_block"]


class _Point:
    """Values and initial gradients of every ORC coordinate at one random point."""

    def __init__(self, problem: Problem, system: ModularSystem, rng: random.Random, p: int) -> None:
        run = run_series(problem, rng, K=1, p=p, fixed={c: int(v) for c, v in system.known.items()})
        if run.p != p:
            raise Resample("the prime changed")
        self.p = p
        M = problem.size
        rat = problem.rational
        model = rat.model
        values: list[int] = []
        T = np.zeros((len(system.coords), M), dtype=np.int64)
        for i, s in enumerate(system.coords):
            if s in run.init:
                v, g = run.init[s]
                values.append(v)
                T[i] = g
            else:  # w_dj
                w = next(w for w, ch in system.w_chain.items() if s in ch)
                j = system.w_chain[w].index(s)
                values.append(run.point.unknown_inputs[w][j] % p)
                T[i, problem.input_columns[w.name][j]] = 1
        for _u, ch in system.u_chain.items():
            for j, _s in enumerate(ch):
                keep = problem.input_derivatives is None or j <= problem.input_derivatives
                values.append(rng.randrange(p) if keep else 0)
        self.values = values
        self.T = T
        self.G_eval = [
            (_ev(G, values), [_ev(G.derivative(i), values) for i in range(len(system.coords))])
            for _, G in system.outputs
        ]
        self.Q_val = _ev(system.Q, values)
        self.dQ_vals = [_ev(system.Q.derivative(i), values) for i in range(len(system.coords))]
        if self.Q_val == 0 or any(g == 0 for g, _ in self.G_eval):
            raise Resample("denominator vanishes")
        del model

    def row(self, system: ModularSystem, out_index: int, N: nmod_mpoly, a: int, b: int) -> np.ndarray:
        p = self.p
        vals = self.values
        n = len(system.coords)
        Nv = _ev(N, vals)
        Gv, dG = self.G_eval[out_index]
        Dinv = pow(Gv, -b, p) * pow(self.Q_val, -a, p) % p
        gi = pow(Gv, -1, p)
        qi = pow(self.Q_val, -1, p)
        degs = N.degrees()
        row = np.zeros(n, dtype=np.int64)
        for i in range(n):
            if system.deadline is not None and time.perf_counter() > system.deadline:
                raise TimeUp("time limit reached while evaluating the observability matrix")
            dN = _ev(N.derivative(i), vals) if degs[i] else 0
            dlogD = (b * dG[i] * gi + a * self.dQ_vals[i] * qi) % p
            row[i] = (dN - Nv * dlogD) % p * Dinv % p
        return row


def _ev(poly: nmod_mpoly, values: Sequence[int]) -> int:
    return int(poly(*values))


def _project(rows_A: np.ndarray, T: np.ndarray, p: int) -> np.ndarray:
    if rows_A.size == 0:
        return np.zeros((0, T.shape[1]), dtype=np.int64)
    prod = nmod_matrix(rows_A, T.shape[0], p) * nmod_matrix(T, T.shape[1], p)
    return np.array([int(x) for x in prod.entries()], dtype=np.int64).reshape(rows_A.shape[0], T.shape[1])


def orc_block(
    problem: Problem,
    *,
    seed: object,
    deadline: float | None = None,
    bound_args: dict | None = None,
    target: float = 0.01,
) -> BlockOutcome:
    """The ORC on one block; see the module docstring. ``target`` is unused (one prime, see notes).

    Parameters
    ----------
    problem : Problem
        The compiled block.
    seed : object
        Seed of the random stream.
    deadline : float or None
        ``time.perf_counter()`` time limit.
    bound_args : dict or None
        Model sizes for the failure bound.
    target : float
        Unused.

    Returns
    -------
    BlockOutcome

    References
    ----------
    .. [1] R. Hermann and A. J. Krener, "Nonlinear controllability and observability", IEEE Trans. Automatic Control
       22(5), 728-740, 1977. doi:10.1109/TAC.1977.1101601
    """
    M = problem.size
    out = BlockOutcome(method="orc", columns=problem.columns)
    if M == 0:
        return out
    rng = random.Random(f"orc:{seed}")
    bound = problem.order_bound()
    try:
        for _attempt in range(6):
            p = draw_prime(problem, rng)
            try:
                first = run_series(problem, rng, K=1, p=p)
                known = {c: first.point.values[c] for c in problem.model.known_constants}
                system = ModularSystem(problem, p, bound + 1, deadline, known)
                point = _Point(problem, system, rng, p)
                break
            except (Resample, ZeroDivisionError):
                continue
        else:
            out.reason = "no usable random point (denominators vanish)"
            return out
        gens = [lie_derivatives(system, H, G, deadline=deadline) for H, G in system.outputs]
        polys: list[list[tuple]] = [[] for _ in gens]
        rows_A: list[np.ndarray] = []
        last_rank = -1
        order = 0
        for k in range(bound):
            if deadline is not None and time.perf_counter() > deadline:
                raise TimeUp(f"time limit reached after {k} Lie derivatives")
            for o, g in enumerate(gens):
                N, a, b = next(g)
                polys[o].append((N, a, b))
                rows_A.append(point.row(system, o, N, a, b))
            order = k
            A = np.vstack(rows_A)
            rA = rank_mod_p(A, A.shape[1], p)
            J = _project(A, point.T, p)
            if rank_mod_p(J, M, p) == M:
                out.rank, out.order, out.failure, out.runs = M, k, 0.0, 1
                return out
            if not problem.specific and rA == last_rank:
                break
            last_rank = rA
        else:
            if not problem.specific:  # pragma: no cover - the rank stops growing before dim orders
                pass
        r1, unobs1 = classify(J, p)
        out.order = order
        # confirm at a second random point (same polynomials)
        confirmed = False
        for extra in range(3):
            try:
                point2 = _Point(problem, system, rng, p)
            except Resample:
                continue
            rows2 = [point2.row(system, o, *polys[o][k]) for k in range(order + 1) for o in range(len(gens))]
            J2 = _project(np.vstack(rows2), point2.T, p)
            r2, unobs2 = classify(J2, p)
            if r2 == M:
                out.rank, out.failure, out.runs = M, 0.0, 2 + extra
                return out
            if (r2, unobs2) == (r1, unobs1):
                confirmed = True
                break
            if r2 > r1:
                r1, unobs1 = r2, unobs2
        if not confirmed:
            out.reason = "two random points gave different ranks or classes; no verdict"
            return out
        out.rank = r1
        out.unobservable = frozenset(c for c, u in zip(problem.columns, unobs1) if u)
        out.failure = failure_bound(p, nfuncs=M, **(bound_args or {}))
        out.runs = 2
        return out
    except TimeUp as exc:
        out.reason = f"{exc}; no verdict from a truncated computation"
        return out
    except OutOfInputs:  # pragma: no cover - input symbols are allocated for the order bound
        out.reason = "ran out of input derivative symbols"
        return out
