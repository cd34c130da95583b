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
numerators and denominators of the (augmented, rational) right-hand sides and outputs.
A full-rank Jacobian at one point is a certificate (a nonzero minor mod p is a nonzero minor
over Q), so its failure bound is 0. An unobservable verdict is reported only when a second,
independent run (new prime, new point) gives the same rank and the same classes; both runs must
then have failed, so the bounds multiply.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

__all__ = ["classify", "failure_bound", "degree_height", "BlockOutcome"]


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


def nmod_matrix(J: np.ndarray, p: int):
    from flint import nmod_mat

    R, M = J.shape
    return nmod_mat(R, M, [int(x) for x in J.ravel()], p)


def rank(J: np.ndarray, p: int) -> int:
    if J.size == 0:
        return 0
    return nmod_matrix(J, p).rank()


def classify(J: np.ndarray, p: int) -> tuple[int, list[bool]]:
    """Rank of ``J`` over GF(p) and, per column, whether the unknown is unobservable."""
    R, M = J.shape
    if M == 0:
        return 0, []
    if R == 0:
        return 0, [True] * M
    mat = nmod_matrix(J, p)
    r = mat.rank()
    if r == M:
        return r, [False] * M
    X, nullity = mat.nullspace()
    entries = X.entries()
    unobs = []
    for j in range(M):
        row = entries[j * M:(j + 1) * M]
        unobs.append(any(int(row[c]) != 0 for c in range(nullity)))
    return r, unobs


def failure_bound(p: int, *, n: int, l: int, m: int, r: int, d: int, h: int, nfuncs: int) -> float:
    """Sedoglavic's Prop. 3.3 failure probability of one run with prime ``p`` (see module doc)."""
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


def degree_height(exprs: Iterable[sp.Expr], gens: Sequence[sp.Symbol]) -> tuple[int, int]:
    """Largest total degree and twice the largest coefficient bit size of numerators and denominators."""
    d, h = 1, 1
    gens = list(gens)
    for e in exprs:
        num, den = sp.fraction(sp.together(e))
        for part in (num, den):
            try:
                poly = sp.Poly(part, *gens) if gens else None
            except sp.PolynomialError:
                poly = None
            if poly is None:
                continue
            d = max(d, poly.total_degree())
            for c in poly.coeffs():
                c = sp.Rational(c)
                h = max(h, 2 * max(abs(int(c.p)).bit_length(), int(c.q).bit_length()))
    return d, h
