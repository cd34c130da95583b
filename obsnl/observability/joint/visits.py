"""The visits of the joint verdict (:mod:`obsnl.observability.joint.verdict`): one smooth model, or the two
sides of a switching surface, evaluated at a point of the run's prime field.

A branch visit is the branch's output series at its own generic point; a surface visit places a
generic point on ``g = 0`` (one state solved from ``g``, where ``g`` is affine in it with a nonzero
coefficient), evaluates both sides there with the same state, parameters, known-input series,
unknown-input coefficients and atom stand-ins, compares the output coefficient values (visible
crossing) and adds the gradient of ``g``. Each visit's rows are brought to reduced echelon form
with its private columns first; the rows without private entries are its parameter information.
"""

from __future__ import annotations

import random
from collections.abc import Callable, Iterator, MutableMapping
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any

import numpy as np
import sympy as sp

from obsnl.algebra.augment import rationalize
from obsnl.algebra.bounds import bound_sizes, failure_bound
from obsnl.algebra.modp import Echelon, kernel_support, rref_mod_p, value_mod_p
from obsnl.algebra.problem import Problem, make_problem
from obsnl.algebra.series import run_series
from obsnl.errors import AnalysisError
from obsnl.model.bounds.work import degree_in
from obsnl.model.branching.branches import derived_model, expr_text
from obsnl.model.core import Model
from obsnl.observability.engines.sedoglavic import RankTracker, stall_safe
from obsnl.observability.joint.result import JointVisit

__all__ = [
    "JointClasses",
    "NewPrime",
    "Plan",
    "Prepared",
    "VisitData",
    "branch_visit",
    "certified",
    "classify_visit",
    "private_names",
    "replace_visit",
    "surface_visit",
]


# --------------------------------------------------------------------------- prepared problems
@dataclass
class Prepared:
    """One smooth model ready for the series: its problem and where its columns are."""

    problem: Problem
    K: int
    n_priv: int
    priv: list[int]  # problem columns that are private to the visit
    par: list[int]  # problem columns of the model's parameters, in model order
    bound: dict[str, int]

    @staticmethod
    def of(model: Model, unknown_input_derivatives: int | str, *, free: bool = False) -> Prepared:
        """``model``'s problem; ``free``: its known initial conditions dropped (a surface visit's states are free)."""
        if free and model.known_initial_conditions:
            model = derived_model(model, known_initial_conditions=(), initial_condition_values={})
        problem = make_problem(rationalize(model), unknown_input_derivatives=unknown_input_derivatives)
        col = {c: j for j, c in enumerate(problem.columns)}
        par = [col[s.name] for s in model.parameters]
        ps = set(par)
        priv = [j for j in range(problem.size) if j not in ps]
        return Prepared(problem, problem.order_bound(), len(priv), priv, par, bound_sizes(problem))

    def failure(self, p: int) -> float:
        return failure_bound(p, nfuncs=max(1, self.problem.size), **self.bound)


@dataclass
class Plan:
    """A visit to make: its kind, labels and its sides' problems (prepared when first visited, so
    that an early stop also saves the preparation of the visits it skips)."""

    kind: str
    labels: tuple[str, ...]
    makers: list[Callable[[], Prepared]]
    g: sp.Expr | None = None

    @cached_property
    def sides(self) -> list[Prepared]:
        return [make() for make in self.makers]


class _Atoms(MutableMapping[tuple, tuple[int, int]]):
    """Atom stand-ins: constant atoms shared by all visits of a run, time-varying ones per visit (keyed by
    ``(kind, argument, root degree, time-varying)``, valued ``(stand-in, circle parameter)``)."""

    def __init__(self, shared: dict) -> None:
        self.shared = shared
        self.local: dict = {}

    def _d(self, key: tuple) -> dict:
        return self.local if key[3] else self.shared

    def __getitem__(self, key: tuple) -> tuple[int, int]:
        return self._d(key)[key]

    def __setitem__(self, key: tuple, value: tuple[int, int]) -> None:
        self._d(key)[key] = value

    def __delitem__(self, key: tuple) -> None:
        del self._d(key)[key]

    def __contains__(self, key: Any) -> bool:  # Mapping's takes any object; a key here is a tuple
        return key in self._d(key)

    def __iter__(self) -> Iterator[tuple]:
        yield from self.shared
        yield from self.local

    def __len__(self) -> int:
        return len(self.shared) + len(self.local)


