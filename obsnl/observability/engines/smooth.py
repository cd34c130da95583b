"""One smooth model, one engine: the common body of the per-branch analysis and of :func:`orc` and
:func:`sedoglavic`.

A model's variables absent from its equations are unobservable and absent (they count in the
transcendence degree, as the seed paper counts ``w_h`` in branches (b), (d)); the output-reachable
submodel is split into independent blocks (:mod:`obsnl.observability.engines.decompose`); each block is
rationalized (:mod:`obsnl.algebra.augment`) and analysed by the chosen engine: ``"orc"``
(:mod:`obsnl.observability.engines.orc`, symbolic Lie derivatives evaluated mod p) or ``"sedoglavic"``
(:mod:`obsnl.observability.engines.sedoglavic`, power series mod p). ``"auto"`` uses the series engine, and the ORC
(with a short time budget) only on a small block (at most 6 unknowns) that the series engine left
undecided.
"""

from __future__ import annotations

import random
import time
from collections.abc import Sequence
from dataclasses import replace
from typing import Any

from obsnl.algebra.augment import rationalize
from obsnl.algebra.bounds import BlockOutcome, bound_sizes
from obsnl.algebra.series import Problem, make_problem
from obsnl.errors import ModelError
from obsnl.model.branching.branches import Branch
from obsnl.model.core import Model
from obsnl.model.reading.unknown_inputs import ARBITRARY
from obsnl.observability.engines.decompose import decompose as _decompose
from obsnl.observability.engines.inputs import check_model_and_options, unknown_variable_names
from obsnl.observability.engines.sedoglavic import sedoglavic_block
from obsnl.observability.limits import out_of_memory
from obsnl.observability.verdicts import BranchResult, Verdict

__all__ = ["analyze_smooth", "orc", "sedoglavic", "fresh_seed"]

_AUTO_ORC_SIZE = 6
_AUTO_ORC_SECONDS = 1.0


def _orc(problem: Problem, **kwargs: Any) -> BlockOutcome:
    """The ORC's outcome on a block; its module (Lie derivatives) loads with the first block the ORC decides."""
    from obsnl.observability.engines.orc import orc_block

    return orc_block(problem, **kwargs)


def _run_block(
    block: Model,
    *,
    method: str,
    seed_key: str,
    deadline: float | None,
    target: float,
    unknown_input_derivatives: int | str,
    input_derivatives: int | None,
    factor_cache: dict | None = None,
) -> tuple[BlockOutcome, Problem]:
    rational = rationalize(block, factor_cache=factor_cache)
    problem = make_problem(
        rational, unknown_input_derivatives=unknown_input_derivatives, input_derivatives=input_derivatives
    )
    bargs = bound_sizes(problem)
    if method == "auto":
        # The series engine first: on every published case and catalogue model it is as fast as the
        # ORC or faster (benchmarks/bench_auto.py), while the ORC can swell on a block with few
        # unknowns (genssi_biomd10_mapk: 1 s of Lie derivatives before a fallback, against 0.02 s).
        # The ORC is only a second opinion on a small block where the random points disagreed.
        out = sedoglavic_block(problem, seed=seed_key, deadline=deadline, bound_args=bargs, target=target)
        if (
            not out.inconclusive
            or problem.size > _AUTO_ORC_SIZE
            or (deadline is not None and time.perf_counter() >= deadline)
        ):
            return out, problem
        budget = time.perf_counter() + _AUTO_ORC_SECONDS
        dl = budget if deadline is None else min(budget, deadline)
        second = _orc(problem, seed=seed_key, deadline=dl, bound_args=bargs, target=target)
        return (out if second.inconclusive else second), problem
    if method == "orc":
        return _orc(problem, seed=seed_key, deadline=deadline, bound_args=bargs, target=target), problem
    return sedoglavic_block(problem, seed=seed_key, deadline=deadline, bound_args=bargs, target=target), problem


