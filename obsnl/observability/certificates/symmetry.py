"""Generators of the unobservable directions of a smooth model: translations, scalings, affine fields.

A Lie symmetry ``X = sum_j xi_j(z) d/dz_j`` of ``x' = f(x, theta, u)``, ``y = h(x, theta, u)``
leaves the outputs unchanged along its flow; its determining equations (Sedoglavic; algorithms.md
§4.2) are linear in the unknown coefficients of an ansatz for ``xi``:

* ``X(f_i) = L_f(xi_i)`` for every state ``x_i``,
* ``L_f(xi_theta) = 0`` for every parameter (automatic: parameter components depend on parameters),
* ``X(h_k) = 0`` for every output; inputs and known quantities are not moved.

They are evaluated at random points modulo a prime, solved (flint), and every solution is brought
back to Q by rational reconstruction and **verified symbolically**: a scaling by weighted
homogeneity of every equation (a proof of ``f(lambda^w z) = lambda^w_i f(z)``), a translation by
substitution, an affine field by simplifying its determining equations. The ansatz grows by
stages: translations, scalings (weights ``a_j + b_j e`` affine in the exponent parameters ``e``
of symbolic powers such as ``N`` in ``|sigma - eta|**(2N)``), affine fields, quadratic fields.
Each stage keeps only generators that add a new direction at the Jacobian's point, and the search
stops when the generators span the whole unobservable space (its dimension ``d`` comes from the
power-series Jacobian of the engine, :func:`obsnl.observability.engines.jacobian.observability_jacobian`). Directions left
without a closed form are counted in ``missing``.
"""

from __future__ import annotations

import itertools
import math
import os
import random
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import sympy as sp

from obsnl._text import quote
from obsnl.algebra.jets import Expressions
from obsnl.algebra.modp import (
    PRIME,
    Resample,
    nullspace_mod_p,
    rank_mod_p,
    rational_reconstruction,
)
from obsnl.errors import AnalysisError, NotSupportedError
from obsnl.model.branching.branches import Branch, split_branches
from obsnl.model.core import Model
from obsnl.model.files import as_model
from obsnl.observability.certificates.generators import Symmetries, Symmetry
from obsnl.observability.certificates.proofs import verify_generator
from obsnl.observability.engines.decompose import output_reachable
from obsnl.observability.engines.jacobian import ModularJacobian, observability_jacobian
from obsnl.observability.limits import check_analysis_limits

__all__ = ["symmetries", "symmetries_of", "branch_symmetries", "check_search", "monomials_up_to"]

_MAX_UNKNOWNS = 2500


# --------------------------------------------------------------------------- weights (scaling proof)


# --------------------------------------------------------------------------- the search
@dataclass
class _Setup:
    model: Model
    J: ModularJacobian
    moved: list[sp.Symbol]  # unknowns allowed to move (unobservable)
    basis_vars: list[sp.Symbol]  # variables of the ansatz monomials
    exps: list[sp.Symbol]  # exponent parameters allowed in weights
    samples: list[tuple[dict, list]] = field(default_factory=list)  # (point, [(value, grad)] of f and h)
    exprs: Expressions | None = None  # f and h, compiled once


#: The tables of a model keyed by its names (a name removed must leave each of them).
_NAMED_TABLES = ("latex", "values", "guess", "bounds")


def _reduced(model: Model, live: set[sp.Symbol]) -> Model:
    """The output-relevant submodel (dead states and parameters removed, from every table keyed by names too)."""
    states = [s for s in model.states if s in live]
    keep = {s.name for s in live} | {s.name for s in model.inputs + model.known_constants} | set(model.outputs)
    tables = {t: {k: v for k, v in getattr(model, t).items() if k in keep} for t in _NAMED_TABLES}
    return model.replace(
        **tables,
        definitions={},
        states=[s.name for s in states],
        parameters=[p.name for p in model.parameters if p in live],
        equations={s.name: model.equations[s] for s in states},
        known_initial_conditions=[s.name for s in model.known_initial_conditions if s in live],
        initial_condition_values={s.name: v for s, v in model.initial_condition_values.items() if s in live},
    )


