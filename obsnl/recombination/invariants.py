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
from dataclasses import dataclass

import flint
import sympy as sp

from obsnl.errors import ModelError
from obsnl.model.reading.parse import make_symbol
from obsnl.observability.certificates.proofs import canonical

__all__ = ["ScalingSection", "scaling_section", "span_intersection", "translation_invariants", "adapted_forms",
           "pushforward", "coordinates", "section_map"]

_MAX_PIVOT_SETS = 4000


# --------------------------------------------------------------------------- linear algebra over Q(e)
def _basis(rows: Sequence[Sequence[sp.Expr]]) -> list[list[sp.Expr]]:
    """A basis (rref rows) of the span of ``rows`` over Q(e)."""
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
        syms = sorted(set().union(*(sp.sympify(x).free_symbols for r in list(a) + list(b) for x in r)),
                      key=lambda s: s.name)
        try:
            same = all(_rank_at(a, at) == _rank_at(b, at) == _rank_at(list(a) + list(b), at) == len(a)
                       for at in ({s: 1009 + 2 * i for i, s in enumerate(syms)},
                                  {s: 2003 + 2 * i for i, s in enumerate(syms)}))
        except TypeError:
            same = False
        if same:
            return [list(r) for r in a]
    a, b = _basis(a), _basis(b)
    if not a or not b:
        return []
    M = sp.Matrix(a + [[-x for x in r] for r in b]).T
    vecs = [sp.Matrix(1, len(a), list(ns[: len(a)])) * sp.Matrix(a) for ns in M.nullspace(simplify=True)]
    return _basis([[sp.factor(x) for x in v] for v in vecs])


# --------------------------------------------------------------------------- scalings
@dataclass(frozen=True)
class ScalingSection:
    """Pivots and invariants of a scaling group.

    Attributes
    ----------
    pivots
        The variables normalised to 1.
    invariants
        ``{v: I_v}`` for every moved non-pivot variable (``I_v`` in the old variables).
    powers
        ``{v: k}``: ``I_v`` involves ``v**k`` (``k > 1`` only when the exponents were fractional).
    weights
        The weight rows in rref form over the pivots (one generator per pivot).
    """

    pivots: tuple[sp.Symbol, ...]
    invariants: Mapping[sp.Symbol, sp.Expr]
    powers: Mapping[sp.Symbol, int]
    weights: tuple[Mapping[sp.Symbol, sp.Expr], ...]


def _samples(exps: Sequence[sp.Symbol]) -> list[dict[sp.Symbol, int]]:
    """Values of the exponent parameters at which an affine entry is fitted (base, shifts) and checked."""
    base = {e: 3 for e in exps}
    out = [base]
    for e in exps:
        out.append({**base, e: 4})
    out.append({e: 7 + 2 * i for i, e in enumerate(exps)})
    return out


def _numeric(W: sp.Matrix, at: Mapping[sp.Symbol, int]) -> flint.fmpq_mat:
    Wn = W.subs(at) if at else W
    return flint.fmpq_mat([[flint.fmpq(int(sp.Rational(x).p), int(sp.Rational(x).q)) for x in Wn.row(i)]
                           for i in range(Wn.rows)])


def _score(mats: Sequence[flint.fmpq_mat], cols: Sequence[int], exps: Sequence[sp.Symbol]) -> tuple | None:
    """(number of awkward exponents, total exponent size) of the section with pivot columns ``cols``.

    An exponent ``a + sum b_e e`` has size ``|a| + sum |b_e|``; it is awkward when a coefficient is
    fractional or when it is not affine in the exponent parameters. None if ``cols`` is no section.
    """
    solved = []
    for A in mats:
        P = flint.fmpq_mat([[A[i, j] for j in cols] for i in range(A.nrows())])
        if P.rank() < P.nrows():
            return None
        solved.append(P.solve(A).tolist())
    total, bad = flint.fmpq(0), 0
    chk = _samples(exps)[-1]
    ne = len(exps)
    for i in range(mats[0].nrows()):
        for j in range(mats[0].ncols()):
            if j in cols:
                continue
            vals = [M[i][j] for M in solved]
            slopes = [v - vals[0] for v in vals[1:1 + ne]]
            const = vals[0] - 3 * sum(slopes, flint.fmpq(0))
            ok = vals[-1] == const + sum((c * chk[e] for c, e in zip(slopes, exps)), flint.fmpq(0))
            cs = [const] + slopes
            total += sum((abs(c) for c in cs), flint.fmpq(0))
            bad += (0 if ok else 1) + sum(1 for c in cs if c.q != 1)
    return bad, float(total)