def _branch_result(
    label: str,
    guard: str,
    bmodel: Model,
    variables: Sequence[str],
    *,
    method: str,
    seed: int,
    deadline: float | None,
    target: float,
    decompose: bool,
    unknown_input_derivatives: int | str,
    input_derivatives: int | None,
    factor_cache: dict | None = None,
) -> tuple[BranchResult, float]:
    t0 = time.perf_counter()
    appear: set[str] = set()
    for e in list(bmodel.rhs) + list(bmodel.output_exprs) + list(bmodel.initial_condition_values.values()):
        appear |= {s.name for s in e.free_symbols}
    known = {s.name for s in bmodel.known_initial_conditions}
    absent = tuple(v for v in variables if v not in appear and v not in known)
    notes: list[str] = []
    blocks: tuple[Model, ...]
    unknowns = set(bmodel.states) | set(bmodel.parameters) | set(bmodel.unknown_inputs) | set(bmodel.inputs)
    if not any(e.free_symbols & unknowns for e in bmodel.output_exprs):
        # every output is a constant on this branch (a contact force while the contact is open): the branch
        # shows nothing; its variables are unobservable here (other branches, jointly, may still reveal them)
        unreachable, blocks = set(variables) - known, ()
        notes.append("every output is constant on this branch: it reveals nothing on its own")
    elif decompose:
        dec = _decompose(bmodel)
        unreachable, blocks = set(dec.unreachable), dec.blocks
        notes.extend(dec.report)
    else:
        unreachable, blocks = set(), (bmodel,)
    w_names = [w.name for w in bmodel.unknown_inputs]
    arbitrary = unknown_input_derivatives == ARBITRARY
    # K + 1 coefficients per unknown input; arbitrary inputs: those of each block's problem (added below)
    size = len(variables) + (0 if arbitrary else len(w_names) * (int(unknown_input_derivatives) + 1))
    terms: list[int] = []
    rank = len(known)  # a known initial value adds its unit row
    unobs: set[str] = set(unreachable) | set(absent)
    undecided: set[str] = set()
    reasons: list[str] = []
    failure = 0.0
    orders: list[int] = []
    methods: list[str] = []
    for i, block in enumerate(blocks):
        if deadline is not None and time.perf_counter() >= deadline:
            out = BlockOutcome(
                method=method,
                columns=tuple(unknown_variable_names(block)),
                reason="time limit reached before this block was analysed",
            )
            problem: Problem | None = None
        else:
            out, problem = _run_block(
                block,
                method=method,
                seed_key=f"{seed}:{label}:{i}",
                deadline=deadline,
                target=target,
                unknown_input_derivatives=unknown_input_derivatives,
                input_derivatives=input_derivatives,
                factor_cache=factor_cache,
            )
        methods.append(out.method)
        if arbitrary and problem is not None and problem.arbitrary:
            size += problem.size - len(problem.variables)
            terms.append(problem.order_bound())
        if out.inconclusive:
            reasons.append(out.reason)
            undecided |= {c for c in unknown_variable_names(block)} | {w.name for w in block.unknown_inputs}
            continue
        rank += out.rank
        unobs |= set(out.unobservable)
        failure += out.failure
        orders.append(out.order)
        notes.extend(out.notes)
        if problem is not None:
            notes.extend(n for n in problem.rational.notes if n not in notes)
            if problem.specific:
                notes.append(
                    "specific initial values: the rank bound on the number of derivatives does not hold; "
                    f"{problem.order_bound()} series terms / derivative orders were the limit"
                )
    unobs -= undecided
    observable = tuple(v for v in variables if v not in unobs and v not in undecided)
    unobservable = tuple(v for v in variables if v in unobs)
    ui = {}
    if w_names:
        ui = {
            "observable": tuple(w for w in w_names if w not in unobs and w not in undecided),
            "unobservable": tuple(w for w in w_names if w in unobs),
        }
        if arbitrary:
            notes.append(
                "unknown inputs are arbitrary functions of time: each series term brings a new unknown "
                f"Taylor coefficient of each input ({', '.join(map(str, sorted(set(terms)))) or 'no'} terms "
                "read; these coefficients count in size and rank; see obsnl.algebra.problem.arbitrary_terms)"
            )
        else:
            notes.append(
                f"unknown inputs are polynomials in t with {unknown_input_derivatives} non-zero derivative(s) "
                f"(STRIKE-GOLDD nnzDerW = {unknown_input_derivatives}; their Taylor coefficients are unknowns "
                f"and count in size and rank)"
            )
    if bmodel.inputs:
        notes.append(
            "known inputs are generic"
            if input_derivatives is None
            else f"known inputs have {input_derivatives} non-zero derivative(s)"
        )
    if absent:
        notes.append(
            "absent from this branch (unobservable, counted in the transcendence degree): " + ", ".join(absent)
        )
    # rank contribution of unreachable unknown-input columns is zero; absent variables are unreachable
    verdict = Verdict.INCONCLUSIVE if reasons else (Verdict.UNOBSERVABLE if unobservable else Verdict.OBSERVABLE)
    used = sorted(set(methods)) or [method]
    br = BranchResult(
        label=label,
        guard=guard,
        observable=observable,
        unobservable=unobservable,
        absent=absent,
        rank=rank,
        size=size,
        transcendence_degree=size - rank,  # not reported for an inconclusive branch (see BranchResult.to_dict)
        seconds=round(time.perf_counter() - t0, 6),
        verdict=verdict,
        reason="; ".join(reasons),
        undecided=tuple(v for v in variables if v in undecided),
        order=max(orders) if orders else None,
        method="+".join(used),
        unknown_inputs=ui,
        notes=tuple(notes),
    )
    return br, failure


