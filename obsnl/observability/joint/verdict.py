"""The joint verdict of a switched model: what the whole experiment reveals when the parameters are
shared by every branch (research/switched.md; Tanwani, Shim & Liberzon, IEEE TAC 58(4), 2013 for
switched linear systems; the nonlinear analogue is the rank of the stacked observability Jacobians
of the visited modes).

Unknowns: the parameters, shared by all visits, and per visit its private unknowns (the initial
states at that visit, the Taylor coefficients of the unknown inputs there).

- **Branch visits**, one per visited branch: the gradients of the output Taylor coefficients of the
  branch's smooth model at the visit's own generic point (own states, own known-input series), all
  visits in one prime field and at the same parameter values (:func:`obsnl.algebra.series.run_series`
  with ``p``, ``fixed`` and a shared atom table). Known initial conditions apply as in the
  per-branch analysis.
- **Surface visits**, one per pair of visited branches whose sign patterns differ in one switching
  function ``g`` only: a generic point on ``g = 0`` (every value drawn, then ``g = 0`` solved mod p for
  one state in which ``g`` is affine with a nonzero coefficient there; all states are free, known
  initial conditions do not apply). Both sides' output series are evaluated at that point with the
  same state, parameters, known-input series and unknown-input coefficients. The crossing is
  *visible* when some output coefficient value differs between the sides: the output then shows the
  crossing instant, at which the state lies on ``g = 0``. A visible crossing adds the rows of both
  sides and the gradient of ``g`` (the constraint restricts the unknowns to the surface); an
  invisible one adds nothing.
- **Stack.** Per visit, the rows are brought to reduced echelon form with the private columns first;
  the rows whose pivot lies among the parameter columns are the parameter information the visit
  carries after its private unknowns are eliminated (``Pi_v``). Their span over all visits is the
  joint parameter row space ``Pi``. A parameter is jointly identifiable iff its unit vector lies in
  ``Pi`` (kernel test); a state (or an unknown input) iff its column is independent at some visit
  given that visit's rows and ``Pi``.

Verdicts and probability. The rank of a matrix at a random point is at most its generic rank, so a
full column rank is a certificate. For a set ``S`` of visits whose private blocks have full column
rank at the point, the stack over ``S`` has rank ``sum |private| + rank Pi_S``; when ``Pi_S`` is full
this is a full column rank, which certifies every parameter and every private unknown of ``S``.
Every other verdict (observable or not) needs a second independent run (new prime, new point) that
agrees: an independent column at one point is no certificate (the rest of the stack may have lost
rank there). Runs are added (up to four) while some variable has no majority of at least two runs
or the bound is weaker than wanted; a variable certified in any run is observable. The failure bound of a run is the sum over its visits (both
sides of a surface) of Sedoglavic's bound (:func:`obsnl.algebra.bounds.failure_bound`) at that
prime; agreeing runs multiply. A time limit, or a surface that could not be placed while some
variable is unobservable, makes the affected verdicts ``inconclusive`` with a reason.

Early stop: the parameter rank only grows as visits are added; once every variable is jointly
observable the remaining visits are skipped (:attr:`JointResult.visits` says which were used).
"""

from __future__ import annotations

import random
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import sympy as sp

from obsnl.algebra.modp import Echelon, Resample, kernel_support, random_prime
from obsnl.algebra.series import TimeUp, draw_prime
from obsnl.errors import AnalysisError
from obsnl.model.branching.branches import Branch, split_branches
from obsnl.model.core import Model
from obsnl.observability.assumptions import JointAssumptions
from obsnl.observability.joint.result import JointResult, JointVisit
from obsnl.observability.joint.visits import (
    JointClasses,
    NewPrime,
    Plan,
    Prepared,
    VisitData,
    branch_visit,
    certified,
    classify_visit,
    replace_visit,
    surface_visit,
)
from obsnl.observability.limits import check_analysis_limits

__all__ = ["JointVisit", "joint_verdict", "joint_verdict_of"]

_MAX_RUNS = 4
_MAX_PRIMES = 4


# --------------------------------------------------------------------------- one run
@dataclass
class _Run:
    p: int
    visits: list[VisitData]
    observable: dict[str, bool]  # reported name -> observable in this run
    certified: set[str]
    failure: float
    pi_rank: int
    early_stop: bool
    union: set[str]


def _names(model: Model) -> tuple[list[str], list[str], list[str]]:
    return ([s.name for s in model.states], [s.name for s in model.parameters], [w.name for w in model.unknown_inputs])