def scaling_section(weights: Sequence[Mapping[sp.Symbol, sp.Expr]], variables: Sequence[sp.Symbol],
                    parameters: Sequence[sp.Symbol], *, exponents: Sequence[sp.Symbol] = (),
                    keep: Sequence[sp.Symbol] = (), eliminate: Sequence[sp.Symbol] = (),
                    avoid: Sequence[sp.Symbol] = ()) -> ScalingSection:
    """Hubert-Labahn invariants of the scaling group spanned by ``weights`` (see module doc).

    Pivot sets are ranked by (number of fractional or non-affine exponents, number of pivots in
    ``avoid``, total exponent size, positions of the pivots in ``variables``); ``avoid`` holds the
    parameters of the measured part of the model, which keeps its parameters when another choice exists.

    Parameters
    ----------
    weights : sequence of mapping of sympy.Symbol to sympy.Expr
        The scaling generators, as weights per symbol.
    variables : sequence of sympy.Symbol
        All symbols (states and parameters), in the preferred order.
    parameters : sequence of sympy.Symbol
        The symbols that may be pivots.
    exponents : sequence of sympy.Symbol
        Symbols allowed in the weights (symbolic exponents).
    keep : sequence of sympy.Symbol
        Parameters never used as pivots.
    eliminate : sequence of sympy.Symbol
        Parameters that must be pivots.
    avoid : sequence of sympy.Symbol
        Parameters used as pivots only when needed.

    Returns
    -------
    ScalingSection

    Raises
    ------
    ModelError
        No parameter pivots exist (the group moves states only) or the hints cannot be met.
    """
    variables = list(variables)
    rows = _basis([[sp.sympify(w.get(v, 0)) for v in variables] for w in weights])
    if not rows:
        return ScalingSection((), {}, {}, ())
    W = sp.Matrix(rows)
    s = W.rows
    cand = [j for j, v in enumerate(variables) if v in set(parameters) and v not in set(keep) and any(W.col(j))]
    forced = [variables.index(v) for v in eliminate if v in variables]
    both = [v for v in eliminate if v in set(keep)]
    if both:
        raise ModelError(f"{both[0]} is asked both to be eliminated and to be kept; name it in one of "
                         f"--eliminate and --keep")
    bad = [v for v in eliminate if v not in variables or variables.index(v) not in cand]
    if bad:
        raise ModelError(f"cannot eliminate {bad[0]}: it is not a parameter moved by the scalings")
    free = [j for j in cand if j not in forced]
    need = s - len(forced)
    if need < 0:
        raise ModelError(f"eliminate lists {len(forced)} variables but the group has only {s} scalings")
    best: tuple | None = None
    mats = [_numeric(W, at) for at in (_samples(exponents) if exponents else [{}])]
    for k, extra in enumerate(itertools.combinations(free, need)):
        if k >= _MAX_PIVOT_SETS:
            break
        cols = sorted(forced + list(extra))
        sc = _score(mats, cols, exponents)
        if sc is None:
            continue
        key = (sc[0], sum(variables[j] in set(avoid) for j in cols), sc[1], cols)
        if best is None or key < best:
            best = key
    if best is None:
        raise ModelError("the scaling group moves no set of parameters that can serve as pivots "
                         "(it acts on states only); its invariants need a state pivot")
    cols = best[3]
    M = (W[:, cols].inv() * W).applyfunc(sp.factor)
    pivots = tuple(variables[j] for j in cols)
    inv: dict[sp.Symbol, sp.Expr] = {}
    powers: dict[sp.Symbol, int] = {}
    for j, v in enumerate(variables):
        if j in cols or not any(M.col(j)):
            continue
        exps_ = [sp.factor(-M[i, j]) for i in range(s)]
        den = 1
        for x in exps_:
            for c in sp.Poly(sp.numer(x), *exponents).coeffs() if exponents else [x]:
                den = sp.ilcm(den, sp.Rational(c).q) if sp.sympify(c).is_Rational else den
        inv[v] = v**den * sp.Mul(*[p ** sp.expand(den * x) for p, x in zip(pivots, exps_)])
        powers[v] = int(den)
    wrows = tuple({variables[j]: M[i, j] for j in range(len(variables)) if M[i, j] != 0} for i in range(s))
    return ScalingSection(pivots, inv, powers, wrows)


