"""Shared pieces of the exact engines: rank and kernel mod p, classification, probability bound.

A Jacobian ``J`` (rows: output derivatives; columns: unknowns ``z``) over GF(p) is classified by
one kernel: ``z_j`` is locally observable/identifiable iff row ``j`` of a kernel basis is zero
(equivalently ``rank J[:, -j] < rank J``; algorithms.md §1.6). The transcendence degree is the
rank deficit.

Probability. For a random prime ``p`` and a random point, Sedoglavic (J. Symbolic Comput. 33(5),
2002, Prop. 3.3, in the form used by StructuralIdentifiability.jl) gives: when
``p >= 2 mu D'`` with ``D = 4 (n+l)^2 (n+m) d`` and
``D' = D (2 ln(n+l+r+1) + ln(mu D)) + 4 (n+l)^2 ((n+m) h + ln(2 n D))``, one function is classified
correctly with probability at least ``(1 - 1/mu)^2``. :func:`failure_bound` inverts this for the
prime actually drawn (largest such ``mu``) and takes the union over the classified unknowns. Here
``n`` counts states, augmented functions and unknown-input derivatives, ``l`` parameters and known
constants, ``d`` the largest total degree and ``h`` twice the largest coefficient bit size of the
numerators and denominators of the (augmented, rational) right-hand sides and outputs, bounded from
above on the straight-line program (:func:`program_degree_height`).
A full-rank Jacobian at one point is a certificate (a nonzero minor mod p is a nonzero minor
over Q), so its failure bound is 0. An unobservable verdict is reported only when a second,
independent run (new prime, new point) gives the same rank and the same classes; both runs must
then have failed, so the bounds multiply.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp

from obsnl.algebra.modp import nullspace_mod_p

__all__ = ["classify", "failure_bound", "bound_sizes", "program_degree_height", "BlockOutcome"]


@dataclass
class BlockOutcome:
    """What an engine found on one block of unknowns (internal value, assembled by ``analyze``)."""

    method: str
    columns: tuple[str, ...]
    rank: int = 0
    unobservable: frozenset[str] = frozenset()
    order: int = 0
    failure: float = 0.0
    runs: int = 0
    reason: str = ""
    notes: list[str] = field(default_factory=list)

    @property
    def inconclusive(self) -> bool:
        return bool(self.reason)


def classify(J: np.ndarray, p: int) -> tuple[int, list[bool]]:
    """Rank of ``J`` over GF(p) and, per column, whether the unknown is unobservable (kernel test).

    Parameters
    ----------
    J : numpy.ndarray
        Integer matrix ``(rows, unknowns)`` with entries in ``[0, p)``.
    p : int
        The prime.

    Returns
    -------
    tuple
        ``(rank, unobservable)``: the rank and one bool per column.
    """
    R, M = J.shape
    if M == 0:
        return 0, []
    kernel = nullspace_mod_p(J, M, p)
    return M - len(kernel), [any(k[j] for k in kernel) for j in range(M)]


def failure_bound(p: int, *, n: int, l: int, m: int, r: int, d: int, h: int, nfuncs: int) -> float:
    """Sedoglavic's Prop. 3.3 failure probability of one run with prime ``p`` (see module doc).

    Parameters
    ----------
    p : int
        The prime of the run.
    n, l, m, r : int
        Numbers of states, parameters, known inputs and outputs.
    d, h : int
        Degree and height bounds of the model (:func:`program_degree_height`).
    nfuncs : int
        Number of classified unknowns (the union bound's factor).

    Returns
    -------
    float
        Upper bound of the failure probability, at most 1.

    References
    ----------
    .. [1] A. Sedoglavic, "A probabilistic algorithm to test local algebraic observability in polynomial time", J.
       Symbolic Computation 33(5), 735-755, 2002. doi:10.1006/jsco.2002.0532
    """
    n = max(n, 1)
    d = max(d, 1)
    h = max(h, 1)
    nl = n + l
    D = 4 * nl**2 * (n + m) * d

    def dprime(mu: float) -> float:
        return D * (2 * math.log(nl + r + 1) + math.log(mu * D)) + 4 * nl**2 * ((n + m) * h + math.log(2 * n * D))

    mu = p / (2 * dprime(1.0))
    for _ in range(50):
        if mu <= 1:
            return 1.0
        new = p / (2 * dprime(mu))
        if abs(new - mu) < 1e-9 * mu:
            break
        mu = new
    mu = math.floor(mu)
    while mu > 1 and 2 * mu * dprime(mu) > p:
        mu -= 1
    if mu <= 1:
        return 1.0
    per = 1 - (1 - 1 / mu) ** 2
    return min(1.0, nfuncs * per)


def bound_sizes(problem: Any) -> dict[str, int]:
    """The sizes ``n, l, m, r, d, h`` of :func:`failure_bound` for a :class:`obsnl.algebra.problem.Problem`."""
    rat = problem.rational
    model = rat.model
    n_rhs = len(model.states) + len(model.outputs)
    d, h = program_degree_height(problem.program, problem.program.roots[:n_rhs])
    # atom derivative rules raise the degree of the augmented system by at most 2 (E' = E g', l' = g'/g)
    if rat.atoms:
        d += 2
    tv_atoms = sum(1 for a in rat.atoms if a.time_varying)
    n = len(model.states) + tv_atoms + len(model.unknown_inputs) * (problem.unknown_input_derivatives + 1)
    ell = len(model.parameters) + len(model.known_constants) + len(rat.atoms) - tv_atoms
    return dict(n=n, l=ell, m=len(model.outputs), r=len(model.inputs), d=d, h=h)


def program_degree_height(program: Any, roots: Sequence[int]) -> tuple[int, int]:
    """Upper bounds of the largest degree ``d`` and twice the coefficient bits ``h`` of a program's roots.

    Every node is bounded as ``P/Q`` without cancellation: ``a + b = (Pa Qb + Pb Qa)/(Qa Qb)``,
    ``a b = Pa Pb/(Qa Qb)``, ``a/b = Pa Qb/(Qa Pb)``; degrees add, and ``log2`` of the coefficient
    1-norms (an upper bound of the largest coefficient) add under products. Linear in the program
    size, and never smaller than the true values (a larger ``d``, ``h`` only weakens the bound).

    Parameters
    ----------
    program : Program
        A straight-line program (:func:`obsnl.algebra.slp.compile_program`).
    roots : sequence of int
        The nodes whose degree and height are bounded.

    Returns
    -------
    tuple of int
        ``(d, h)``, each at least 1.
    """
    INF = 10**9
    nd: list[tuple[int, int, float, float]] = []  # (deg P, deg Q, log2|P|_1, log2|Q|_1)
    for op in program.ops:
        k = op.kind
        if k == "leaf":
            nd.append((1, 0, 0.0, 0.0))
        elif k == "const":
            c = sp.Rational(op.arg)
            nd.append((0, 0, math.log2(max(1, abs(int(c.p)))), math.log2(int(c.q))))
        elif k == "neg":
            nd.append(nd[op.a])
        elif k in ("scale", "shift"):
            c = sp.Rational(op.arg)
            a = nd[op.a]
            cp, cq = math.log2(max(1, abs(int(c.p)))), math.log2(int(c.q))
            if k == "scale":
                nd.append((a[0], a[1], a[2] + cp, a[3] + cq))
            else:  # a + p/q = (q Pa + p Qa) / (q Qa)
                nd.append((max(a[0], a[1]), a[1], _lsum(a[2] + cq, cp + a[3]), a[3] + cq))
        else:
            a, b = nd[op.a], nd[op.b]
            if k in ("add", "sub"):
                if a[1] == 0 and b[1] == 0 and a[3] == 0 and b[3] == 0:
                    nd.append((max(a[0], b[0]), 0, _lsum(a[2], b[2]), 0.0))
                else:
                    nd.append(
                        (max(a[0] + b[1], b[0] + a[1]), a[1] + b[1], _lsum(a[2] + b[3], b[2] + a[3]), a[3] + b[3])
                    )
            elif k == "mul":
                nd.append((a[0] + b[0], a[1] + b[1], a[2] + b[2], a[3] + b[3]))
            elif k == "div":
                nd.append((a[0] + b[1], a[1] + b[0], a[2] + b[3], a[3] + b[2]))
            else:  # pragma: no cover
                nd.append((INF, INF, float(INF), float(INF)))
    d, h = 1, 1
    for r in roots:
        n = nd[r]
        d = max(d, n[0], n[1])
        h = max(h, 2 * math.ceil(max(n[2], n[3], 1.0)))
    return d, h


def _lsum(x: float, y: float) -> float:
    """log2(2**x + 2**y)."""
    m = max(x, y)
    return m + math.log2(1 + 2 ** (min(x, y) - m))