class NewPrime(Exception):
    """A visit could not be evaluated modulo the run's prime."""


# --------------------------------------------------------------------------- one visit
@dataclass
class VisitData:
    plan: Plan
    rows: np.ndarray  # columns ordered [private | parameters]
    pi: np.ndarray  # parameter information (rows over the parameter columns)
    record: JointVisit
    used: bool = True  # False: an invisible or skipped surface


def _unused(plan: Plan, model: Model, record: JointVisit) -> VisitData:
    """A surface visit that adds no rows (invisible, or skipped for the reason in ``record``)."""
    return VisitData(
        plan, np.zeros((0, 0), dtype=np.int64), np.zeros((0, len(model.parameters)), dtype=np.int64), record, used=False
    )


def branch_visit(plan: Plan, p: int, shared: dict, atoms: dict, key: str, deadline: float | None) -> VisitData:
    """One branch visit: the branch's series at its own point, reduced to private and parameter rows.

    Parameters
    ----------
    plan : Plan
        The visit's plan (one prepared side).
    p : int
        The run's prime.
    shared : dict
        Parameter and constant values (mod ``p``) shared by all visits.
    atoms : dict
        The run's shared atom table.
    key : str
        Seed of this visit's random stream.
    deadline : float or None
        Time limit passed to :func:`obsnl.algebra.series.run_series`.

    Returns
    -------
    VisitData

    Raises
    ------
    NewPrime
        When the series had to change prime.
    """
    prep = plan.sides[0]
    tracker = RankTracker(prep.problem.size, stall=stall_safe(prep.problem))  # the visit's own rank stops growing
    run = run_series(
        prep.problem,
        random.Random(key),
        K=prep.K,
        p=p,
        deadline=deadline,
        fixed=shared,
        atom_values=_Atoms(atoms),
        stop=tracker,
    )
    if run.p != p:
        raise NewPrime(f"branch {plan.labels[0]}")
    R = np.vstack(run.rows) if run.rows else np.zeros((0, prep.problem.size), dtype=np.int64)
    return _finish(plan, R[:, prep.priv + prep.par], prep.n_priv, p, JointVisit("branch", plan.labels))


