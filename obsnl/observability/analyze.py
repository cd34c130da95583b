"""``analyze``: observability of every smooth branch of a model, their union, and the joint verdict.

The per-branch results and their union are the seed paper's rule (Chatzis, Chatzi & Smyth 2015);
the joint verdict (:mod:`obsnl.observability.joint.verdict`) is what the visited branches and the visible
switching surfaces reveal together, parameters being shared. Which branches are visited is decided by
:mod:`obsnl.observability.joint.selection` (every feasible branch by default).

Per branch (:func:`obsnl.model.split_branches`): variables absent from the branch's equations are listed
as unobservable and absent (they count in the transcendence degree, as the seed paper counts
``w_h`` in branches (b), (d)); the output-reachable submodel is split into independent blocks
(:mod:`obsnl.observability.engines.decompose`); each block is rationalized (:mod:`obsnl.algebra.augment`) and analysed by the
chosen engine: ``"orc"`` (:mod:`obsnl.observability.engines.orc`, symbolic Lie derivatives evaluated mod p) or
``"sedoglavic"`` (:mod:`obsnl.observability.engines.sedoglavic`, power series mod p). ``"auto"`` uses the series engine,
and the ORC (with a short time budget) only on a small block (at most 6 unknowns) that the series
engine left undecided.

A time limit or a disagreement of random points gives ``Verdict.INCONCLUSIVE`` with a reason;
no unobservable verdict ever comes from a truncated computation.
"""

from __future__ import annotations

import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from obsnl._text import quote
from obsnl.errors import AnalysisError
from obsnl.model.bounds.budget import deadline as budget_deadline
from obsnl.model.branching.signature import ModelSignature
from obsnl.model.branching.switching import expr_text
from obsnl.model.core import Model
from obsnl.model.files import read_model
from obsnl.observability.assumptions import Assumptions, InitialConditions
from obsnl.observability.certificates.certify import (
    certify_by_symmetry,
    undecided_beyond_visits,
)
from obsnl.observability.engines.inputs import METHODS, check_model_and_options
from obsnl.observability.engines.smooth import branch_result, fresh_seed
from obsnl.observability.joint.selection import select_branches
from obsnl.observability.joint.verdict import joint_verdict_of
from obsnl.observability.limits import out_of_memory
from obsnl.observability.results import AnalysisResult
from obsnl.observability.verdicts import BranchResult

__all__ = ["analyze", "check_analysis", "run_analysis", "CheckedAnalysis", "assumptions", "METHODS"]


