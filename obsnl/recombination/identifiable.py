"""A generating set of the identifiable functions of a smooth model, readable first, complete always.

The field of locally identifiable functions of the unknowns ``z`` (initial states and parameters)
is described by the power-series Jacobian ``J``: ``g`` is identifiable exactly when ``grad g . K = 0``
for a kernel basis ``K`` of ``J`` (the function test, algorithms.md §1.6), and a set of identifiable
functions generates the field (up to algebraic closure) when its Jacobian has the rank of ``J``.
Candidates are offered in order of readability; one is kept when it passes the function test and
raises the rank. The sources, in order (``method`` names those that were needed):

1. ``symmetries``: the given invariants (Hubert-Labahn monomials, translation invariants) and the
   identifiable variables themselves; then ``invariant pairs``: products, ratios, sums and
   differences of two of the non-identifiable invariants (``N a/b`` from ``N/b`` and ``a``);
2. ``polynomial invariants``: polynomials of degree <= ``degree`` annihilated by every generator
   found (exact identities, solved at random points and reconstructed over Q) and, when directions
   have no closed form, orthogonal to the kernel at further random points;
3. ``output derivatives``: the coefficients of the output derivatives ``L_f^k h`` (as polynomials in
   the input derivatives), split into their identifiable terms.

The answer is checked again at an independent random point (``complete`` is that check). Error
probability: ranks and kernels are those of the engine's Jacobian at one random point
(:mod:`obsnl.observability.engines.jacobian`), exact unless the prime or the point is special: probability at most
``J.failure``, Sedoglavic's Prop. 3.3 bound (:mod:`obsnl.algebra.bounds`).
"""

from __future__ import annotations

import itertools
import math
import os
import random
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import sympy as sp

from obsnl._text import block, names, one_line
from obsnl.algebra.jets import Expressions
from obsnl.algebra.modp import PRIME, nullspace_mod_p, rank_mod_p, rational_reconstruction
from obsnl.errors import AnalysisError, NotSupportedError
from obsnl.model.core import Model
from obsnl.model.files import as_model
from obsnl.observability.certificates.generators import Symmetries
from obsnl.observability.certificates.symmetry import monomials_up_to
from obsnl.observability.certificates.symmetry import symmetries as find_symmetries
from obsnl.observability.engines.jacobian import ModularJacobian, observability_jacobian

__all__ = ["IdentifiableFunctions", "identifiable_functions"]


@dataclass(frozen=True)
class IdentifiableFunctions:
    """Identifiable functions generating the field of a smooth model (see module doc).

    Attributes
    ----------
    functions
        The generators (sympy expressions in the model's symbols); known initial states come first.
    sources
        For each function: ``"known"``, ``"symmetries"``, ``"invariant pairs"``,
        ``"polynomial invariants"`` or ``"output derivatives"``.
    rank
        Rank of the observability Jacobian (the number of independent identifiable functions).
    complete
        The functions reach that rank and pass the function test at an independent point.
    method
        ``"symmetries"`` or ``"symmetries+..."``: the sources that were needed.
    """

    model: str
    functions: tuple[sp.Expr, ...]
    sources: tuple[str, ...]
    rank: int
    complete: bool
    method: str
    notes: tuple[str, ...] = ()
    seconds: float = 0.0

    def __repr__(self) -> str:
        return one_line(
            "IdentifiableFunctions",
            f"model={self.model!r}",
            f"functions={names([sp.sstr(f) for f in self.functions], 5)!r}",
            f"rank={self.rank}",
            f"complete={self.complete}",
        )

    def summary(self) -> str:
        """A few lines of plain text: how many functions, whether they generate every identifiable one, which."""
        return block(
            f"{self.model}: {len(self.functions)} identifiable functions of rank {self.rank}, "
            f"{'generating every identifiable function' if self.complete else 'NOT complete'} "
            f"(found by {self.method})",
            *(f"{sp.sstr(f)}   ({src})" for f, src in list(zip(self.functions, self.sources))[:10]),
            f"... and {len(self.functions) - 10} more" if len(self.functions) > 10 else "",
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "model": self.model,
            "functions": [sp.sstr(f) for f in self.functions],
            "sources": list(self.sources),
            "rank": self.rank,
            "complete": self.complete,
            "method": self.method,
            "notes": list(self.notes),
            "seconds": self.seconds,
        }