def _exponent_parameters(model: Model, observable: set[sp.Symbol]) -> list[sp.Symbol]:
    out: set[sp.Symbol] = set()
    for e in list(model.rhs) + list(model.output_exprs):
        for p in e.atoms(sp.Pow):
            if not p.exp.is_Integer:
                out |= p.exp.free_symbols
    return sorted((s for s in out if s in set(model.parameters) and s in observable), key=lambda s: s.name)


def _samples(st: _Setup, count: int, rng: random.Random) -> None:
    """Values and gradients (w.r.t. the moved unknowns) of ``f`` and ``h`` at random points mod :data:`PRIME`."""
    m = st.model
    syms = list(m.states) + list(m.parameters) + list(m.inputs) + list(m.known_constants)
    if st.exprs is None:
        st.exprs = Expressions(list(m.rhs) + list(m.output_exprs), syms)
    while len(st.samples) < count:
        pt = {s: rng.randrange(1, PRIME) for s in syms}
        try:
            st.samples.append((pt, st.exprs.jets(pt, st.moved, PRIME, rng)))
        except Resample:
            continue


def monomials_up_to(vars_: Sequence[sp.Symbol], degree: int) -> list[tuple[sp.Symbol, ...]]:
    """Every monomial of total degree at most ``degree`` in ``vars_``, each as the tuple of its factors.

    The constant monomial ``()`` comes first, then degree 1, 2, ... in turn, each degree in the order of
    :func:`itertools.combinations_with_replacement` (factors in the order of ``vars_``).

    Parameters
    ----------
    vars_ : Sequence[sympy.Symbol]
        The variables, in the order the factors of each monomial follow.
    degree : int
        The highest total degree (0 gives only the constant monomial).

    Returns
    -------
    list[tuple[sympy.Symbol, ...]]
        The monomials, a monomial as its factors with repetition (``(x, x, y)`` for ``x**2*y``).

    Examples
    --------
    >>> import sympy as sp
    >>> x, y = sp.symbols("x y")
    >>> monomials_up_to([x, y], 2)
    [(), (x,), (y,), (x, x), (x, y), (y, y)]
    """
    out: list[tuple[sp.Symbol, ...]] = [()]
    for d in range(1, degree + 1):
        out += list(itertools.combinations_with_replacement(vars_, d))
    return out