def _one_run(model: Model, plans: list[Plan], seed: int, run_no: int, deadline: float | None, known: set[str]) -> _Run:
    states, params, ws = _names(model)
    reported = states + params + ws
    for attempt in range(_MAX_PRIMES):
        rng = random.Random(f"joint:{seed}:{run_no}:{attempt}")
        p = draw_prime(plans[0].sides[0].problem, rng) if plans else random_prime(rng)  # roots of numbers exist mod p
        shared = {s: rng.randrange(1, p) for s in list(model.parameters) + list(model.known_constants)}
        atoms: dict = {}
        try:
            return _run_at(model, plans, seed, run_no, attempt, p, shared, atoms, deadline, known, reported)
        except (NewPrime, Resample):
            continue
    raise AnalysisError(f"model {model.name!r}: no prime of {_MAX_PRIMES} tried gave a usable point for every visit")


def _run_at(
    model: Model,
    plans: list[Plan],
    seed: int,
    run_no: int,
    attempt: int,
    p: int,
    shared: dict,
    atoms: dict,
    deadline: float | None,
    known: set[str],
    reported: list[str],
) -> _Run:
    states, params, ws = _names(model)
    n_par = len(params)
    ech = Echelon(n_par, p)
    done: list[VisitData] = []
    failure = 0.0
    early = False
    union: set[str] = set(known)
    classes = JointClasses(p, states, params, ws, known)
    for i, plan in enumerate(plans):
        if deadline is not None and time.perf_counter() > deadline:
            raise TimeUp(f"time limit reached after {i} of {len(plans)} visits")
        key = f"joint:{seed}:{run_no}:{attempt}:{i}"
        if plan.kind == "branch":
            v = branch_visit(plan, p, shared, atoms, key, deadline)
        else:
            v = surface_visit(plan, model, p, shared, atoms, key, deadline)
        failure += sum(s.failure(p) for s in plan.sides)
        gain = 0
        for r in v.pi:
            gain += ech.add(r)
        v.record = replace_visit(v.record, rank_gain=gain)
        done.append(v)
        if plan.kind == "branch":  # the union: this visit on its own
            alone = classify_visit(v, np.zeros((0, n_par), dtype=np.int64), p)
            union |= {c for c, ok in alone.items() if ok and c in states}
            unobs_par = kernel_support(v.pi, n_par, p)
            union |= {c for c, u in zip(params, unobs_par) if not u}
        if ech.rank == n_par and i < len(plans) - 1:
            obs = classes.update(done, ech)
            if all(obs.values()):
                early = True
                break
    obs = classes.update(done, ech)
    return _Run(p, done, obs, certified(done, p, n_par, states, params, ws, known), failure, ech.rank, early, union)


# --------------------------------------------------------------------------- the verdict
def _select(model: Model, branches: Sequence[str | Branch] | None) -> list[Branch]:
    if branches is None:
        return list(split_branches(model))
    items = list(branches)
    given = [b for b in items if isinstance(b, Branch)]
    if len(given) == len(items):
        return given
    labels = [b for b in items if isinstance(b, str)]
    if len(labels) != len(items):
        raise AnalysisError("branches= must be labels (str) or obsnl Branch objects, not a mixture")
    every = {b.label: b for b in split_branches(model)}
    missing = [lb for lb in labels if lb not in every]
    if missing:
        raise AnalysisError(f"no branch labelled {', '.join(map(repr, missing))}; the branches are {', '.join(every)}")
    return [every[lb] for lb in labels]


def _surface_pairs(chosen: list[Branch]) -> list[tuple[int, int, sp.Expr]]:
    """Pairs of branches (indices) whose sign patterns differ in one switching function, and that function."""
    pairs = []
    for i, a in enumerate(chosen):
        da = dict(zip(a.switching, a.signs))
        for j in range(i + 1, len(chosen)):
            db = dict(zip(chosen[j].switching, chosen[j].signs))
            if set(da) != set(db):
                continue
            diff = [g for g in da if da[g] != db[g]]
            if len(diff) == 1:
                pairs.append((i, j, diff[0]))
    return pairs


