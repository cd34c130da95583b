"""A section of the scaling symmetries: which parameters to fix so that the scalings act freely, and the
map onto that section."""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import flint
import sympy as sp

from obsnl.errors import ModelError
from obsnl.model.reading.parse import make_symbol
from obsnl.recombination.invariants import row_basis

__all__ = ["ScalingSection", "scaling_section", "section_map"]

#: Most candidate pivot sets :func:`scaling_section` scores (the combinations beyond are not tried).
_MAX_PIVOT_SETS = 4000


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
    return flint.fmpq_mat(
        [[flint.fmpq(int(sp.Rational(x).p), int(sp.Rational(x).q)) for x in Wn.row(i)] for i in range(Wn.rows)]
    )


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
            slopes = [v - vals[0] for v in vals[1 : 1 + ne]]
            const = vals[0] - 3 * sum(slopes, flint.fmpq(0))
            ok = vals[-1] == const + sum((c * chk[e] for c, e in zip(slopes, exps)), flint.fmpq(0))
            cs = [const] + slopes
            total += sum((abs(c) for c in cs), flint.fmpq(0))
            bad += (0 if ok else 1) + sum(1 for c in cs if c.q != 1)
    return bad, float(total)


def scaling_section(
    weights: Sequence[Mapping[sp.Symbol, sp.Expr]],
    variables: Sequence[sp.Symbol],
    parameters: Sequence[sp.Symbol],
    *,
    exponents: Sequence[sp.Symbol] = (),
    keep: Sequence[sp.Symbol] = (),
    eliminate: Sequence[sp.Symbol] = (),
    avoid: Sequence[sp.Symbol] = (),
) -> ScalingSection:
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

    References
    ----------
    .. [1] E. Hubert and G. Labahn, "Scaling invariants and symmetry reduction of dynamical systems", Foundations of
       Computational Mathematics 13(4), 479-516, 2013. doi:10.1007/s10208-013-9165-9
    """
    variables = list(variables)
    rows = row_basis([[sp.sympify(w.get(v, 0)) for v in variables] for w in weights])
    if not rows:
        return ScalingSection((), {}, {}, ())
    W = sp.Matrix(rows)
    s = W.rows
    cand = [j for j, v in enumerate(variables) if v in set(parameters) and v not in set(keep) and any(W.col(j))]
    forced = [variables.index(v) for v in eliminate if v in variables]
    both = [v for v in eliminate if v in set(keep)]
    if both:
        raise ModelError(
            f"{both[0]} is asked both to be eliminated and to be kept; name it in one of eliminate= and keep="
        )
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
        raise ModelError(
            "the scaling group moves no set of parameters that can serve as pivots "
            "(it acts on states only); its invariants need a state pivot"
        )
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


def section_map(
    new: Sequence[tuple[str, sp.Expr, sp.Expr]],
    rest: Sequence[sp.Symbol],
    tpiv: Sequence[sp.Symbol],
    sec: ScalingSection,
    V: Sequence[sp.Symbol],
    kic: Sequence[sp.Symbol],
) -> dict[sp.Symbol, sp.Expr]:
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
    kic : sequence of sympy.Symbol
        Known initial conditions, kept as they are (last in the section, in this order).

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