# --------------------------------------------------------------------------- translations
def translation_invariants(vectors: Sequence[Mapping[sp.Symbol, sp.Rational]], coords: Sequence[sp.Symbol],
                           allowed_pivots: Sequence[sp.Symbol]) -> tuple[list[sp.Symbol], dict[sp.Symbol, sp.Expr]]:
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
    rows = _basis([[sp.Rational(v.get(c, 0)) for c in coords] for v in vectors])
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


def adapted_forms(branch_vectors: Sequence[Sequence[Mapping[sp.Symbol, sp.Rational]]],
                  coords: Sequence[sp.Symbol]) -> list[tuple[dict[sp.Symbol, sp.Rational], tuple[int, ...]]]:
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
        return tuple(b for b, vs in enumerate(branch_vectors)
                     if all(sum(f * sp.Rational(v.get(c, 0)) for f, c in zip(form, moved)) == 0 for v in vs))

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
        den = sp.ilcm(*[x.q for x in f]) if f else 1
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
def pushforward(comp: Mapping[sp.Symbol, sp.Expr],
                coords: Sequence[tuple[sp.Symbol, sp.Expr]]) -> dict[sp.Symbol, sp.Rational] | None:
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
    for y, phi in coords:
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


def coordinates(coords: Sequence[tuple[sp.Symbol, sp.Expr]], rest: Sequence[sp.Symbol],
                tinv: Mapping[sp.Symbol, sp.Expr], forms: Sequence[tuple[Mapping[sp.Symbol, sp.Rational], tuple]],
                V: Sequence[sp.Symbol], flips: set[str]) -> list[tuple[str, sp.Expr, sp.Expr]]:
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


def section_map(new: Sequence[tuple[str, sp.Expr, sp.Expr]], rest: Sequence[sp.Symbol], tpiv: Sequence[sp.Symbol],
                sec: ScalingSection, V: Sequence[sp.Symbol], kic: set[sp.Symbol]) -> dict[sp.Symbol, sp.Expr]:
    """Old symbols in terms of the new ones on the section (pivots 1, translation pivots 0).

    Parameters
    ----------
    new : sequence of tuple
        The new coordinates (:func:`coordinates`).
    rest : sequence of sympy.Symbol
        Coordinates left after the scaling section.
    tpiv : sequence of sympy.Symbol
        Translation pivots (set to 0).
    sec : ScalingSection
        The scaling section (pivots set to 1).
    V : sequence of sympy.Symbol
        Old symbols.
    kic : set of sympy.Symbol
        Known initial conditions, kept as they are.

    Returns
    -------
    dict of sympy.Symbol to sympy.Expr
    """
    rest, tpiv = list(rest), list(tpiv)
    unknown_y = [sp.Dummy(y.name) for y in rest + tpiv]
    to_dummy = dict(zip(rest + tpiv, unknown_y))
    eqs_lin = [lin.xreplace(to_dummy) - make_symbol(nm) for nm, _, lin in new] + [to_dummy[p] for p in tpiv]
    A, b = sp.linear_eq_to_matrix(eqs_lin, unknown_y)
    if A.rows != A.cols or A.rank() < A.cols:
        raise ModelError("internal: the linear coordinates are not invertible")  # pragma: no cover
    sol = A.LUsolve(b)
    ysec = {y: sp.expand(sol[i]) for i, y in enumerate(rest + tpiv)}
    section: dict[sp.Symbol, sp.Expr] = {p: sp.Integer(1) for p in sec.pivots}
    for v in V:
        if v not in sec.pivots:
            val = ysec.get(v, sp.Integer(0))
            section[v] = val ** sp.Rational(1, sec.powers[v]) if sec.powers.get(v, 1) != 1 else val
    for v in kic:
        section[v] = v
    return section