def analyze(
    model: Model | str | os.PathLike,
    *,
    method: str = "auto",
    seed: int | None = 0,
    max_seconds: float | None = None,
    prob: float = 0.99,
    unknown_input_derivatives: int | str | None = None,
    input_derivatives: int | None = None,
    decompose: bool = True,
    branches: Sequence[str] | None = None,
    visited: Mapping[tuple[int, ...], float] | None = None,
    crossings: Mapping[str, int] | None = None,
    joint: bool = True,
    per_branch: bool = True,
) -> AnalysisResult:
    """Observability and identifiability of every branch of ``model``, their union and the joint verdict.

    Parameters
    ----------
    model : Model or str or os.PathLike
        Any model (smooth or not), or its file (a path, or ``obsnl:NAME`` for a packaged one, read with
        :func:`obsnl.read_model`); non-smooth models are split with :func:`obsnl.model.split_branches`.
    method : str
        ``"auto"``, ``"orc"`` or ``"sedoglavic"``.
    seed : int or None
        Seed of all random choices (default 0: the same answer on every run, its error probability stated); None
        draws one (reported in the result).
    max_seconds : float or None
        Time limit for the whole analysis; branches or blocks not finished are ``INCONCLUSIVE``. The split
        into branches gets at least 2 s of it and raises :class:`~obsnl.errors.AnalysisError` past that. Inside a
        command's :func:`obsnl.model.bounds.budget.time_budget` (``obsnl analyze --max-seconds``, started before the
        model was read) that budget's deadline holds as well, without the 2 s floor.
    prob : float
        Wanted lower bound on the probability that every verdict is right; more independent runs
        are made while a block's bound is weaker (up to a few; the result reports what was reached).
    unknown_input_derivatives : int or str or None
        What the unknown inputs are: ``"arbitrary"`` (any function of time: each Taylor coefficient
        the test reads is a new unknown, see :func:`obsnl.algebra.problem.arbitrary_terms`) or ``K``
        (polynomials with K non-zero derivatives, STRIKE-GOLDD ``nnzDerW``; 0: constants), K at most the
        model's states + parameters + 16 (:func:`obsnl.model.reading.unknown_inputs.max_unknown_input_derivatives`:
        more derivatives add nothing to the rank test). None (the default): the model's
        ``unknown_input_derivatives`` key, else ``"arbitrary"``.
    input_derivatives : int or None
        Non-zero derivatives of the known inputs (None: generic inputs).
    decompose : bool
        Use the exact dependency-graph decomposition (:mod:`obsnl.observability.engines.decompose`).
    branches : sequence of str or None
        Labels of the branches to visit (default: every feasible branch; representative branches
        when the model has more than 8 switching functions, see :mod:`obsnl.model.branching.representatives`).
    visited : mapping of tuple of int to float or None
        Sign patterns a record visits, with the seconds spent in each
        (:func:`obsnl.observability.joint.visited.visited_patterns`); overrides ``branches``.
    crossings : mapping of str to int or None
        Crossings per switching function seen with ``visited`` (reported only).
    joint : bool
        Also compute the joint verdict (default True).
    per_branch : bool
        Also analyse each branch on its own (default True); False gives the joint verdict only
        (``branches`` then holds just the branches whose feasibility is undecided), about a third of
        the time on a building: what a search over sensor sets (:mod:`obsnl.design`) needs.

    Returns
    -------
    AnalysisResult
        One :class:`~obsnl.observability.verdicts.BranchResult` per visited branch, the union, the joint
        verdict (:class:`~obsnl.observability.joint.result.JointResult`), how the branches were chosen, the
        seed, the bound and the ``assumptions`` the verdicts rest on (unknown and known inputs,
        initial conditions).

    Raises
    ------
    AnalysisError
        No outputs, an output that depends on no state, an unknown method or a bad option; a model with
        more unknowns (states + parameters + unknown-input coefficients) than
        :data:`obsnl.observability.limits.MAX_UNKNOWNS`, refused before any work; running out of memory.
    OptionError
        ``unknown_input_derivatives`` larger than the model can use (its states + parameters + 16, see
        :func:`obsnl.model.reading.unknown_inputs.max_unknown_input_derivatives`), refused before any work.
    ModelError
        The same for the model's ``unknown_input_derivatives`` key.
    NotSupportedError
        A function or term the exact engines cannot handle (the message says what to do).

    References
    ----------
    .. [1] M. N. Chatzis, E. N. Chatzi and A. W. Smyth, "On the observability and identifiability of nonlinear
       structural and mechanical systems", Structural Control and Health Monitoring 22(3), 574-593, 2015.
       doi:10.1002/stc.1690
    .. [2] A. Sedoglavic, "A probabilistic algorithm to test local algebraic observability in polynomial time", J.
       Symbolic Computation 33(5), 735-755, 2002. doi:10.1006/jsco.2002.0532
    .. [3] R. Hermann and A. J. Krener, "Nonlinear controllability and observability", IEEE Trans. Automatic Control
       22(5), 728-740, 1977. doi:10.1109/TAC.1977.1101601

    Examples
    --------
    >>> from obsnl import Model, analyze
    >>> m = Model(name="friction", states=["x", "v"], parameters=["c", "mu"], inputs=["u"],
    ...           equations={"x": "v", "v": "u - c*v - mu*sign(v)"}, outputs={"y": "x"})
    >>> res = analyze(m, seed=0)
    >>> [(b.label, b.unobservable) for b in res.branches]
    [('a', ()), ('b', ())]
    >>> res.joint.unobservable
    ()
    """
    if isinstance(model, (str, os.PathLike)):  # a path is accepted wherever a model is, as identify does
        model = read_model(model)
    checked = check_analysis(
        model,
        method=method,
        seed=seed,
        max_seconds=max_seconds,
        prob=prob,
        unknown_input_derivatives=unknown_input_derivatives,
        input_derivatives=input_derivatives,
        decompose=decompose,
        branches=branches,
        joint=joint,
        per_branch=per_branch,
    )
    return run_analysis(checked, visited=visited, crossings=crossings)


@dataclass(frozen=True, kw_only=True)
class CheckedAnalysis:
    """An analysis of one model, its options checked and what they settle resolved once
    (:func:`check_analysis`): what :func:`run_analysis` runs.

    Attributes
    ----------
    model : Model
        The model.
    variables : tuple of str
        The reported variables: every state, then every parameter.
    unknown_input_derivatives : int or str
        The unknown-input assumption in force (the option, else the model's key, else ``"arbitrary"``).
    method, seed, max_seconds, prob, input_derivatives, decompose, branches, joint, per_branch
        The options of :func:`analyze`, checked.
    """

    model: Model
    variables: tuple[str, ...]
    unknown_input_derivatives: int | str
    method: str
    seed: int | None
    max_seconds: float | None
    prob: float
    input_derivatives: int | None
    decompose: bool
    branches: Sequence[str] | None
    joint: bool
    per_branch: bool


