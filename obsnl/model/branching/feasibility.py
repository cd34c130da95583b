"""Does some point satisfy a sign pattern of switching functions? A witness point, a proof that none does,
or an honest "not decided".

Affine switching functions are decided exactly by a linear program. Others are first tried as a linear
program in their monomials, each taken as an unknown of its own (squares and exponentials kept
non-negative): when even that relaxation has no solution, no point does either, and the pattern is
proved empty (``x*v - k > 0``, ``x*v - 2*k < 0``, ``k > 0`` contradict each other). Otherwise a witness is
searched: random points at the unit scales, then at the scales the constants of the switching functions
set (``k*x - 1e20`` changes sign where ``|k*x|`` is near 1e20, far beyond the unit scales), then with
magnitudes spread over those decades, then a local search. A pattern neither found nor proved empty is
*undecided*: :func:`feasible` says so (``proved=False``) and the callers report it instead of dropping it.

Before any linear program or search, each switching function is checked for a sign it can never take
(:func:`obsnl.model.branching.definite.never_positive`: a sum of squares plus a positive constant, a
quadratic of definite sign): ``x**2 - 2*x*v + 2*v**2 + 1 < 0`` is proved empty, not searched.

Declared bounds of parameters (a model's ``[bounds]``, :func:`bound_conditions`) join the sign conditions
of every pattern whose functions involve them: with ``fy`` declared positive, ``fy < 0`` is proved empty by
the same linear programs, and a witness lies within the bounds.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TypeAlias, cast

import numpy as np
import sympy as sp

from obsnl.model.bounds.budget import check_time
from obsnl.model.bounds.work import can_expand, can_factor
from obsnl.model.branching.definite import never_positive

__all__ = ["feasible", "affine_coefficients", "bound_conditions", "UNDECIDED", "Memo", "MemoKey", "MemoValue"]

#: How the reason of an undecided pattern starts.
UNDECIDED = "no point was found"

#: A key of the cache one split shares between its levels and branches (:data:`Memo`): a switching function
#: (its factorization, :mod:`obsnl.model.branching.switching`), ``("affine", g, unknowns)``
#: (:func:`affine_coefficients`), ``("relax", pattern)`` (the monomial relaxation of a sign pattern) or
#: ``("never", g, s)`` (whether ``s * g > 0`` holds nowhere).
MemoKey: TypeAlias = (
    sp.Expr
    | tuple[str, sp.Expr, tuple[sp.Symbol, ...]]
    | tuple[str, tuple[tuple[sp.Expr, int], ...]]
    | tuple[str, sp.Expr, int]
)
#: What the cache holds under each kind of :data:`MemoKey`, in the same order: ``(sign, factors)``, the affine
#: coefficients and constant (None: not affine), whether the relaxation is empty, why the sign never holds ("": not
#: shown).
MemoValue: TypeAlias = tuple[int, list[sp.Expr]] | tuple[list[float], float] | None | bool | str
#: The cache of one split: each entry's kind of value is fixed by its kind of key (:data:`MemoKey`).
Memo: TypeAlias = dict[MemoKey, MemoValue]

_FIX = "raise max_seconds=, or smooth some switching functions (tanh(g/eps) for sign(g))"


def affine_coefficients(
    g: sp.Expr, syms: Sequence[sp.Symbol], memo: Memo | None = None
) -> tuple[list[float], float] | None:
    """(coefficients of ``syms``, constant) when ``g`` is affine in ``syms`` with numeric coefficients, else
    None; an expression too large to expand cheaply (:func:`obsnl.model.bounds.work.can_factor`) counts as not
    affine, without expanding it.

    Parameters
    ----------
    g : sympy.Expr
        A switching function.
    syms : sequence of sympy.Symbol
        The unknowns, in the order of the coefficients returned.
    memo : Memo or None
        Cache shared by the calls of one split.

    Returns
    -------
    (list of float, float) or None

    Examples
    --------
    >>> x, v = sp.symbols("x v")
    >>> affine_coefficients(2*x - v + 3, [v, x]), affine_coefficients((x + v)**60, [v, x])
    (([-1.0, 2.0], 3.0), None)
    """
    key = ("affine", g, tuple(syms))
    if memo is not None and key in memo:
        return cast("tuple[list[float], float] | None", memo[key])
    out = None
    if can_factor(g):
        try:
            poly = sp.Poly(g, *syms)
            if poly.total_degree() <= 1 and all(c.is_number for c in poly.coeffs()):
                out = ([float(poly.coeff_monomial(v)) for v in syms], float(poly.coeff_monomial(1)))
        except (sp.PolynomialError, sp.GeneratorsError):
            out = None
    if memo is not None:
        memo[key] = out
    return out


def _lp(rows: np.ndarray, consts: np.ndarray, signs: np.ndarray, known: Sequence[int] = ()) -> np.ndarray | None:
    """A point ``z`` with ``signs * (rows @ z + consts) > 0`` (strictly, with a margin), or None when the
    linear program proves there is none. Unknowns are scaled to the constants' magnitude and each row to
    unit size, so that ``x - 1e20 > 0`` is as solvable as ``x - 1 > 0``. ``known[k]`` is the sign of unknown
    ``k`` when it is known (+1: non-negative, -1: non-positive), else 0."""
    from scipy.optimize import linprog

    m, n = rows.shape
    big = np.max(np.abs(rows), axis=1) if n else np.zeros(m)
    ratio = [abs(b) / a for a, b in zip(big, consts) if a > 0]
    scale = max([1.0] + ratio)
    norm = np.maximum(np.maximum(big * scale, np.abs(consts)), 1e-300)
    a_ub = np.hstack([-(signs / norm)[:, None] * rows * scale, np.ones((m, 1))])
    b_ub = signs * consts / norm
    # free unknowns (bounds would turn "no point within them" into a false proof); t <= 1 bounds the program
    sides = {1: (0.0, None), -1: (None, 0.0), 0: (None, None)}
    bounds = [sides[known[k] if k < len(known) else 0] for k in range(n)] + [(None, 1.0)]
    cost = np.zeros(n + 1)
    cost[-1] = -1.0
    res = linprog(cost, A_ub=a_ub, b_ub=b_ub, bounds=bounds, method="highs")
    if res.status == 0 and -res.fun > 1e-9:
        return res.x[:n] * scale
    return None


def _affine_witness(
    conds: Sequence[tuple[sp.Expr, int]], syms: Sequence[sp.Symbol], coeffs: Sequence[tuple[list[float], float]]
) -> dict[str, float] | None:
    n = len(syms)
    rows = np.array([c[0] for c in coeffs], dtype=float).reshape(len(conds), n)
    consts = np.array([c[1] for c in coeffs], dtype=float)
    signs = np.array([s for _, s in conds], dtype=float)
    if n and np.linalg.matrix_rank(rows) == len(conds):
        # independent affine forms: every sign pattern holds somewhere; solve A z + b = signs * margin, the
        # margin as large as the constant so that the value is resolvable in floating point (x - 1e20)
        z = np.linalg.lstsq(rows, signs * np.maximum(1.0, np.abs(consts)) - consts, rcond=None)[0]
        if np.all(signs * (rows @ z + consts) > 0):
            return {v.name: float(x) for v, x in zip(syms, z)}
    z = _lp(rows, consts, signs)
    return None if z is None else {v.name: float(x) for v, x in zip(syms, z)}


def _monomials(g: sp.Expr) -> dict[tuple, float] | None:
    """``g`` as ``{monomial: coefficient}`` over its symbols and non-polynomial parts, a monomial as the
    sorted ``((generator, exponent), ...)`` (``()`` for the constant), or None when that is not cheap or the
    coefficients are not numbers."""
    if not can_expand(g):
        return None
    try:
        poly = sp.Poly(sp.expand(g))
    except (sp.PolynomialError, sp.GeneratorsError, sp.CoercionFailed):
        return None
    if not poly.domain.is_Numerical:
        return None
    out: dict[tuple, float] = {}
    for exps, c in poly.terms():
        mono = tuple(
            sorted(((b, int(e)) for b, e in zip(poly.gens, exps) if e), key=lambda p: sp.default_sort_key(p[0]))
        )
        out[mono] = out.get(mono, 0.0) + float(c)
    return out


def _sign_of(mono: tuple, signs: dict[sp.Basic, int]) -> int:
    """+1 when the monomial cannot be negative for real values (even powers, exponentials, even roots, factors
    whose sign the pattern fixes), -1 when it cannot be positive, 0 when its sign is not known."""
    out = 1
    for b, e in mono:
        if e % 2 == 0 or isinstance(b, sp.exp):
            continue
        if isinstance(b, sp.Pow) and b.exp.is_Rational and not b.exp.is_Integer and int(b.exp.q) % 2 == 0:
            continue
        if b not in signs:
            return 0
        out *= signs[b]
    return out


def _relaxation_empty(conds: Sequence[tuple[sp.Expr, int]], memo: Memo | None) -> bool:
    """True when the sign conditions have no solution even with each monomial an independent unknown."""
    key = ("relax", tuple(conds))
    if memo is not None and key in memo:
        return cast(bool, memo[key])
    parts = [_monomials(g) for g, _ in conds]
    known = [p for p in parts if p is not None]
    out = False
    if len(known) == len(parts):
        monos = sorted({m for p in known for m in p if m}, key=str)
        index = {m: k for k, m in enumerate(monos)}
        rows = np.zeros((len(conds), len(monos)))
        consts = np.zeros(len(conds))
        for i, p in enumerate(known):
            for m, c in p.items():
                if not m:
                    consts[i] = c
                else:
                    rows[i, index[m]] = c
        signs = np.array([s for _, s in conds], dtype=float)
        fixed: dict[sp.Basic, int] = {}  # symbols whose sign the pattern fixes (a switching function c*x)
        for g, s in conds:
            c, rest = g.as_coeff_Mul()
            if rest.is_Symbol and c.is_Number and c != 0:
                fixed[rest] = s * (1 if c > 0 else -1)
        out = _lp(rows, consts, signs, [_sign_of(m, fixed) for m in monos]) is None
    if memo is not None:
        memo[key] = out
    return out


def _scales(conds: Sequence[tuple[sp.Expr, int]]) -> list[float]:
    """Magnitudes at which the switching functions change sign, from their constants: ``|c0 / c|**(1/d)``
    for a term ``c * m`` of degree ``d`` beside the constant ``c0``."""
    out: set[float] = set()
    for g, _ in conds:
        p = _monomials(g)
        if not p or not p.get(()):
            continue
        for m, c in p.items():
            d = sum(e for _, e in m)
            if d > 0 and c != 0:
                out.add(float(f"{abs(p[()] / c) ** (1.0 / d):.1e}"))
    return sorted(s for s in out if 1e-6 < s < 1e150 and not 0.01 <= s <= 100)


def _search(
    conds: Sequence[tuple[sp.Expr, int]], syms: Sequence[sp.Symbol], rng: np.random.Generator
) -> dict[str, float] | None:
    fn = sp.lambdify(list(syms), [g for g, _ in conds], modules="numpy")
    signs = np.array([s for _, s in conds], dtype=float)
    n = len(syms)

    def hit(z: np.ndarray) -> dict[str, float] | None:
        with np.errstate(all="ignore"):
            vals = np.array([np.broadcast_to(np.asarray(v, dtype=float), (z.shape[0],)) for v in fn(*z.T)])
        ok = np.all(signs[:, None] * vals > 0, axis=0) & np.all(np.isfinite(vals), axis=0)
        if ok.any():
            i = int(np.argmax(ok))
            return {v.name: float(x) for v, x in zip(syms, z[i])}
        return None

    what = "searching a point where the switching functions " + ", ".join(str(g)[:40] for g, _ in conds[:3])
    for scale in (1.0, 10.0, 0.1, 100.0):
        found = hit(rng.standard_normal((4000, n)) * scale)
        if found is not None:
            return found
    scales = _scales(conds)
    for scale in scales:  # the constants' scales
        check_time(what, _FIX)
        found = hit(rng.standard_normal((4000, n)) * scale)
        if found is not None:
            return found
    top = max([2.0] + [math.log10(s) + 1 for s in scales])
    for _ in range(4):  # each coordinate at its own magnitude, spread over every decade in play
        check_time(what, _FIX)
        mags = 10.0 ** rng.uniform(-3.0, top, (4000, n))
        found = hit(mags * rng.choice([-1.0, 1.0], (4000, n)))
        if found is not None:
            return found
    from scipy.optimize import minimize

    def loss(x: np.ndarray) -> float:
        with np.errstate(all="ignore"):
            v = np.array(fn(*x), dtype=float)
        if not np.all(np.isfinite(v)):
            return 1e6
        return float(np.sum(np.maximum(0.0, 1e-3 - signs * v) ** 2))

    for k in range(20):
        check_time(what, _FIX)
        start = rng.standard_normal(n) * (scales[k % len(scales)] if scales and k % 2 else 1.0)
        x = minimize(loss, start, method="Nelder-Mead", options={"maxiter": 2000}).x
        with np.errstate(all="ignore"):
            v = np.array(fn(*x), dtype=float)
        if np.all(np.isfinite(v)) and np.all(signs * v > 0):
            return {s.name: float(xi) for s, xi in zip(syms, x)}
    return None


def bound_conditions(
    bounds: Mapping[str, tuple[float, float]], symbols: Mapping[str, sp.Symbol]
) -> tuple[tuple[sp.Expr, int], ...]:
    """The sign conditions that declared bounds put on symbols: ``p - lo > 0`` and ``p - hi < 0`` for each finite end.

    Strict conditions are exact here: a sign pattern holds on an open set, which meets a box ``[lo, hi]``
    (``lo < hi``) if and only if it meets its interior.

    Parameters
    ----------
    bounds : mapping of str to (float, float)
        ``{name: (lo, hi)}``, ends possibly infinite (:attr:`obsnl.model.core.Model.bounds`).
    symbols : mapping of str to sympy.Symbol
        The model's symbols by name.

    Returns
    -------
    tuple of (sympy.Expr, int)

    Examples
    --------
    >>> fy, gap = sp.symbols("fy gap", real=True)
    >>> bound_conditions({"fy": (0.0, math.inf), "gap": (-1.0, 2.5)}, {"fy": fy, "gap": gap})
    ((fy, 1), (gap + 1, 1), (gap - 5/2, -1))
    """
    out: list[tuple[sp.Expr, int]] = []
    for name, (lo, hi) in bounds.items():
        s = symbols[name]
        if math.isfinite(lo):
            out.append((s - sp.nsimplify(lo, rational=False) if lo else s, 1))
        if math.isfinite(hi):
            out.append((s - sp.nsimplify(hi, rational=False) if hi else s, -1))
    return tuple(out)


def feasible(
    conds: Sequence[tuple[sp.Expr, int]],
    rng: np.random.Generator,
    memo: Memo | None = None,
    *,
    bounds: Sequence[tuple[sp.Expr, int]] = (),
) -> tuple[dict[str, float] | None, str, bool]:
    """A point where every ``(g, s)`` of ``conds`` has ``s * g > 0``.

    Parameters
    ----------
    conds : sequence of (sympy.Expr, int)
        Switching functions and their wanted signs (+1 or -1).
    rng : numpy.random.Generator
        Random source of the witness search.
    memo : Memo or None
        Cache shared by the calls of one split.
    bounds : sequence of (sympy.Expr, int)
        Declared bounds as sign conditions (:func:`bound_conditions`); those on symbols of ``conds`` hold too.

    Returns
    -------
    (witness or None, reason, proved)
        ``proved`` is True when the answer is certain: a witness was found, or no point exists (a linear
        program, or a sign the function never takes, proves it; ``reason`` says which). False: no point
        found and none proved impossible (``reason`` starts with :data:`UNDECIDED`).

    Examples
    --------
    >>> k, x, v = sp.symbols("k x v", real=True)
    >>> w, _, proved = feasible([(k*x - sp.Integer(10)**20, 1)], np.random.default_rng(0))
    >>> w["k"] * w["x"] > 1e20, proved
    (True, True)
    >>> feasible([(k*x - 1, 1), (k*x - 2, -1), (k*x - 3, 1)], np.random.default_rng(0))[1:]
    ('the sign conditions contradict each other, even with each monomial taken as an unknown of its own (linear program)', True)
    >>> feasible([(x**2 - 2*x*v + 2*v**2 + 1, -1)], np.random.default_rng(0))[1]
    '2*v**2 - 2*v*x + x**2 + 1 < 0 holds nowhere: it is a quadratic in x, v whose symmetric matrix is negative semidefinite (exact rational arithmetic)'
    >>> feasible([(k, -1)], np.random.default_rng(0), bounds=[(k, 1)])[1:]
    ('the affine sign conditions contradict each other (linear program), within the declared bounds', True)
    """
    if not conds:
        return {}, "", True
    for g, s in conds:  # a sign the function never takes: proved before any search
        key = ("never", g, s)
        if memo is None or key not in memo:
            why = never_positive(s * g)
            if memo is not None:
                memo[key] = why
        else:
            why = cast(str, memo[key])
        if why:
            return None, f"{_pattern_text([(g, s)])} holds nowhere: {why}", True
    within = ""
    if bounds:
        names = set().union(*(g.free_symbols for g, _ in conds))
        extra = [(g, s) for g, s in bounds if g.free_symbols <= names and (g, s) not in conds]
        if extra:
            conds, within = list(conds) + extra, ", within the declared bounds"
    syms = sorted(set().union(*(g.free_symbols for g, _ in conds)), key=lambda s: s.name)
    coeffs = [affine_coefficients(g, syms, memo) for g, _ in conds]
    affine = [c for c in coeffs if c is not None]
    if len(affine) == len(coeffs):
        w = _affine_witness(conds, syms, affine)
        why = f"the affine sign conditions contradict each other (linear program){within}"
        return w, "" if w is not None else why, True
    if _relaxation_empty(conds, memo):
        return (
            None,
            (
                "the sign conditions contradict each other, even with each monomial taken as an unknown of "
                f"its own (linear program){within}"
            ),
            True,
        )
    w = _search(conds, syms, rng)
    if w is not None:
        return w, "", True
    return (
        None,
        (
            f"{UNDECIDED} where {_pattern_text(conds)} (random search at the scales of the constants, then "
            f"a local search) and none was proved impossible: the branch may be empty or not"
        ),
        False,
    )


def _pattern_text(conds: Sequence[tuple[sp.Expr, int]]) -> str:
    from obsnl.model.reading.parse import shorten

    return shorten(" and ".join(f"{g} {'>' if s > 0 else '<'} 0" for g, s in conds), 120)