def joint_verdict(
    model: Model,
    *,
    branches: Sequence[str | Branch] | None = None,
    seed: int = 0,
    prob: float = 0.99,
    max_seconds: float | None = None,
    unknown_input_derivatives: int = 1,
) -> JointResult:
    """The joint observability-identifiability verdict of a (switched) model.

    Parameters
    ----------
    model : Model
        Any model; a smooth one has a single branch and its joint verdict is the branch's.
    branches : sequence of str or Branch or None
        The visited branches: labels of :func:`obsnl.model.split_branches` or :class:`obsnl.model.Branch`
        objects (a caller's representative branches); None visits every feasible branch.
    seed : int
        Seed of every random choice (primes, points, input series).
    prob : float
        Wanted lower bound on the probability that the decided verdicts are right; runs are added
        (up to four) while the bound is weaker or some variable has no majority of two runs or more.
    max_seconds : float or None
        Time limit; verdicts not decided by then are ``inconclusive``.
    unknown_input_derivatives : int
        Non-zero derivatives of each unknown input (as in :func:`obsnl.analyze`).

    Returns
    -------
    JointResult

    References
    ----------
    .. [1] A. Tanwani, H. Shim and D. Liberzon, "Observability for switched linear systems: characterization and
       observer design", IEEE Trans. Automatic Control 58(4), 2013 (the switched linear case).

    Examples
    --------
    A relay whose level ``d`` appears only in the switching function: no branch sees ``d``, the
    visible crossing ``x = d`` reveals it (the union of the branches leaves it out).

    >>> from obsnl import Model
    >>> m = Model(name="relay", states=["x", "v"], parameters=["k", "s", "d"], inputs=["u"],
    ...           equations={"x": "v", "v": "u - k*x - s*sign(x - d)"}, outputs={"y": "x"})
    >>> r = joint_verdict(m, seed=1)
    >>> r.observable, r.union_observable
    (('x', 'v', 'k', 's', 'd'), ('x', 'v', 'k', 's'))
    >>> [(v.kind, v.labels, v.visible) for v in r.visits]
    [('branch', ('a',), True), ('branch', ('b',), True), ('surface', ('a', 'b'), True)]
    """
    if not isinstance(model, Model):
        raise AnalysisError(f"expected an obsnl Model, got {type(model).__name__}")
    # before any work (analyze, which checks its own, calls joint_verdict_of); the default 1 means nothing without
    # unknown inputs
    check_analysis_limits(model, unknown_input_derivatives if model.unknown_inputs else None)
    if not (0 < prob < 1):
        raise AnalysisError(f"prob must be strictly between 0 and 1, got {prob!r}")
    if not model.outputs:
        raise AnalysisError(f"model {model.name!r} has no outputs; nothing is observable")
    return joint_verdict_of(
        model,
        _select(model, branches),
        seed=seed,
        prob=prob,
        max_seconds=max_seconds,
        unknown_input_derivatives=unknown_input_derivatives,
    )