def branch_result(
    b: Branch,
    variables: Sequence[str],
    *,
    method: str,
    seed: int,
    deadline: float | None,
    target: float,
    decompose: bool,
    unknown_input_derivatives: int | str,
    input_derivatives: int | None,
    factor_cache: dict | None = None,
) -> tuple[BranchResult, float]:
    """The result of one branch of an analysis and its failure bound; a branch whose feasibility is undecided
    (:attr:`~obsnl.model.Branch.undecided`) is not analysed: inconclusive.

    Parameters
    ----------
    b : Branch
        The branch.
    variables : sequence of str
        The reported variables (every state, then every parameter).
    method : str
        The engine (``"auto"``, ``"orc"`` or ``"sedoglavic"``).
    seed : int
        The seed of the random choices.
    deadline : float or None
        ``time.perf_counter()`` time limit (None: none).
    target : float
        The failure bound this branch may use.
    decompose : bool
        Analyse the output-connected blocks separately.
    unknown_input_derivatives : int or str
        The unknown-input assumption in force.
    input_derivatives : int or None
        The known inputs' degree (None: generic inputs).
    factor_cache : dict or None
        Shared between the branches of one analysis: their logarithm arguments.

    Returns
    -------
    tuple of BranchResult and float
        The branch's result (its signs set) and its failure bound.
    """
    if b.undecided:
        return BranchResult(
            label=b.label,
            guard=b.guard_text,
            observable=(),
            unobservable=(),
            absent=(),
            rank=0,
            size=len(variables),
            transcendence_degree=0,
            seconds=0.0,
            verdict=Verdict.INCONCLUSIVE,
            reason=f"not analysed, its feasibility is undecided: {b.undecided}",
            undecided=tuple(variables),
            signs=tuple(b.signs),
        ), 0.0
    br, failure = _branch_result(
        b.label,
        b.guard_text,
        b.model,
        variables,
        method=method,
        seed=seed,
        deadline=deadline,
        target=target,
        decompose=decompose,
        unknown_input_derivatives=unknown_input_derivatives,
        input_derivatives=input_derivatives,
        factor_cache=factor_cache,
    )
    return replace(br, signs=tuple(b.signs)), failure


def fresh_seed(seed: int | None) -> int:
    """The seed an analysis runs with: ``seed`` when given, else a fresh one from the system's randomness.

    Parameters
    ----------
    seed : int or None
        The caller's seed (None: draw one).

    Returns
    -------
    int
        ``seed`` itself when it is not None, else a random integer from 0 to ``2**31 - 1``.

    Examples
    --------
    >>> fresh_seed(7)
    7
    >>> 0 <= fresh_seed(None) < 2**31
    True
    """
    return seed if seed is not None else random.SystemRandom().randrange(2**31)


def analyze_smooth(
    model: Model,
    *,
    method: str,
    seed: int | None = None,
    max_seconds: float | None = None,
    prob: float = 0.99,
    unknown_input_derivatives: int | str | None = None,
    input_derivatives: int | None = None,
    decompose: bool = True,
) -> BranchResult:
    """One smooth model, one engine: the common body of :func:`obsnl.observability.orc` and :func:`obsnl.observability.sedoglavic`.

    Parameters
    ----------
    model : Model
        A smooth model.
    method : str
        ``"orc"`` or ``"sedoglavic"``.
    seed : int or None
        Random seed (None: a fresh one).
    max_seconds : float or None
        Time limit.
    prob : float
        Required probability of a correct answer.
    unknown_input_derivatives : int, str or None
        Unknown-input assumption (None: the model's, else ``"arbitrary"``).
    input_derivatives : int or None
        Known-input degree (None: generic).
    decompose : bool
        Split the model into independent blocks first.

    Returns
    -------
    BranchResult

    Raises
    ------
    ModelError
        When the model is not smooth, or its ``unknown_input_derivatives`` key is beyond the bound of
        :func:`obsnl.observability.limits.check_analysis_limits`.
    OptionError
        When ``unknown_input_derivatives`` is beyond that bound.
    AnalysisError
        When an option is invalid, the model has more unknowns than
        :data:`obsnl.observability.limits.MAX_UNKNOWNS`, or the analysis runs out of memory.
    """
    k, variables = check_model_and_options(
        model, method, seed, max_seconds, prob, unknown_input_derivatives, input_derivatives
    )
    if not model.is_smooth:
        raise ModelError(
            f"model {model.name!r} is not smooth; use obsnl.observability.analyze (which splits it into branches) or "
            f"obsnl.model.split_branches"
        )
    t0 = time.perf_counter()
    deadline = None if max_seconds is None else t0 + float(max_seconds)
    try:
        br, _ = _branch_result(
            "smooth",
            "true",
            model,
            variables,
            method=method,
            seed=fresh_seed(seed),
            deadline=deadline,
            target=1 - prob,
            decompose=decompose,
            unknown_input_derivatives=k,
            input_derivatives=input_derivatives,
        )
        return br
    except MemoryError:  # numpy's _ArrayMemoryError too; raised below, once the arrays are freed
        pass
    raise out_of_memory(model, k)