class _Kept:
    def __init__(self, J: ModularJacobian) -> None:
        self.J = J
        self.funcs: list[sp.Expr] = []
        self.sources: list[str] = []
        self.grads: list[list[int]] = []

    @property
    def full(self) -> bool:
        return len(self.grads) >= self.J.rank

    def offer(self, expr: sp.Expr, source: str) -> bool:
        expr = sp.sympify(expr)
        if self.full or not expr.free_symbols & set(self.J.variables):
            return False
        g = self.J.gradients([expr])[0]
        if any(sum(a * b for a, b in zip(g, k)) % self.J.p for k in self.J.kernel):
            return False
        if rank_mod_p(self.grads + [g], len(g), self.J.p) == len(self.grads) + 1:
            self.grads.append(g)
            self.funcs.append(expr)
            self.sources.append(source)
            return True
        return False

    def redundant(self, term: sp.Expr) -> bool:
        """The term is (locally) a function of the kept ones."""
        g = self.J.gradients([term])[0]
        return rank_mod_p(self.grads + [g], len(g), self.J.p) == len(self.grads)


def _normalise(e: sp.Expr) -> sp.Expr:
    """Integer coefficients with gcd 1, positive leading term."""
    e = sp.expand(e)
    terms = sp.Add.make_args(e)
    coeffs = [t.as_coeff_Mul()[0] for t in terms]
    den = math.lcm(*[int(sp.Rational(c).q) for c in coeffs])
    nums = [int(sp.Rational(c) * den) for c in coeffs]
    g = math.gcd(*nums) or 1
    e = sp.expand(e * den / g)
    return -e if e.as_ordered_terms()[0].could_extract_minus_sign() else e


def _pairs(kept: _Kept, coords: Sequence[sp.Expr]) -> None:
    """Offer products, ratios, sums and differences of two non-identifiable coordinates."""
    J = kept.J
    coords = [c for c in coords if not kept.J.identifiable([c])[0]]
    if not coords:
        return
    jets = J.jets(list(coords))
    p = J.p
    for i, j in itertools.combinations(range(len(coords)), 2):
        (vi, gi), (vj, gj) = jets[i], jets[j]
        inv_i, inv_j = pow(vi, -1, p), pow(vj, -1, p)
        forms = [
            (coords[i] * coords[j], [(vj * a + vi * b) % p for a, b in zip(gi, gj)]),
            (coords[i] / coords[j], [(a * inv_j - vi * inv_j * inv_j * b) % p for a, b in zip(gi, gj)]),
            (coords[j] / coords[i], [(b * inv_i - vj * inv_i * inv_i * a) % p for a, b in zip(gi, gj)]),
            (coords[i] + coords[j], [(a + b) % p for a, b in zip(gi, gj)]),
            (coords[i] - coords[j], [(a - b) % p for a, b in zip(gi, gj)]),
        ]
        for expr, g in forms:
            if kept.full:
                return
            if any(sum(a * b for a, b in zip(g, k)) % p for k in J.kernel):
                continue
            if rank_mod_p(kept.grads + [g], len(g), p) == len(kept.grads) + 1:
                kept.grads.append(g)
                kept.funcs.append(sp.factor_terms(expr))
                kept.sources.append("invariant pairs")