def joint_verdict_of(
    model: Model,
    chosen: Sequence[Branch],
    *,
    seed: int,
    prob: float,
    max_seconds: float | None,
    unknown_input_derivatives: int | str,
) -> JointResult:
    """:func:`joint_verdict` over the branches ``chosen`` (:class:`~obsnl.model.Branch` values), the model and the
    options checked already (as :func:`obsnl.analyze` checks them before it chooses the branches).

    Parameters
    ----------
    model : Model
        The (switched) model.
    chosen : sequence of Branch
        The visited branches.
    seed : int
        Seed of every random choice.
    prob : float
        Wanted lower bound on the probability that the decided verdicts are right.
    max_seconds : float or None
        Time limit.
    unknown_input_derivatives : int or str
        The unknown-input assumption in force (``K`` or ``"arbitrary"``).

    Returns
    -------
    JointResult
    """
    t0 = time.perf_counter()
    deadline = None if max_seconds is None else t0 + float(max_seconds)
    chosen = list(chosen)
    if not chosen:
        raise AnalysisError("no branch to visit")
    cache: dict[tuple[int, bool], Prepared] = {}

    def prepared(i: int, free: bool) -> Callable[[], Prepared]:
        """Branch ``i``'s problem; ``free``: known initial conditions dropped (surface visits)."""

        def make() -> Prepared:
            key = (i, free and bool(model.known_initial_conditions))
            if key not in cache:
                cache[key] = Prepared.of(chosen[i].model, unknown_input_derivatives, free=key[1])
            return cache[key]

        return make

    plans: list[Plan] = [Plan("branch", (b.label,), [prepared(i, False)]) for i, b in enumerate(chosen)]
    for i, j, g in _surface_pairs(chosen):
        plans.append(Plan("surface", (chosen[i].label, chosen[j].label), [prepared(i, True), prepared(j, True)], g=g))
    states, params, ws = _names(model)
    known = {s.name for s in model.known_initial_conditions}
    variables = states + params
    runs: list[_Run] = []
    reason = ""
    try:
        for run_no in range(_MAX_RUNS):
            runs.append(_one_run(model, plans, seed, run_no, deadline, known))
            if _decided(runs, prob, states + params + ws) is not None:
                break
    except TimeUp as exc:
        reason = f"{exc}; no verdict from a truncated computation"
    decided = _decided(runs, prob, states + params + ws, final=True)
    verdict, failure = decided if decided is not None else ({}, 1.0)
    first = runs[0] if runs else None
    skipped = [v.record for v in first.visits if v.record.reason] if first else []
    names_unobs = [c for c, ok in verdict.items() if ok is False]
    if skipped and names_unobs:
        why = "; ".join(f"surface {v.switching} ({'/'.join(v.labels)}): {v.reason}" for v in skipped)
        reason = "; ".join(x for x in (reason, f"not every surface could be placed ({why})") if x)
        verdict = {c: (None if ok is False else ok) for c, ok in verdict.items()}
    undecided = [c for c in states + params + ws if verdict.get(c) is None]
    if undecided and not reason:
        reason = f"{len(runs)} random points disagree on {', '.join(undecided)}; no verdict"
    visits = tuple(v.record for v in first.visits) if first else ()
    used_surfaces = [f"{v.switching} ({'/'.join(v.labels)})" for v in visits if v.kind == "surface" and v.visible]
    invisible = [f"{v.switching} ({'/'.join(v.labels)})" for v in visits if v.kind == "surface" and v.visible is False]
    assumptions = JointAssumptions(
        unknown_input_derivatives=unknown_input_derivatives,
        visited_branches=tuple(b.label for b in chosen),
        surfaces_used=tuple(used_surfaces),
        surfaces_invisible=tuple(invisible),
        surfaces_skipped=tuple(f"{v.switching} ({'/'.join(v.labels)}): {v.reason}" for v in skipped),
        known_initial_conditions=(
            "applied in branch visits; surface visits have free states" if model.known_initial_conditions else "none"
        ),
        union_over=tuple(v.labels[0] for v in visits if v.kind == "branch"),
    )
    return JointResult(
        model=model.name,
        observable=tuple(c for c in variables if verdict.get(c) is True),
        unobservable=tuple(c for c in variables if verdict.get(c) is False),
        inconclusive=tuple(c for c in variables + ws if verdict.get(c) is None),
        unknown_inputs={
            "observable": tuple(w for w in ws if verdict.get(w) is True),
            "unobservable": tuple(w for w in ws if verdict.get(w) is False),
        }
        if ws
        else {},
        visits=visits,
        union_observable=tuple(c for c in variables if first and c in first.union),
        parameter_rank=first.pi_rank if first else 0,
        probability=max(0.0, 1.0 - failure),
        seed=seed,
        runs=len(runs),
        early_stop=bool(first and first.early_stop),
        reason=reason,
        assumptions=assumptions,
        seconds=round(time.perf_counter() - t0, 6),
    )


def _decided(
    runs: list[_Run], prob: float, names: list[str], final: bool = False
) -> tuple[dict[str, bool | None], float] | None:
    """Verdicts from the runs so far and their failure bound; None while more runs are wanted.

    A name certified in some run is observable (failure 0). Otherwise the class given by at least
    two runs and by more runs than the other class decides it, with the product of those runs'
    bounds (each of them must have failed for the verdict to be wrong); the overall bound is the
    largest such product. More runs are wanted (up to four) while a name is undecided or the bound
    exceeds ``1 - prob``.
    """
    if not runs:
        return None
    out: dict[str, bool | None] = {}
    failure = 0.0
    certified = set().union(*(r.certified for r in runs))
    pending = False
    for c in names:
        if c in certified:
            out[c] = True
            continue
        votes = {cls: [r for r in runs if r.observable[c] is cls] for cls in (True, False)}
        win = max(votes, key=lambda cls: len(votes[cls]))
        if len(votes[win]) >= 2 and len(votes[win]) > len(votes[not win]):
            out[c] = win
            f = 1.0
            for r in votes[win]:
                f *= r.failure
            failure = max(failure, f)
        else:
            out[c] = None
            pending = True
    if not final and (pending or failure > 1 - prob) and len(runs) < _MAX_RUNS:
        return None
    return out, min(1.0, failure)