def check_analysis(
    model: Model,
    *,
    method: str = "auto",
    seed: int | None = 0,
    max_seconds: float | None = None,
    prob: float = 0.99,
    unknown_input_derivatives: int | str | None = None,
    input_derivatives: int | None = None,
    decompose: bool = True,
    branches: Sequence[str] | None = None,
    joint: bool = True,
    per_branch: bool = True,
    option: str = "unknown_input_derivatives",
) -> CheckedAnalysis:
    """Check an analysis's options and the model's size once, before any work, and resolve what they settle.

    A command that reads a record between the checks and the analysis (``obsnl analyze --record``) calls this
    first and :func:`run_analysis` after; :func:`analyze` calls both.

    Parameters
    ----------
    model : Model
        The model (a command reads its file first, once).
    method : str
        As for :func:`analyze`.
    seed : int or None
        As for :func:`analyze`.
    max_seconds : float or None
        As for :func:`analyze`.
    prob : float
        As for :func:`analyze`.
    unknown_input_derivatives : int, str or None
        As for :func:`analyze`.
    input_derivatives : int or None
        As for :func:`analyze`.
    decompose : bool
        As for :func:`analyze`.
    branches : sequence of str or None
        As for :func:`analyze`.
    joint : bool
        As for :func:`analyze`.
    per_branch : bool
        As for :func:`analyze`.
    option : str
        How messages name the caller's unknown-input option (``"unknown_input_derivatives="``: the command line
        prints its flag).

    Returns
    -------
    CheckedAnalysis

    Raises
    ------
    AnalysisError, OptionError, ModelError
        As :func:`analyze`, before any work.

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="m", states=["x"], parameters=["a"], equations={"x": "-a*x"}, outputs={"y": "x"})
    >>> check_analysis(m).variables
    ('x', 'a')
    """
    k, variables = check_model_and_options(
        model, method, seed, max_seconds, prob, unknown_input_derivatives, input_derivatives, option=option
    )
    if isinstance(branches, str):  # "a,c" as the command line takes it; "ab" is one label, not a and b
        branches = [b.strip() for b in branches.split(",") if b.strip()]
    elif branches is not None and (not isinstance(branches, Sequence) or not all(isinstance(b, str) for b in branches)):
        raise AnalysisError(f"branches= takes labels, e.g. ['a', 'c'] or 'a,c', got {quote(branches, 40)}")
    return CheckedAnalysis(
        model=model,
        variables=variables,
        unknown_input_derivatives=k,
        method=method,
        seed=seed,
        max_seconds=max_seconds,
        prob=prob,
        input_derivatives=input_derivatives,
        decompose=decompose,
        branches=branches,
        joint=joint,
        per_branch=per_branch,
    )


def run_analysis(
    checked: CheckedAnalysis,
    *,
    visited: Mapping[tuple[int, ...], float] | None = None,
    crossings: Mapping[str, int] | None = None,
) -> AnalysisResult:
    """Run a checked analysis (:func:`check_analysis`): the checks are not made again, inside or below.

    Parameters
    ----------
    checked : CheckedAnalysis
        The model and its options, checked.
    visited : mapping of tuple of int to float or None
        As for :func:`analyze`.
    crossings : mapping of str to int or None
        As for :func:`analyze`.

    Returns
    -------
    AnalysisResult
        As for :func:`analyze`.

    Raises
    ------
    AnalysisError
        Running out of memory.
    """
    if not isinstance(checked, CheckedAnalysis):  # an AttributeError below otherwise
        raise AnalysisError(
            f"run_analysis takes the CheckedAnalysis that check_analysis returns, got {type(checked).__name__}; "
            f"or call obsnl.analyze with the model"
        )
    try:  # the joint verdict and the symmetry certificates below take the checked model: they do not check again
        return _analyze(checked, visited, crossings)
    except MemoryError:  # numpy's _ArrayMemoryError too; raised below, once the arrays are freed
        pass
    raise out_of_memory(checked.model, checked.unknown_input_derivatives)