def _polynomial_invariants(
    model: Model, J: ModularJacobian, S: Symmetries, degree: int, rng: random.Random, deadline: float
) -> list[sp.Expr]:
    """Polynomials of degree <= ``degree`` annihilated by the generators (and orthogonal to the kernel)."""
    vars_ = list(J.variables) + list(model.known_initial_conditions)
    monos = monomials_up_to(vars_, degree)[1:]
    M = len(monos)
    gens = [[sp.sympify(g.components.get(v.name, 0)) for v in vars_] for g in S.generators]
    syms = sorted(set(J.point), key=lambda s: s.name)
    progs = [Expressions(gv, syms) for gv in gens]
    idx = {v: i for i, v in enumerate(vars_)}
    P = J.p if S.missing else PRIME  # one field for all rows: the Jacobians' when their kernels join

    def grad_rows(pt: dict, dirs: list[list[int]]) -> list[list[int]]:
        rows = [[0] * M for _ in dirs]
        for m, mono in enumerate(monos):
            for i, v in enumerate(mono):  # d/dv of the monomial: product of the others (with multiplicity)
                if mono.index(v) != i:
                    continue
                k = mono.count(v)
                rest = k
                for w in mono:
                    rest = rest * pt[w] % P
                rest = rest * pow(pt[v], -1, P) % P
                for r, dvec in enumerate(dirs):
                    rows[r][m] = (rows[r][m] + rest * dvec[idx[v]]) % P
        return rows

    rows: list[list[int]] = []
    for _ in range(M // max(1, len(gens)) + 3 if gens else 0):
        pt = {s: rng.randrange(1, P) for s in syms}
        dirs = [e.values(pt, P, rng) for e in progs]
        rows += grad_rows(pt, dirs)
    if S.missing:
        nullity, stable, k = None, 0, 0
        while stable < 2 and time.perf_counter() < deadline and k < M + 3:
            k += 1
            try:
                Jk = observability_jacobian(model, seed=rng.randrange(2**30), p=P)
            except AnalysisError:  # no usable point modulo P
                continue
            pad = [list(kv) + [0] * (len(vars_) - len(kv)) for kv in Jk.kernel]
            rows += grad_rows(dict(Jk.point), pad)
            n = M - rank_mod_p(rows, M, P)
            stable = stable + 1 if n == nullity else 0
            nullity = n
    out = []
    for vec in nullspace_mod_p(rows, M, P):
        coeffs = [rational_reconstruction(c, P) for c in vec]
        if any(c is None for c, x in zip(coeffs, vec) if x):
            continue
        out.append(_normalise(sp.Add(*[c * sp.Mul(*mono) for c, mono in zip(coeffs, monos) if c])))
    return sorted(
        out, key=lambda e: (len(sp.Add.make_args(e)), sp.Poly(e, *vars_).total_degree(), sp.default_sort_key(e))
    )


def _lie(expr: sp.Expr, model: Model, useries: dict[sp.Symbol, list[sp.Symbol]]) -> sp.Expr:
    out = sp.Add(*[sp.diff(expr, x) * f for x, f in model.equations.items()])
    for _u, ders in useries.items():
        for k, uk in enumerate(ders[:-1]):
            out += sp.diff(expr, uk) * ders[k + 1]
    return out


def _split_offer(kept: _Kept, c: sp.Expr) -> None:
    """Offer the identifiable terms of ``c`` one by one, then what is left of it."""
    top, den = sp.fraction(sp.together(c))
    terms = sp.Add.make_args(sp.expand(top))
    if 1 < len(terms) <= 60:
        rest = [
            t
            for t in terms
            if not kept.offer(t.as_coeff_Mul()[1] / den, "output derivatives") and not kept.redundant(t / den)
        ]
        c = sp.Add(*rest) / den
    kept.offer(sp.factor_terms(c), "output derivatives")


def _output_derivatives(model: Model, kept: _Kept, deadline: float, max_ops: int = 4000) -> None:
    """Offer the coefficients of ``L_f^k h`` as polynomials in the input derivatives."""
    K = len(kept.J.variables) + 1
    useries = {u: [u] + [sp.Symbol(f"{u.name}__d{k}", real=True) for k in range(1, K + 1)] for u in model.inputs}
    usyms = [s for ders in useries.values() for s in ders]
    exprs = list(model.output_exprs)
    for _ in range(K):
        for e in exprs:
            if kept.full or time.perf_counter() > deadline:
                return
            top, den = sp.fraction(sp.together(e))
            coeffs = [top]
            if usyms and not den.free_symbols & set(usyms):
                coeffs = sp.Poly(top, *usyms).coeffs()
            for c in coeffs:
                _split_offer(kept, c / den)
        exprs = [_lie(e, model, useries) for e in exprs]
        if any(sp.count_ops(e) > max_ops for e in exprs):
            return


def identifiable_functions(
    model: Model | str | os.PathLike[str],
    *,
    seed: int = 0,
    symmetries: Symmetries | None = None,
    invariants: Sequence[sp.Expr] = (),
    degree: int = 2,
    max_seconds: float = 60.0,
) -> IdentifiableFunctions:
    """A generating set of the identifiable functions (with states) of a smooth model.

    Parameters
    ----------
    model : Model, str or os.PathLike
        A smooth model (one branch), or its file.
    seed : int
        Seed of the random points.
    symmetries : Symmetries or None
        The model's :func:`obsnl.symmetries` (computed when not given).
    invariants : sequence of sympy.Expr
        Preferred candidates (e.g. the coordinates proposed by :func:`obsnl.reparametrize`).
    degree : int
        Highest degree of the polynomial invariants searched.
    max_seconds : float
        Time budget of the searches (the answer says whether it is complete).

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="lc", states=["x0", "x1"], parameters=["a01", "a21", "a12"],
    ...           equations={"x0": "-(a01 + a21)*x0 + a12*x1", "x1": "a21*x0 - a12*x1"}, outputs={"y": "x0"})
    >>> r = identifiable_functions(m)
    >>> r.complete, [str(f) for f in r.functions]
    (True, ['x0', 'a01*a12', 'a01 + a12 + a21', 'a01*x0 - a12*x1 + a21*x0'])
    """
    t0 = time.perf_counter()
    model = as_model(model)  # a Model, or read from its file (anything else refused in one line)
    if not model.is_smooth:
        raise NotSupportedError(f"model {model.name!r} is not smooth; pass one branch at a time")
    S = symmetries if symmetries is not None else find_symmetries(model, seed=seed)
    J = S.jacobian if S.jacobian is not None else observability_jacobian(model, seed=seed)
    deadline = t0 + max_seconds
    kept = _Kept(J)
    for e in invariants:
        kept.offer(e, "symmetries")
    for v, ok in zip(J.variables, J.identifiable(list(J.variables))):
        if ok:
            kept.offer(v, "symmetries")
    notes: list[str] = []
    if not kept.full:
        _pairs(kept, list(invariants) or list(J.variables))
    if not kept.full:
        for p in _polynomial_invariants(model, J, S, degree, random.Random(seed + 3), deadline):
            kept.offer(p, "polynomial invariants")
    if not kept.full:
        _output_derivatives(model, kept, deadline)
    J2 = observability_jacobian(model, seed=seed + 101)
    ok2 = all(J2.identifiable(kept.funcs)) if kept.funcs else True
    complete = kept.full and ok2 and rank_mod_p(J2.gradients(kept.funcs), len(J2.variables), J2.p) == J2.rank
    if not complete:
        notes.append(f"{len(kept.funcs)} of {J.rank} independent identifiable functions found")
    used = [
        s for s in ("symmetries", "invariant pairs", "polynomial invariants", "output derivatives") if s in kept.sources
    ]
    method = "+".join(used or ["symmetries"])
    known = list(model.known_initial_conditions)
    return IdentifiableFunctions(
        model.name,
        tuple(known) + tuple(kept.funcs),
        ("known",) * len(known) + tuple(kept.sources),
        J.rank,
        complete,
        method,
        tuple(notes),
        time.perf_counter() - t0,
    )