def _solve_stage(
    st: _Setup, kind: str, rng: random.Random, degree: int = 1, with_exps: bool = False
) -> list[dict[sp.Symbol, sp.Expr]] | None:
    """Solutions of the determining equations for one ansatz, as {symbol: xi} dicts over Q (None: too many
    unknowns for the ansatz)."""
    m = st.model
    states = list(m.states)
    ns = len(states)
    U = st.moved
    if kind == "translation":
        basis: list[tuple] = [()]
    elif kind == "scaling":
        basis = [("self",)] + [("self", e) for e in (st.exps if with_exps else [])]
    else:
        basis = monomials_up_to(st.basis_vars, degree)
    unknowns = [(j, b) for j in range(len(U)) for b in basis]
    if len(unknowns) > _MAX_UNKNOWNS:
        return None
    _samples(st, len(unknowns) // max(1, ns + len(m.outputs)) + 6, rng)
    sidx = {s: i for i, s in enumerate(states)}
    uidx = [sidx.get(z) for z in U]
    nb = len(basis)
    P = PRIME
    rows = []
    for pt, vals in st.samples:
        fvals = [v for v, _ in vals[:ns]]
        # per component j: values v[j][b] of the basis functions and of L_f of them
        v: list[list[int]] = []
        lf: list[list[int]] = []
        for j, z in enumerate(U):
            vj, lj = [], []
            for b in basis:
                if b == ():
                    val, l_ = 1, 0
                elif b[0] == "self":
                    e = pt[b[1]] if len(b) > 1 else 1
                    val = pt[z] * e % P
                    k = uidx[j]
                    l_ = fvals[k] * e % P if k is not None else 0
                else:
                    val, l_ = 1, 0
                    for i, s in enumerate(b):
                        si = sidx.get(s)
                        if si is not None:
                            rest = fvals[si]
                            for t in b[:i] + b[i + 1 :]:
                                rest = rest * pt[t] % P
                            l_ += rest
                        val = val * pt[s] % P
                vj.append(val)
                lj.append(l_ % P)
            v.append(vj)
            lf.append(lj)
        if kind == "affine":  # L_f(xi_theta) = 0 for a parameter component depending on states
            for jp in range(len(U)):
                if uidx[jp] is None:
                    rows.append([0] * (jp * nb) + lf[jp] + [0] * ((len(U) - jp - 1) * nb))
        for i, (_, grad) in enumerate(vals):
            row = [vb * grad[j] % P for j in range(len(U)) for vb in v[j]]
            if i < ns:
                for j in range(len(U)):
                    if uidx[j] == i:
                        row[j * nb : (j + 1) * nb] = [(a - b) % P for a, b in zip(row[j * nb : (j + 1) * nb], lf[j])]
            rows.append(row)
    sols = []
    for vec in nullspace_mod_p(rows, len(unknowns)):
        comp: dict[sp.Symbol, sp.Expr] = {}
        ok = True
        for (j, b), c in zip(unknowns, vec):
            if c == 0:
                continue
            q = rational_reconstruction(c)
            if q is None:
                ok = False
                break
            term = sp.Mul(*b) if b and b[0] != "self" else (U[j] * (b[1] if len(b) > 1 else 1) if b else 1)
            comp[U[j]] = comp.get(U[j], 0) + q * term
        if ok and comp:
            sols.append({k: sp.expand(v) for k, v in comp.items() if sp.expand(v) != 0})
    return sols


def _normalised(comp: Mapping[sp.Symbol, sp.Expr], order: Sequence[sp.Symbol]) -> dict[sp.Symbol, sp.Expr]:
    """Integer coefficients with gcd 1 and a positive first component (a generator is defined up to scale)."""
    coeffs = [t.as_coeff_Mul()[0] for v in comp.values() for t in sp.Add.make_args(sp.expand(v))]
    den = math.lcm(*[int(sp.Rational(c).q) for c in coeffs])
    num = math.gcd(*[int(sp.Rational(c) * den) for c in coeffs]) or 1
    first = next(comp[v] for v in order if v in comp)
    sign = -1 if sp.expand(first).as_ordered_terms()[0].could_extract_minus_sign() else 1
    return {v: sp.expand(c * den * sign / num) for v, c in comp.items()}


def symmetries(
    model: Model | str | os.PathLike[str], *, seed: int = 0, degree: int = 1, jacobian: ModularJacobian | None = None
) -> Symmetries:
    """Generators of the unobservable directions of a smooth model, exact over Q and verified.

    Parameters
    ----------
    model : Model, str or os.PathLike
        A smooth model (a branch: ``[b.model for b in obsnl.model.split_branches(model)]``), or its file.
    seed : int
        Seed of the random points (the Jacobian and the determining equations).
    degree : int
        Highest polynomial degree of the ansatz after translations and scalings: 1 (affine,
        default) or 2 (quadratic in the states and parameters).
    jacobian : ModularJacobian or None
        A precomputed :func:`obsnl.observability.engines.jacobian.observability_jacobian` of ``model`` (to share the point).

    Returns
    -------
    Symmetries
        Pointwise independent generators; ``missing`` counts the directions with no closed form.
        Every generator kept is verified symbolically, so a special random point can only lose
        generators (they would count in ``missing``): the dimension and the unobservable set come
        from the Jacobian (error probability at most ``jacobian.failure``, :mod:`obsnl.algebra.bounds`), the
        determining equations are solved mod :data:`obsnl.algebra.modp.PRIME` (62 bits).

    References
    ----------
    .. [1] A. Sedoglavic, "A probabilistic algorithm to test local algebraic observability in polynomial time", J.
       Symbolic Computation 33(5), 735-755, 2002. doi:10.1006/jsco.2002.0532

    Examples
    --------
    >>> from obsnl import Model, symmetries
    >>> m = Model(name="scaled", states=["x"], parameters=["a", "b", "c"], inputs=["u"],
    ...           equations={"x": "a*x + b*u"}, outputs={"y": "c*x"})
    >>> [str(g) for g in symmetries(m).generators]
    ['x*d/dx + b*d/db - c*d/dc']
    """
    model = as_model(model)  # a Model, or read from its file (anything else refused in one line)
    check_search(seed, degree)
    if not model.is_smooth:
        raise NotSupportedError(
            f"model {model.name!r} is not smooth; pass one branch at a time "
            f"([b.model for b in obsnl.model.split_branches(model)])"
        )
    check_analysis_limits(model)  # the size the dense Jacobian and series can hold, before any work
    return symmetries_of(model, seed=seed, degree=degree, jacobian=jacobian)


def check_search(seed: int, degree: int) -> None:
    """Refuse the options of a symmetry search that :func:`symmetries_of` cannot take.

    Parameters
    ----------
    seed : int
        Seed of the random points: an integer >= 0.
    degree : int
        Ansatz degree: 1 or 2.

    Raises
    ------
    AnalysisError
        A seed that is not a non-negative integer.
    NotSupportedError
        A degree other than 1 or 2.

    Examples
    --------
    >>> check_search(0, 3)
    Traceback (most recent call last):
    ...
    obsnl.errors.NotSupportedError: degree must be 1 or 2, got 3
    """
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise AnalysisError(f"seed must be a non-negative integer, got {quote(seed, 30)}")
    if degree not in (1, 2):
        raise NotSupportedError(f"degree must be 1 or 2, got {degree!r}")


def symmetries_of(
    model: Model, *, seed: int = 0, degree: int = 1, jacobian: ModularJacobian | None = None
) -> Symmetries:
    """The search of :func:`symmetries` on a smooth model whose options and limits its caller has checked.

    :func:`symmetries` is the door that checks them, for one model. A caller that searches the branches of a model
    checks them once for the whole model (:func:`check_search` and
    :func:`~obsnl.observability.limits.check_analysis_limits`, which counts the states, parameters and unknown inputs
    that every branch shares) and then calls this for each branch: :func:`branch_symmetries`, the symmetry
    certificates of :func:`obsnl.analyze`, :func:`obsnl.reparametrize`.

    Parameters
    ----------
    model : Model
        A smooth model (a branch), checked.
    seed, degree : int
        As for :func:`symmetries`, checked (:func:`check_search`).
    jacobian : ModularJacobian or None
        As for :func:`symmetries`.

    Returns
    -------
    Symmetries
        As for :func:`symmetries`.

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="scaled", states=["x"], parameters=["a", "b", "c"], inputs=["u"],
    ...           equations={"x": "a*x + b*u"}, outputs={"y": "c*x"})
    >>> symmetries_of(m, seed=0).dimension
    1
    """
    if not isinstance(model, Model):  # an AttributeError below otherwise
        raise AnalysisError(
            f"symmetries_of takes an obsnl Model (a smooth branch, checked), got {type(model).__name__}; "
            f"call obsnl.symmetries with a model or its file"
        )
    t0 = time.perf_counter()
    J = jacobian if jacobian is not None else observability_jacobian(model, seed=seed)
    d = len(J.variables) - J.rank
    moved = list(J.unobservable)
    observable = set(J.variables) - set(moved)
    exps = _exponent_parameters(model, observable)
    rng = random.Random(seed + 7919)
    notes: list[str] = []
    kept: list[Symmetry] = []
    kept_vals: list[list[int]] = []
    syms = model.symbols
    live = {syms[n] for n in output_reachable(model)}
    dead = [v for v in J.variables if v not in live]
    for v in dead:  # no path to an output: any change of v is invisible (proof: the dependency graph)
        kept.append(Symmetry("decoupled", {v.name: sp.Integer(1)}, "dependency graph"))
        kept_vals.append([int(u == v) for u in J.variables])
    if dead:
        notes.append(
            f"{', '.join(v.name for v in dead)} cannot influence any output (dependency graph); "
            f"the search ran on the output-relevant submodel"
        )
    if d > len(kept):
        sub = _reduced(model, live) if dead else model
        st = _Setup(sub, J, [v for v in moved if v in live], list(sub.states) + list(sub.parameters), exps)
        stages = [("translation", 1, False), ("scaling", 1, False)]
        if exps:
            stages.append(("scaling", 1, True))
        stages.append(("affine", 1, False))
        if degree == 2:
            stages.append(("quadratic", 2, False))
        for kind, deg, with_e in stages:
            if len(kept) == d:
                break
            sols = _solve_stage(st, kind if kind != "quadratic" else "affine", rng, deg, with_e)
            if sols is None:
                notes.append(f"the {kind} ansatz has more than {_MAX_UNKNOWNS} unknowns; skipped")
                continue
            sols.sort(key=lambda c: (len(c), sum(sp.count_ops(v) for v in c.values())))
            for comp in sols:
                vals = J.values([comp.get(v, sp.Integer(0)) for v in J.variables])  # the field at J's point
                if rank_mod_p(kept_vals + [vals], len(vals), J.p) == len(kept_vals) + 1:
                    verified = verify_generator(sub, kind if kind != "quadratic" else "affine", comp)
                    if not verified:
                        notes.append(f"a {kind} generator failed symbolic verification and was not kept")
                        continue
                    comp = _normalised(comp, J.variables)
                    kept.append(Symmetry(kind, {s.name: comp[s] for s in J.variables if s in comp}))
                    kept_vals.append(vals)
                    if len(kept) == d:
                        break
    missing = d - len(kept)
    if missing:
        notes.append(
            f"{missing} unobservable direction(s) have no closed form in the "
            f"{'quadratic' if degree == 2 else 'affine'} ansatz"
        )
    return Symmetries(
        model.name,
        tuple(kept),
        d,
        missing,
        tuple(v.name for v in moved),
        tuple(e.name for e in exps),
        time.perf_counter() - t0,
        seed,
        tuple(notes),
        J,
    )


def branch_symmetries(model: Model, *, seed: int = 0, degree: int = 1) -> list[tuple[Branch, Symmetries | None]]:
    """:func:`symmetries` of each smooth branch of a model (the ``i``-th branch with seed ``seed + i``); a
    branch whose feasibility is undecided (:attr:`Branch.undecided`) is listed with ``None``, not analysed and
    never dropped.

    Parameters
    ----------
    model : Model
        A model, smooth or not.
    seed : int
        Seed of the split and of the first branch's random points.
    degree : int
        Ansatz degree, as for :func:`symmetries`.

    Returns
    -------
    list of (Branch, Symmetries or None)
        Each branch with the generators found on it (None: its feasibility is undecided).
    """
    check_search(seed, degree)
    check_analysis_limits(model)  # once for the model: its branches have its states, parameters and inputs
    return [
        (b, None if b.undecided else symmetries_of(b.model, seed=seed + i, degree=degree))
        for i, b in enumerate(split_branches(model, seed=seed, undecided=True))
    ]