def surface_visit(
    plan: Plan, model: Model, p: int, shared: dict, atoms: dict, key: str, deadline: float | None
) -> VisitData:
    """One surface visit: both sides of ``plan.g = 0`` at one point on the surface (module docstring).

    Parameters
    ----------
    plan : Plan
        The surface and its two prepared sides.
    model : Model
        The non-smooth model.
    p : int
        The run's prime.
    shared : dict
        Parameter and constant values (mod ``p``) shared by all visits.
    atoms : dict
        The run's shared atom table.
    key : str
        Seed of this visit's random stream.
    deadline : float or None
        Time limit passed to :func:`obsnl.algebra.series.run_series`.

    Returns
    -------
    VisitData
        ``used=False`` with a reason when the surface is invisible or cannot be visited.

    Raises
    ------
    NewPrime
        When a side's series had to change prime.
    """
    g = plan.g
    assert g is not None  # a surface's plan carries its switching function
    a_side, b_side = plan.sides
    K = max(a_side.K, b_side.K)
    text = expr_text(g)
    rng = random.Random(key + ":surface")
    states = {s: rng.randrange(1, p) for s in model.states}
    inputs = {u: [rng.randrange(p) for _ in range(K + 1)] for u in model.inputs}
    record = JointVisit("surface", plan.labels, switching=text, visible=None)
    if g.free_symbols & set(model.unknown_inputs):
        return _unused(plan, model, replace_visit(record, reason="the switching function depends on an unknown input"))
    values: dict[sp.Symbol, int] = dict(shared)
    values.update(states)
    values.update({u: c[0] for u, c in inputs.items()})
    solved = None
    for s in model.states:
        if s not in g.free_symbols:
            continue
        if degree_in(g, s) != 1:  # g = a*s + b read without expanding g (which may be huge)
            continue
        a, b = sp.diff(g, s), g.xreplace({s: sp.Integer(0)})
        av, bv = value_mod_p(a, values, p), value_mod_p(b, values, p)
        if av is None or bv is None or av == 0:
            continue
        states[s] = (-bv) * pow(av, -1, p) % p
        values[s] = states[s]
        solved = s
        break
    if solved is None:
        return _unused(
            plan,
            model,
            replace_visit(
                record,
                reason=f"{text} = 0 cannot be solved for a state in which it is affine "
                f"(with a rational, nonzero coefficient at the point)",
            ),
        )
    record = replace_visit(record, solved_for=solved.name)
    runs = []
    local: dict = {}  # both sides share the point, so also the time-varying atoms' stand-ins
    for label, side in zip(plan.labels, (a_side, b_side)):
        table = _Atoms(atoms)
        table.local = local
        try:
            run = run_series(
                side.problem,
                random.Random(key),
                K=K,
                p=p,
                deadline=deadline,
                fixed=shared,
                states=states,
                input_series=inputs,
                atom_values=table,
            )
        except AnalysisError:  # e.g. |g|**N with N unknown: its logarithm is singular on g = 0
            return _unused(
                plan,
                model,
                replace_visit(
                    record,
                    reason=f"the field of side {label} is singular on {text} = 0 (a denominator or a "
                    f"logarithm vanishes there, e.g. |g|**N with N unknown)",
                ),
            )
        if run.p != p:
            raise NewPrime(f"surface {text}")
        runs.append(run)
    ra, rb = runs
    if ra.point.unknown_inputs != rb.point.unknown_inputs:  # pragma: no cover - same stream, same draws
        raise AnalysisError("internal: the two sides of a surface drew different unknown-input coefficients")
    visible = any(int(x) != int(y) for va, vb in zip(ra.values, rb.values) for x, y in zip(va, vb))
    record = replace_visit(record, visible=visible)
    cols = a_side.problem.columns
    if cols != b_side.problem.columns:  # pragma: no cover - both sides are derived from one model
        raise AnalysisError("internal: the two sides of a surface have different unknowns")
    if not visible:
        return _unused(plan, model, record)
    syms = model.symbols
    grow = []
    for c in cols:
        s = syms.get(c)
        d = value_mod_p(sp.diff(g, s), values, p) if s is not None else 0
        if d is None:
            return _unused(
                plan, model, replace_visit(record, reason=f"the gradient of {text} is not rational at the point")
            )
        grow.append(d)
    R = np.vstack(ra.rows + rb.rows + [np.array([grow], dtype=np.int64)])
    return _finish(plan, R[:, a_side.priv + a_side.par], a_side.n_priv, p, record)


def replace_visit(v: JointVisit, **kw: Any) -> JointVisit:
    """``v`` with the fields ``kw`` replaced (:func:`dataclasses.replace`: the keywords are the fields of
    :class:`JointVisit`, so a bag of keywords is the call's own contract, checked by the dataclass)."""
    return replace(v, **kw)


def _finish(plan: Plan, R: np.ndarray, n_priv: int, p: int, record: JointVisit) -> VisitData:
    E = rref_mod_p(R, p)
    keep = [i for i in range(E.shape[0]) if not E[i, :n_priv].any()]
    pi = E[keep, n_priv:] if keep else np.zeros((0, R.shape[1] - n_priv), dtype=np.int64)
    return VisitData(plan, E, pi, replace_visit(record, parameter_rank=len(keep)))


def private_names(prep: Prepared) -> list[str]:
    return [prep.problem.columns[j] for j in prep.priv]


def classify_visit(v: VisitData, Pi: np.ndarray, p: int) -> dict[str, bool]:
    """Private column name -> determined at this visit given its rows and ``Pi``.

    Parameters
    ----------
    v : VisitData
        The visit.
    Pi : numpy.ndarray
        Parameter information rows (over the parameter columns) to add.
    p : int
        The run's prime.

    Returns
    -------
    dict of str to bool
    """
    prep = v.plan.sides[0]
    n_priv, n_par = prep.n_priv, len(prep.par)
    if n_priv == 0:
        return {}
    stack = v.rows if v.rows.size else np.zeros((0, n_priv + n_par), dtype=np.int64)  # a visit may show nothing
    if Pi.shape[0]:
        stack = np.vstack([stack, np.hstack([np.zeros((Pi.shape[0], n_priv), dtype=np.int64), Pi])])
    unobs = kernel_support(stack, n_priv + n_par, p)
    return {c: not unobs[i] for i, c in enumerate(private_names(prep))}


