"""``analyze``: observability of every smooth branch of a model, and their union.

Per branch (:func:`obsnl.split_branches`): variables absent from the branch's equations are listed
as unobservable and absent (they count in the transcendence degree, as the seed paper counts
``w_h`` in branches (b), (d)); the output-reachable submodel is split into independent blocks
(:mod:`obsnl.observability.decompose`); each block is rationalized (:mod:`obsnl.algebra.augment`) and analysed by the
chosen engine: ``"orc"`` (:mod:`obsnl.observability.orc`, symbolic Lie derivatives evaluated mod p) or
``"sedoglavic"`` (:mod:`obsnl.observability.sedoglavic`, power series mod p). ``"auto"`` uses the ORC on tiny
blocks (at most 6 unknowns, with a short time budget) and the series engine otherwise.

A time limit or a disagreement of random points gives ``Verdict.INCONCLUSIVE`` with a reason;
no unobservable verdict ever comes from a truncated computation.
"""

from __future__ import annotations

import time
from dataclasses import replace

from obsnl.model.branches import split_branches
from obsnl.model.switching import expr_text
from obsnl.model.core import Model
from obsnl.model.signature import ModelSignature
from obsnl.observability.results import AnalysisResult, BranchResult
from obsnl.observability.smooth import METHODS, _branch_result, _check, _fresh_seed, _variable_names

__all__ = ["analyze", "METHODS"]


def analyze(
    model: Model,
    *,
    method: str = "auto",
    seed: int | None = None,
    max_seconds: float | None = None,
    prob: float = 0.99,
    unknown_input_derivatives: int = 1,
    input_derivatives: int | None = None,
    decompose: bool = True,
) -> AnalysisResult:
    """Observability and identifiability of every branch of ``model``.

    Parameters
    ----------
    model
        Any model (smooth or not); non-smooth models are split with :func:`obsnl.split_branches`.
    method
        ``"auto"``, ``"orc"`` or ``"sedoglavic"``.
    seed
        Seed of all random choices; None draws one (reported in the result).
    max_seconds
        Time limit for the whole analysis; branches or blocks not finished are ``INCONCLUSIVE``. The split
        into branches gets at least 2 s of it and raises :class:`~obsnl.errors.AnalysisError` past that.
    prob
        Wanted lower bound on the probability that every verdict is right; more independent runs
        are made while a block's bound is weaker (up to a few; the result reports what was reached).
    unknown_input_derivatives
        Non-zero derivatives of each unknown input (STRIKE-GOLDD ``nnzDerW``, default 1).
    input_derivatives
        Non-zero derivatives of the known inputs (None: generic inputs).
    decompose
        Use the exact dependency-graph decomposition (:mod:`obsnl.observability.decompose`).

    Returns
    -------
    AnalysisResult
        One :class:`~obsnl.observability.results.BranchResult` per branch, the union, the seed and the bound.

    Raises
    ------
    AnalysisError
        No outputs, an output that depends on no state, an unknown method or a bad option.
    NotSupportedError
        A function or term the exact engines cannot handle (the message says what to do).

    Examples
    --------
    >>> from obsnl import Model, analyze
    >>> m = Model(name="friction", states=["x", "v"], parameters=["c", "mu"], inputs=["u"],
    ...           equations={"x": "v", "v": "u - c*v - mu*sign(v)"}, outputs={"y": "x"})
    >>> res = analyze(m, seed=0)
    >>> [(b.label, b.unobservable) for b in res.branches]
    [('a', ()), ('b', ())]
    """
    _check(model, method, seed, max_seconds, prob, unknown_input_derivatives, input_derivatives)
    t0 = time.perf_counter()
    deadline = None if max_seconds is None else t0 + float(max_seconds)
    seed = _fresh_seed(seed)
    variables = _variable_names(model)
    # the split is bounded too, with a floor: a tiny limit still yields branches (each then inconclusive)
    branches = split_branches(model, max_seconds=None if max_seconds is None else max(float(max_seconds), 2.0))
    n_blocks_guess = max(1, len(branches))
    target = (1 - prob) / n_blocks_guess
    results: list[BranchResult] = []
    failure = 0.0
    factor_cache: dict = {}  # branches share their logarithm arguments (|sigma - eta| in the seed model)
    for b in branches:
        br, f = _branch_result(b.label, b.guard_text, b.model, variables, method=method, seed=seed,
                               deadline=deadline, target=target, decompose=decompose,
                               unknown_input_derivatives=unknown_input_derivatives,
                               input_derivatives=input_derivatives, factor_cache=factor_cache)
        results.append(replace(br, signs=tuple(b.signs)))
        failure += f
    return AnalysisResult(
        model=model.name,
        method=method,
        seed=seed,
        probability=max(0.0, 1.0 - failure),
        seconds=round(time.perf_counter() - t0, 6),
        branches=tuple(results),
        variables=variables,
        switching=tuple(expr_text(g) for g in branches[0].switching) if branches else (),
        parameters=tuple(p.name for p in model.parameters),
        latex=dict(model.latex),
        signature=ModelSignature(name=model.name, fingerprint=model.fingerprint,
                                 states=tuple(s.name for s in model.states),
                                 parameters=tuple(p.name for p in model.parameters),
                                 inputs=tuple(s.name for s in model.inputs), outputs=tuple(model.output_names),
                                 switching=tuple(expr_text(g) for g in branches[0].switching) if branches else ()),
    )