def _analyze(
    checked: CheckedAnalysis,
    visited: Mapping[tuple[int, ...], float] | None,
    crossings: Mapping[str, int] | None,
) -> AnalysisResult:
    """The body of :func:`run_analysis`: the branches chosen once and handed down."""
    model, variables, method, seed = checked.model, checked.variables, checked.method, checked.seed
    max_seconds, prob, per_branch = checked.max_seconds, checked.prob, checked.per_branch
    unknown_input_derivatives = checked.unknown_input_derivatives
    t0 = time.perf_counter()
    deadline = None if max_seconds is None else t0 + float(max_seconds)
    outer = budget_deadline()  # a command's budget (obsnl.model.bounds.budget.time_budget), started before reading
    deadline = outer if deadline is None else deadline if outer is None else min(deadline, outer)
    seed = fresh_seed(seed)
    # the split is bounded too, with a floor: a tiny limit still yields branches (each then inconclusive)
    chosen, how = select_branches(
        model,
        labels=checked.branches,
        patterns=visited,
        crossings=crossings,
        seed=seed,
        max_seconds=None if max_seconds is None else max(float(max_seconds), 2.0),
    )
    target = (1 - prob) / max(1, len(chosen))
    results: list[BranchResult] = []
    failure = 0.0
    factor_cache: dict = {}  # branches share their logarithm arguments (|sigma - eta| in the seed model)
    for b in chosen:
        if per_branch or b.undecided:  # an undecided one is reported as such, never silently dropped
            br, f = branch_result(
                b,
                variables,
                method=method,
                seed=seed,
                deadline=deadline,
                target=target,
                decompose=checked.decompose,
                unknown_input_derivatives=unknown_input_derivatives,
                input_derivatives=checked.input_derivatives,
                factor_cache=factor_cache,
            )
            results.append(br)
            failure += f
    verdict = None
    decided = [b for b in chosen if not b.undecided]
    if (checked.joint or not per_branch) and decided:
        left = None if deadline is None else max(deadline - time.perf_counter(), 1e-3)
        verdict = joint_verdict_of(
            model, decided, seed=seed, prob=prob, max_seconds=left, unknown_input_derivatives=unknown_input_derivatives
        )
        representatives = how.how == "representatives"
        if (representatives or len(decided) < len(chosen)) and verdict.unobservable:
            verdict = undecided_beyond_visits(verdict, how.note)  # a verdict about the model, not decided by the visits
        if verdict.inconclusive and (deadline is None or time.perf_counter() < deadline):
            verdict = certify_by_symmetry(
                verdict, model, chosen, seed=seed, kinds=("scaling", "translation") if representatives else None
            )
    switching = tuple(expr_text(g) for g in chosen[0].switching) if chosen else ()
    return AnalysisResult(
        model=model.name,
        method=method,
        seed=seed,
        # every verdict printed: the branches' and the joint one's (a union bound: each may fail on its own)
        probability=(
            max(0.0, 1.0 - failure - (0.0 if verdict is None else 1.0 - verdict.probability))
            if per_branch
            else 1.0 - failure
            if verdict is None
            else verdict.probability
        ),
        seconds=round(time.perf_counter() - t0, 6),
        branches=tuple(results),
        variables=variables,
        switching=switching,
        parameters=tuple(p.name for p in model.parameters),
        latex=dict(model.latex),
        signature=ModelSignature.of(model, switching=switching),
        joint=verdict,
        visited=how,
        assumptions=assumptions(model, unknown_input_derivatives, checked.input_derivatives),
    )


def assumptions(model: Model, unknown_input_derivatives: int | str, input_derivatives: int | None) -> Assumptions:
    """What an analysis of ``model`` assumes (:attr:`AnalysisResult.assumptions`; ``to_dict()`` is its JSON).

    Parameters
    ----------
    model : Model
        The analysed model.
    unknown_input_derivatives : int or str
        The unknown-input assumption in force (``K`` or ``"arbitrary"``).
    input_derivatives : int or None
        Degree of the known inputs as polynomials, or None (generic inputs).

    Returns
    -------
    Assumptions
        ``unknown_input_derivatives``, ``known_inputs`` and ``initial_conditions``; the ``bounds`` the model
        declares (``{name: (lo, hi)}``, an infinite end as ``"inf"``/``"-inf"``: only the sign patterns that
        can hold within them are branches).

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="m", states=["x"], parameters=["a"], unknown_inputs=["w"],
    ...           equations={"x": "-a*x + w"}, outputs={"y": "x"})
    >>> assumptions(m, "arbitrary", None).unknown_input_derivatives
    'arbitrary'
    """
    known = model.known_initial_conditions
    return Assumptions(
        unknown_input_derivatives=unknown_input_derivatives if model.unknown_inputs else None,
        known_inputs=None
        if not model.inputs
        else ("generic" if input_derivatives is None else f"polynomial of degree {input_derivatives}"),
        initial_conditions=InitialConditions(
            unknown=tuple(s.name for s in model.states if s not in known),
            known_generic=tuple(s.name for s in known if s not in model.initial_condition_values),
            known_values={s.name: str(v) for s, v in model.initial_condition_values.items()},
        ),
        bounds=dict(model.bounds or {}),
    )