class JointClasses:
    """The joint classes of one run, kept up to date as visits are added.

    ``Pi`` only grows, and with it what each visit determines: a visit classified at some rank of
    ``Pi`` keeps its observable columns, and is classified again only when the rank has grown since
    (so a run costs one classification per visit once ``Pi`` is full, not one per visit and check).

    Parameters
    ----------
    p : int
        The run's prime.
    states : list of str
        The model's states.
    params : list of str
        The model's parameters, in the order of the columns of ``Pi``.
    ws : list of str
        The model's unknown inputs.
    known : set of str
        States with known initial conditions (observable from the start).

    Examples
    --------
    >>> import numpy as np
    >>> from obsnl.algebra.modp import Echelon
    >>> classes = JointClasses(101, ["x", "y"], ["a", "b"], ["w"], {"x"})
    >>> Pi = Echelon(2, 101)
    >>> classes.update([], Pi)
    {'a': False, 'b': False, 'x': True, 'y': False, 'w': False}
    >>> Pi.add(np.array([1, 0]))  # a visit determines ``a``: the rank grows
    True
    >>> classes.update([], Pi)["a"]
    True
    """

    def __init__(self, p: int, states: list[str], params: list[str], ws: list[str], known: set[str]) -> None:
        self.p, self.params = p, params
        self.seen: dict[str, bool] = {c: c in known for c in states}
        self.seen.update({w: False for w in ws})
        self.at_rank: dict[int, int] = {}  # id of a visit -> rank of Pi at its last classification

    def update(self, done: list[VisitData], ech: Echelon) -> dict[str, bool]:
        """The joint classes after the visits ``done``, given the joint parameter row space ``ech``.

        Parameters
        ----------
        done : list of VisitData
            The visits of the run so far (those not used are skipped).
        ech : Echelon
            The joint parameter row space ``Pi`` of those visits.

        Returns
        -------
        dict of str to bool
            Each parameter, then each state and unknown input -> whether it is jointly observable so far.
        """
        p, n_par = self.p, len(self.params)
        Pi = ech.rows if ech.rank else np.zeros((0, n_par), dtype=np.int64)
        unobs_par = kernel_support(Pi, n_par, p)
        for v in done:
            if not v.used or self.at_rank.get(id(v), -1) >= ech.rank:
                continue
            self.at_rank[id(v)] = ech.rank
            for c, ok in classify_visit(v, Pi, p).items():
                if ok and c in self.seen:
                    self.seen[c] = True
        out = {c: not u for c, u in zip(self.params, unobs_par)}
        out.update(self.seen)
        return out


def certified(
    done: list[VisitData], p: int, n_par: int, states: list[str], params: list[str], ws: list[str], known: set[str]
) -> set[str]:
    """Names certified by a full-column-rank sub-stack (see :mod:`obsnl.observability.joint.verdict`).

    Parameters
    ----------
    done : list of VisitData
        The visits of one run.
    p : int
        The run's prime.
    n_par : int
        Number of parameters.
    states, params, ws : list of str
        The model's states, parameters and unknown inputs.
    known : set of str
        States with known initial conditions.

    Returns
    -------
    set of str
    """
    S = []
    for v in done:
        if not v.used:
            continue
        n_priv = v.plan.sides[0].n_priv
        rank_priv = sum(1 for i in range(v.rows.shape[0]) if v.rows[i, :n_priv].any())
        if rank_priv == n_priv:
            S.append(v)
    e = Echelon(n_par, p)
    for v in S:
        for r in v.pi:
            e.add(r)
    if e.rank < n_par:
        return set()
    out = set(params) | known
    for v in S:
        out |= {c for c in private_names(v.plan.sides[0]) if c in states or c in ws}
    return out