def orc(
    model: Model,
    *,
    seed: int | None = None,
    max_seconds: float | None = None,
    unknown_input_derivatives: int | str | None = None,
    input_derivatives: int | None = None,
    decompose: bool = True,
) -> BranchResult:
    """Hermann-Krener observability rank condition of a smooth model (extended Lie derivatives).

    Parameters
    ----------
    model : Model
        A smooth :class:`~obsnl.model.core.Model` (use :func:`obsnl.observability.analyze` for non-smooth ones).
    seed : int or None
        Seed of the random prime and point; None draws one.
    max_seconds : float or None
        Time limit (symbolic Lie derivatives swell); reaching it gives ``INCONCLUSIVE``.
    unknown_input_derivatives : int or str or None
        As in :func:`obsnl.analyze`.
    input_derivatives : int or None
        As in :func:`obsnl.analyze`.
    decompose : bool
        As in :func:`obsnl.analyze`.

    Returns
    -------
    BranchResult
        ``order`` is the number of Lie derivatives used.

    References
    ----------
    .. [1] R. Hermann and A. J. Krener, "Nonlinear controllability and observability", IEEE Trans. Automatic Control
       22(5), 728-740, 1977. doi:10.1109/TAC.1977.1101601

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="decay", states=["x"], parameters=["a", "b"],
    ...           equations={"x": "-a*b*x"}, outputs={"y": "x"})
    >>> r = orc(m, seed=1)
    >>> r.unobservable, r.order
    (('a', 'b'), 2)
    """
    return analyze_smooth(
        model,
        method="orc",
        seed=seed,
        max_seconds=max_seconds,
        unknown_input_derivatives=unknown_input_derivatives,
        input_derivatives=input_derivatives,
        decompose=decompose,
    )


def sedoglavic(
    model: Model,
    *,
    seed: int | None = None,
    max_seconds: float | None = None,
    unknown_input_derivatives: int | str | None = None,
    input_derivatives: int | None = None,
    decompose: bool = True,
) -> BranchResult:
    """Sedoglavic's randomized observability test of a smooth model.

    Parameters
    ----------
    model : Model
        A smooth :class:`~obsnl.model.core.Model` (split non-smooth models with
        :func:`obsnl.model.split_branches`, or use :func:`obsnl.observability.analyze`).
    seed : int or None
        Seed of every random choice (prime, point, inputs); None draws one and reports it.
    max_seconds : float or None
        Time limit; reaching it gives an ``INCONCLUSIVE`` verdict, never an unobservable one.
    unknown_input_derivatives : int or str or None
        ``K``: each unknown input a polynomial with K non-zero derivatives (STRIKE-GOLDD ``nnzDerW``);
        ``"arbitrary"``: any function of time; None: the model's ``unknown_input_derivatives`` key,
        else ``"arbitrary"``.
    input_derivatives : int or None
        Number of non-zero derivatives of the known inputs (None: generic inputs).
    decompose : bool
        Analyse the output-reachable submodel and its independent blocks separately.

    Returns
    -------
    BranchResult
        Label ``"smooth"``, guard ``"true"``.

    References
    ----------
    .. [1] A. Sedoglavic, "A probabilistic algorithm to test local algebraic observability in polynomial time", J.
       Symbolic Computation 33(5), 735-755, 2002. doi:10.1006/jsco.2002.0532

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="decay", states=["x"], parameters=["a", "b"],
    ...           equations={"x": "-a*b*x"}, outputs={"y": "x"})
    >>> r = sedoglavic(m, seed=1)
    >>> r.observable, r.unobservable, r.transcendence_degree
    (('x',), ('a', 'b'), 1)
    """
    return analyze_smooth(
        model,
        method="sedoglavic",
        seed=seed,
        max_seconds=max_seconds,
        unknown_input_derivatives=unknown_input_derivatives,
        input_derivatives=input_derivatives,
        decompose=decompose,
    )
