"""Invariants of translation and scaling groups: the readable identifiable coordinates.

* **Scalings (Hubert-Labahn).** A scaling group with weight matrix ``W`` (rows = generators,
  entries affine in exponent parameters such as ``N``) has the monomial invariants ``z**e`` with
  ``W e = 0``. A *rational section* picks pivot variables (normalised to 1); with ``M = W_P^-1 W``
  every other variable ``v`` gives ``I_v = v * prod_P p**(-M[p, v])`` (Hubert & Labahn, FoCM 13,
  2013). Pivots are parameters only (a state cannot be set to 1 along a trajectory). The choice
  avoids fractional or non-affine exponents, then keeps the parameters of the measured part of the
  model (those in the outputs and in the equations of observable states: setting the seed model's
  ``A_m`` to 1 would strip the stiffness from the measured equation), then minimises the total size
  of the exponents (``|a| + |b|`` for ``a + b N``), then prefers parameters declared first;
  ``keep``/``eliminate`` steer it. On the seed model this gives the paper's pivots E, L, sigma_y.
* **Translations.** ``X = sum c_j d/dy_j`` has the linear invariants ``l . y`` with ``l . c = 0``;
  a pivot coordinate per generator is dropped (set to 0 on the section).
* **Branch-adapted coordinates.** Translations that hold in some branches only (the seed model's
  ``beta -> beta + e, gamma -> gamma -/+ e``) are not removed; instead the coordinates they move are
  replaced by a basis of linear forms chosen among the invariants of each branch (``Delta1 = beta' +
  gamma'`` invariant in (a), (c); ``Delta2 = beta' - gamma'`` in (b), (d)), so that every
  combination identifiable in one branch is a coordinate of the model.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence

import flint
import sympy as sp

from obsnl.observability.certificates.proofs import canonical

__all__ = [
    "span_intersection",
    "translation_invariants",
    "adapted_forms",
    "pushforward",
    "coordinates",
    "row_basis",
]


# --------------------------------------------------------------------------- linear algebra over Q(e)
def row_basis(rows: Sequence[Sequence[sp.Expr]]) -> list[list[sp.Expr]]:
    """A basis of the span of ``rows`` over Q(e): the nonzero rows of their reduced row echelon form.

    Parameters
    ----------
    rows : sequence of sequences of sympy.Expr
        Row vectors of one length, with entries rational in the exponent parameters ``e`` (or none).

    Returns
    -------
    list of lists of sympy.Expr
        The basis rows (as many as the rank), each entry factored; ``[]`` for no rows.

    Examples
    --------
    >>> import sympy as sp
    >>> N = sp.Symbol("N")
    >>> row_basis([[1, 2], [2, 4]])
    [[1, 2]]
    >>> row_basis([[1, N], [0, 1]])
    [[1, 0], [0, 1]]
    """
    if not rows:
        return []
    R, piv = sp.Matrix(rows).rref(simplify=True)
    return [[sp.factor(x) for x in R.row(i)] for i in range(len(piv))]


def _rank_at(rows: Sequence[Sequence[sp.Expr]], at: Mapping[sp.Symbol, int]) -> int:
    vals = [[sp.Rational(sp.sympify(x).xreplace(at)) for x in r] for r in rows]
    return flint.fmpq_mat([[flint.fmpq(int(x.p), int(x.q)) for x in r] for r in vals]).rank() if vals else 0


def span_intersection(a: Sequence[Sequence[sp.Expr]], b: Sequence[Sequence[sp.Expr]]) -> list[list[sp.Expr]]:
    """A basis of span(a) ∩ span(b) (row vectors over Q(e)).

    Equal spans (the usual case across branches) are recognised by ranks at two values of the
    exponent parameters (a rank can only drop at a special value, so equal ranks of ``a``, ``b`` and
    ``a + b`` at a value where ``a`` and ``b`` keep their generic rank prove equality there).

    Parameters
    ----------
    a, b : sequence of sequence of sympy.Expr
        Row vectors spanning the two spaces.

    Returns
    -------
    list of list of sympy.Expr
    """
    if a and b:
        syms = sorted(
            set().union(*(sp.sympify(x).free_symbols for r in list(a) + list(b) for x in r)), key=lambda s: s.name
        )
        try:
            same = all(
                _rank_at(a, at) == _rank_at(b, at) == _rank_at(list(a) + list(b), at) == len(a)
                for at in ({s: 1009 + 2 * i for i, s in enumerate(syms)}, {s: 2003 + 2 * i for i, s in enumerate(syms)})
            )
        except TypeError:
            same = False
        if same:
            return [list(r) for r in a]
    a, b = row_basis(a), row_basis(b)
    if not a or not b:
        return []
    M = sp.Matrix(a + [[-x for x in r] for r in b]).T
    vecs = [sp.Matrix(1, len(a), list(ns[: len(a)])) * sp.Matrix(a) for ns in M.nullspace(simplify=True)]
    return row_basis([[sp.factor(x) for x in v] for v in vecs])


# --------------------------------------------------------------------------- translations
def translation_invariants(
    vectors: Sequence[Mapping[sp.Symbol, sp.Rational]], coords: Sequence[sp.Symbol], allowed_pivots: Sequence[sp.Symbol]
) -> tuple[list[sp.Symbol], dict[sp.Symbol, sp.Expr]]:
    """Pivots (dropped) and linear invariants ``{coordinate: y_j - sum c y_piv}`` of commuting translations.

    Parameters
    ----------
    vectors : sequence of mapping of sympy.Symbol to sympy.Rational
        Translation vectors.
    coords : sequence of sympy.Symbol
        The coordinates they act on.
    allowed_pivots : sequence of sympy.Symbol
        Coordinates preferred as pivots.

    Returns
    -------
    tuple
        ``(pivots, invariants)``.
    """
    coords = list(coords)
    rows = row_basis([[sp.Rational(v.get(c, 0)) for c in coords] for v in vectors])
    if not rows:
        return [], {}
    order = sorted(range(len(coords)), key=lambda j: (coords[j] not in set(allowed_pivots), -j))
    R = sp.Matrix(rows)[:, order]
    R, piv = R.rref()
    pivots = [coords[order[p]] for p in piv]
    out: dict[sp.Symbol, sp.Expr] = {}
    for k in range(len(order)):
        if k in piv or not any(R.col(k)):
            continue
        c = coords[order[k]]
        out[c] = c - sum(R[i, k] * pivots[i] for i in range(len(piv)))
    return pivots, out


def adapted_forms(
    branch_vectors: Sequence[Sequence[Mapping[sp.Symbol, sp.Rational]]], coords: Sequence[sp.Symbol]
) -> list[tuple[dict[sp.Symbol, sp.Rational], tuple[int, ...]]]:
    """Linear forms on the coordinates moved by branch translations, adapted to every branch.

    Returns a basis of forms ``(coefficients, branches where the form is invariant)``: for each
    branch the forms invariant there span (greedily, as far as possible) its whole space of
    invariant forms, so that what is identifiable in a branch is a coordinate.

    Parameters
    ----------
    branch_vectors : sequence of sequence of mapping
        Per branch, its translation vectors.
    coords : sequence of sympy.Symbol
        The coordinates.

    Returns
    -------
    list of tuple
    """
    moved = [c for c in coords if any(v.get(c, 0) for vs in branch_vectors for v in vs)]
    if not moved:
        return []
    n = len(moved)
    anns = []
    for vs in branch_vectors:
        C = sp.Matrix([[sp.Rational(v.get(c, 0)) for c in moved] for v in vs]) if vs else sp.zeros(0, n)
        ns = C.nullspace() if vs else [sp.eye(n).col(i) for i in range(n)]
        anns.append([list(x) for x in ns])

    def invariant_in(form: list) -> tuple[int, ...]:
        return tuple(
            b
            for b, vs in enumerate(branch_vectors)
            if all(sum(f * sp.Rational(v.get(c, 0)) for f, c in zip(form, moved)) == 0 for v in vs)
        )

    cands: list[list] = [list(sp.eye(n).row(i)) for i in range(n)]
    for ann in anns:
        if ann:
            R, _ = sp.Matrix([list(a) for a in ann]).rref()
            cands += [list(R.row(i)) for i in range(R.rows) if any(R.row(i))]
    for a, b in itertools.combinations(range(len(anns)), 2):
        cands += span_intersection(anns[a], anns[b])
    norm = []
    for f in cands:
        f = [sp.Rational(x) for x in f]
        lead = next(x for x in f if x != 0)
        den = math.lcm(*[int(x.q) for x in f])  # (sympy's ilcm refuses a single number: one moved coordinate)
        f = [x * den / abs(lead * den) for x in f]
        g = math.gcd(*[int(x) for x in f if x != 0]) if all(x.is_Integer for x in f) else 1
        f = [x / g for x in f]
        if f not in norm:
            norm.append(f)
    inv = {tuple(f): invariant_in(f) for f in norm}
    norm = [f for f in norm if inv[tuple(f)]]
    norm.sort(key=lambda f: (-len(inv[tuple(f)]), inv[tuple(f)], sum(1 for x in f if x), sum(abs(x) for x in f)))
    chosen: list[list] = []
    for f in norm:
        if sp.Matrix(chosen + [f]).rank() == len(chosen) + 1:
            chosen.append(f)
    for i in range(n):  # complete to a basis with coordinates (identifiable nowhere)
        e = list(sp.eye(n).row(i))
        if len(chosen) < n and sp.Matrix(chosen + [e]).rank() == len(chosen) + 1:
            chosen.append(e)
    return [({c: x for c, x in zip(moved, f) if x != 0}, inv.get(tuple(f), invariant_in(f))) for f in chosen]


# --------------------------------------------------------------------------- coordinates of a reparametrization
def pushforward(
    comp: Mapping[sp.Symbol, sp.Expr], coords: Sequence[tuple[sp.Symbol, sp.Expr]]
) -> dict[sp.Symbol, sp.Rational] | None:
    """The translation vector of generator ``comp`` in ``coords`` (None if it is not a translation there).

    Returns ``{}`` when the generator does not move the coordinates (it lies in the divided group).

    Parameters
    ----------
    comp : mapping of sympy.Symbol to sympy.Expr
        The generator's component per old symbol.
    coords : sequence of tuple
        ``(y, phi)``: each coordinate and its expression in the old symbols.

    Returns
    -------
    dict of sympy.Symbol to sympy.Rational or None
    """
    vals = []
    for _y, phi in coords:
        vals.append(sp.Add(*[c * sp.diff(phi, v) for v, c in comp.items()]))
    vals = [sp.expand(v) for v in vals]
    nz = [(y, v) for (y, _), v in zip(coords, vals) if v != 0 and sp.cancel(sp.together(canonical(v))) != 0]
    if not nz:
        return {}
    ref = nz[0][1]
    out = {}
    for y, v in nz:
        r = v / ref
        if not r.is_Rational:
            r = sp.cancel(sp.together(canonical(v) / canonical(ref)))
        if not r.is_Rational:
            return None
        if r != 0:
            out[y] = r
    return out


def coordinates(
    coords: Sequence[tuple[sp.Symbol, sp.Expr]],
    rest: Sequence[sp.Symbol],
    tinv: Mapping[sp.Symbol, sp.Expr],
    forms: Sequence[tuple[Mapping[sp.Symbol, sp.Rational], tuple]],
    V: Sequence[sp.Symbol],
    flips: set[str],
) -> list[tuple[str, sp.Expr, sp.Expr]]:
    """The new coordinates ``(name, expression in the old symbols, linear expression in the y)``.

    Parameters
    ----------
    coords : sequence of tuple
        ``(y, phi)``: intermediate coordinates and their expressions in the old symbols.
    rest : sequence of sympy.Symbol
        Coordinates left after the scaling section.
    tinv : mapping of sympy.Symbol to sympy.Expr
        Translation invariants (:func:`translation_invariants`).
    forms : sequence of tuple
        Adapted forms (:func:`adapted_forms`).
    V : sequence of sympy.Symbol
        Old symbols, fixing the order of the result.
    flips : set of str
        Names of ``Delta`` coordinates to take with the opposite sign.

    Returns
    -------
    list of tuple
    """
    phi_y = dict(coords)
    formed = set().union(*(set(f) for f, _ in forms)) if forms else set()
    y_of_new: dict[str, sp.Expr] = {}
    k_delta = 0
    for y in rest:
        if y not in formed:
            y_of_new[y.name if phi_y[y] == y else f"{y.name}_p"] = tinv.get(y, y)
    for f, _ in forms:
        lin = sp.Add(*[c * tinv.get(y, y) for y, c in f.items()])
        if len(f) == 1 and list(f.values())[0] == 1:
            y = list(f)[0]
            nm = y.name if phi_y[y] == y else f"{y.name}_p"
        else:
            k_delta += 1
            nm = f"Delta{k_delta}"
            lin = -lin if nm in flips else lin
        y_of_new[nm] = lin
    order = {v: i for i, v in enumerate(V)}
    new = []
    for nm in sorted(y_of_new, key=lambda n: min(order[y] for y in y_of_new[n].free_symbols)):
        phi = sp.expand(y_of_new[nm].xreplace(phi_y))
        phi = sp.powsimp(sp.factor_terms(phi)) if isinstance(phi, sp.Add) else phi
        new.append((nm, phi, y_of_new[nm]))
    return new
