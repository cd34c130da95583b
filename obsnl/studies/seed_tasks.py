"""The independent tasks of ``obsnl reproduce``, as an :class:`obsnl.executor.Executor` runs them.

A task carries a :class:`Spec` (the record, the number of samples, JIT or not, the branch table's
JSON) and what it computes (a filter, a tuning, noise seeds), never a compiled object. A worker
builds the experiment and its filters from the spec once (:func:`context`; the compiled code
comes from the disk cache) and keeps them for its next tasks. Every random draw is fixed by the
task's own seeds, so the results do not depend on where or in which order the tasks run.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from obsnl.errors import ObsnlError, OutputError
from obsnl.identification.experiments import (DIVERGED, Practical, Setup, Tuning, coordinates, make_data, make_filter,
                                          mc_replicates, mc_truth, output_misfit, practical_identifiability,
                                          run_passes, tune_one)
from obsnl.estimation.records import Record
from obsnl.estimation.ukf import Trajectory
from obsnl.estimation.ukf_step import INTERVENTIONS
from obsnl.executor import built_once
from obsnl.model.files import catalogue_path

__all__ = ["Spec", "context", "compile_task", "tuning_task", "reported_task", "replicates_task", "refine_task", "late_task",
           "RunResult", "Refined", "seed_setup", "seed_record", "check_record_name", "seed_model_path",
           "reported_with_fallbacks", "SEED_GUESS", "FALLBACKS", "ML_MAX_ITER"]

#: Initial guesses of Table 2 of the seed paper (000_d24855f97fc8bdd4.txt).
SEED_GUESS: Mapping[str, float] = {"k_m": 5e3, "c_dm": 50.0, "c_eta_p": 3e3, "c_p": 4.0, "h_p": 4e-3, "N": 3.0,
                                   "w_h": 0.3, "Delta1": 3e10, "Delta2": -6e9}
#: A reported run whose free-run output misfit exceeds ``DIVERGED`` times the stated output noise
#: level (:data:`obsnl.identification.experiments.DIVERGED`; the noise floor of the misfit is 1x) has diverged; it is
#: redone with the next configuration of the tuning ranking, at most ``FALLBACKS`` times. Uses the
#: measured data only, never the truth.
FALLBACKS = 2
#: Levenberg-Marquardt iterations at most per weighting of the maximum-likelihood refinement of a reported
#: seed (:func:`obsnl.identification.refine.refine` fits with the stated noise level, then again with the
#: noise level of its residuals). Bounds its time: on this model's rough objective (the healing switch) the
#: iteration reaches its lowest chi2 within about 10 iterations and then takes steps that gain less than 0.5 in
#: chi2 (measured on the five reported seeds: the errors after 12 and after 40 iterations agree to 0.01
#: percentage points on every parameter, the verdicts are the same, and the five refinements take 135 instead
#: of 182 CPU-seconds); a refinement cut there says so in its reason and is not called converged.
ML_MAX_ITER = 12


@dataclass(frozen=True, eq=False)
class RunResult:
    """One reported filter run: final estimate, cost, repairs, misfit, practical identifiability."""

    method: str
    passes: int
    seed: int
    tuning: Tuning
    theta: tuple[float, ...]
    seconds: float
    repairs: int
    implicit: int
    misfit: float
    practical: Practical | None
    error: str = ""
    interventions: Mapping[str, int] = field(default_factory=dict)
    redone: tuple[Mapping[str, Any], ...] = ()
    passes_run: int | None = None  # fewer than ``passes`` when an estimate could not be simulated

    @property
    def failed(self) -> bool:
        """True when the filter stopped (NaN); the run is reported with its error, not dropped."""
        return bool(self.error)

    def errors(self, truth: np.ndarray) -> np.ndarray:
        """Error of each parameter in % of its true value."""
        return 100.0 * (np.asarray(self.theta) - truth) / np.abs(truth)

    def to_dict(self, parameters: Sequence[str], truth: np.ndarray) -> dict[str, Any]:
        err = self.errors(truth)
        return {"method": self.method, "passes": self.passes, "seed": self.seed, "tuning": self.tuning.to_dict(),
                "parameters": {p: {"true": float(t), "estimate": _num(e), "error_percent": _num(r)}
                               for p, t, e, r in zip(parameters, truth, self.theta, err)},
                "seconds": _num(self.seconds), "repairs": self.repairs, "interventions": dict(self.interventions),
                "implicit_sigma_point_steps": self.implicit,
                "output_misfit": _num(self.misfit), "error": self.error,
                "passes_run": self.passes if self.passes_run is None else self.passes_run,
                # None: not decided (the run stopped, or its estimate diverged: see practical_identifiability)
                "practically_unidentifiable": (list(self.practical.flagged)
                                               if self.practical and not self.practical.inconclusive else None),
                "practical_identifiability": self.practical.to_dict() if self.practical else None,
                "redone": [dict(a) for a in self.redone]}


@dataclass(frozen=True, eq=False)
class Refined:
    """The maximum-likelihood refinement of one reported seed (:func:`obsnl.identification.refine.refine`).

    ``start``: the filter run it started from (``method``, ``passes``, ``output_misfit``); ``std``: the Fisher
    std per parameter at the estimate (``inf`` along a flat direction); ``converged`` and ``reason`` as the
    refinement says them (first-order condition and last step); ``error``: why it could not run (then no
    estimate).
    """

    seed: int
    start: Mapping[str, Any]
    theta: tuple[float, ...]
    std: tuple[float, ...]
    converged: bool
    reason: str
    seconds: float
    iterations: int = 0
    misfit_over_noise: Mapping[str, float] = field(default_factory=dict)
    at_edge: tuple[str, ...] = ()
    newton_decrement: float = float("nan")
    last_step_in_std: float = float("nan")
    error: str = ""

    def to_dict(self, parameters: Sequence[str], truth: np.ndarray) -> dict[str, Any]:
        err = 100.0 * (np.asarray(self.theta) - truth) / np.abs(truth)
        rel = 100.0 * np.asarray(self.std) / np.abs(np.asarray(self.theta))
        return {"seed": self.seed, "start": dict(self.start),
                "parameters": {p: {"true": float(t), "estimate": _num(e), "error_percent": _num(r), "std": _num(s),
                                   "std_percent": _num(q)}
                               for p, t, e, r, s, q in zip(parameters, truth, self.theta, err, self.std, rel)},
                "converged": self.converged, "reason": self.reason, "error": self.error,
                "seconds": _num(self.seconds), "iterations": self.iterations,
                "newton_decrement": _num(self.newton_decrement), "last_step_in_std": _num(self.last_step_in_std),
                "misfit_over_noise": {k: _num(v) for k, v in self.misfit_over_noise.items()},
                "at_edge": list(self.at_edge)}


def seed_model_path() -> str:
    """The packaged ``damage_healing_reparam.toml`` (the model of the seed experiment)."""
    return str(catalogue_path("damage_healing_reparam"))


def check_record_name(name: str) -> str:
    """Refuse a record name that cannot be one folder below ``reports/identification``.

    Parameters
    ----------
    name : str
        The record's name (its file's stem).

    Returns
    -------
    str
        ``name``.

    Raises
    ------
    OutputError
        ``""``, ``"."``, ``".."``, or a name with a path separator or a NUL.

    Examples
    --------
    >>> check_record_name("northridge")
    'northridge'
    >>> check_record_name("..")
    Traceback (most recent call last):
    ...
    obsnl.errors.OutputError: the record's name '..' (its file name without the extension) cannot name a folder below reports/identification; rename the record file
    """
    if name in ("", ".", "..") or any(c and c in name for c in ("/", "\0", os.sep, os.altsep)):
        raise OutputError(f"the record's name {name!r} (its file name without the extension) cannot name a folder "
                          f"below reports/identification; rename the record file")
    return name


def seed_record(record: Record | None = None, samples: int | None = None) -> Record:
    """The record of the seed experiment: Northridge 1994 LOS270, or ``record`` resampled to 100 Hz and
    cut to its first 2000 samples; then its first ``samples``.

    Parameters
    ----------
    record : Record or None
        Another record (None: Northridge 1994 LOS270, as the seed paper).
    samples : int or None
        Keep only the first samples.

    Returns
    -------
    Record

    Raises
    ------
    DataError
        A step that cannot be resampled to 100 Hz, or fewer than 2 samples.
    OutputError
        A record whose name (its file's stem) is not a plain folder name: ``obsnl reproduce`` writes into
        ``reports/identification/<name>``, and a file named ``...csv`` (stem ``..``) led into ``reports/``.

    Examples
    --------
    >>> len(seed_record(samples=300)), seed_record().dt
    (300, 0.01)
    """
    from importlib import resources

    from obsnl.estimation.records import read_record

    if record is None:
        record = read_record(str(resources.files("obsnl").joinpath("studies/data/northridge1994_LOS270_ngawest2_accel.csv")))
    else:
        check_record_name(record.name)
        record = record.resampled(0.01)
        record = record.head(min(len(record), 2000))
    return record if samples is None else record.head(samples)


def seed_setup(*, record: Record | None = None, samples: int | None = None, jit: bool = False,
               kind: str = "log") -> Setup:
    """The seed paper's experiment (on another record when given: resampled to 100 Hz, first 2000 samples).

    Parameters
    ----------
    record : Record or None
        Another record (None: Northridge 1994).
    samples : int or None
        Use only the first samples.
    jit : bool
        Compile the filter step.
    kind : str
        Filter coordinates (:func:`obsnl.identification.setup.coordinates`).

    Returns
    -------
    Setup
    """
    from obsnl.estimation.codegen import to_casadi
    from obsnl.model.files import read_model

    model = read_model(seed_model_path())
    record = seed_record(record, samples)
    num = to_casadi(model)
    truth = {p: float(model.values[p]) for p in num.parameters}
    return Setup(model=num, record=record, truth=truth, guess=dict(SEED_GUESS), jit=jit,
                 coordinates=coordinates(num, kind, reference=SEED_GUESS))


def _interventions(trs: Sequence[Trajectory]) -> dict[str, int]:
    return {k: int(sum(t.counts()[k] for t in trs)) for k in INTERVENTIONS}


def _num(v: float) -> float | None:
    """A finite number, or None (JSON has no NaN)."""
    return float(v) if np.isfinite(v) else None


def _diverged(run: RunResult, setup: Setup) -> bool:
    """The run stopped, or its estimate reproduces the measured output worse than ``DIVERGED`` x noise."""
    return run.failed or not (run.misfit <= DIVERGED * setup.noise)


def _reported_run(setup: Setup, f: Any, data: Any, name: str, k: int, seed: int,
                  tuning: Tuning) -> tuple[RunResult, tuple[Trajectory, ...] | None]:
    """One reported run (``k`` passes) with its misfit and practical identifiability; a stop is a failed run."""
    try:
        trs, _ = run_passes(setup, f, data, tuning, passes=k)
    except ObsnlError as exc:  # reported as a failed run, never dropped
        return RunResult(method=name, passes=k, seed=seed, tuning=tuning, theta=(float("nan"),) * setup.model.np,
                         seconds=float("nan"), repairs=0, implicit=0, misfit=float("nan"), practical=None,
                         error=str(exc)), None
    theta = trs[-1].theta[-1]
    misfit = output_misfit(setup, theta, data)
    return RunResult(
        method=name, passes=k, seed=seed, tuning=tuning, theta=tuple(float(v) for v in theta),
        seconds=float(sum(t.seconds for t in trs)), repairs=sum(t.total_repairs for t in trs),
        implicit=int(sum(t.implicit.sum() for t in trs)), misfit=misfit, interventions=_interventions(trs),
        passes_run=len(trs),
        practical=practical_identifiability(setup, theta, data, first=trs[0], prior_std=tuning.s0,
                                            misfit=misfit)), trs


def reported_with_fallbacks(setup: Setup, f: Any, name: str, k: int, seed: int, ranking: Sequence[Tuning],
                            fallbacks: int = FALLBACKS) -> tuple[RunResult, tuple[Trajectory, ...] | None]:
    """A reported run on noise seed ``seed``; a diverged attempt is recorded and redone with the next
    configuration of ``ranking``, at most ``fallbacks`` times (if all diverge, the last is reported).

    Parameters
    ----------
    setup : Setup
        The experiment.
    f : UKF
        The filter.
    name : str
        Method name recorded in the result.
    k : int
        Number of passes.
    seed : int
        Noise seed.
    ranking : sequence of Tuning
        Configurations, best first.
    fallbacks : int
        Largest number of redone attempts.

    Returns
    -------
    tuple
        ``(RunResult, trajectories or None)``.
    """
    data = make_data(setup, seed)
    result, trs, redone = None, None, []
    for tuning in ranking[:1 + fallbacks]:
        if result is not None:  # the previous attempt diverged: recorded, then redone
            redone.append({"tuning": result.tuning.to_dict(), "output_misfit": _num(result.misfit),
                           "error": result.error})
        result, trs = _reported_run(setup, f, data, name, k, seed, tuning)
        if not _diverged(result, setup):
            break
    if redone:
        result = replace(result, redone=tuple(redone))
    return result, trs


@dataclass(frozen=True, eq=False)
class Spec:
    """What a worker needs to rebuild the seed experiment: plain data only."""

    record: Record | None
    samples: int | None
    jit: bool
    table_json: str


def context(spec: Spec) -> dict[str, Any]:
    """``{"setup", "table", "filters"}`` for ``spec``, built once per process (:func:`obsnl.executor.built_once`)."""

    def build() -> dict[str, Any]:
        from obsnl.observability.contract.branch_table import BranchTable
        setup = seed_setup(record=spec.record, samples=spec.samples, jit=spec.jit)
        table = BranchTable.from_dict(json.loads(spec.table_json))
        filters = {"ukf": make_filter(setup, "ukf"), "dukf": make_filter(setup, "dukf", table=table),
                   "dukf-zero": make_filter(setup, "dukf", table=table, cross="zero")}
        return {"setup": setup, "table": table, "filters": filters}

    return built_once((spec.record, spec.samples, spec.jit, spec.table_json), build)


def compile_task(task: tuple[Spec, str]) -> float:
    """Build (JIT: compile into the disk cache, or load from it) one filter of the experiment; its seconds."""
    import time

    spec, name = task
    tic = time.perf_counter()
    context(spec)["filters"][name]._compiled()
    return time.perf_counter() - tic


def tuning_task(task: tuple[Spec, str, Tuning, int, int]) -> dict[int, float]:
    """One configuration of one filter on one tuning seed: misfits after 1 pass and after ``passes``."""
    spec, name, tuning, seed, passes = task
    ctx = context(spec)
    return tune_one(ctx["setup"], ctx["filters"][name], make_data(ctx["setup"], seed), tuning, passes=passes)


def reported_task(task: tuple[Spec, str, int, int, tuple[Tuning, ...], int]) -> tuple[Any, Any]:
    """One reported run with its fallbacks: ``(RunResult, trajectories of seed 0 or None)``."""
    spec, name, k, seed, ranking, fallbacks = task
    ctx = context(spec)
    result, trs = reported_with_fallbacks(ctx["setup"], ctx["filters"][name], name, k, seed, ranking, fallbacks)
    return result, (trs if seed == 0 else None)  # the figures show seed 0 only


def replicates_task(task: tuple[Spec, str, int, tuple[float, ...], Tuning, int, int, tuple[int, ...]]) -> list[tuple]:
    """Monte-Carlo replicates ``indices`` of one reported run (its data: noise seed ``seed``)."""
    spec, name, seed, theta, tuning, passes, mc_seed, indices = task
    ctx = context(spec)
    setup = ctx["setup"]
    data = make_data(setup, seed)
    y_hat = mc_truth(setup, np.asarray(theta), data)
    if y_hat is None:
        return []
    return mc_replicates(setup, ctx["filters"][name], data, y_hat, tuning, passes=passes, seed=mc_seed,
                         indices=indices)


def refine_task(task: tuple[Spec, int, tuple[float, ...], Mapping[str, Any]]) -> Refined:
    """The maximum-likelihood refinement of reported seed ``seed``, started from ``theta`` (a filter's estimate,
    described by ``start``); every parameter free, the initial state estimated, Fisher std at the estimate."""
    import time

    from obsnl.identification.refine import refine

    spec, seed, theta, start = task
    setup = context(spec)["setup"]
    nan = (float("nan"),) * setup.model.np
    tic = time.perf_counter()
    try:
        ref = refine(setup, make_data(setup, seed), np.asarray(theta, float), max_iter=ML_MAX_ITER,
                     advice="the seed paper's guesses are fixed here: try more filter passes (passes=)")
    except ObsnlError as exc:  # reported with its reason, never dropped
        return Refined(seed=seed, start=start, theta=nan, std=nan, converged=False, reason="", error=str(exc),
                       seconds=time.perf_counter() - tic)
    f = ref.fit
    return Refined(seed=seed, start=start, theta=tuple(map(float, ref.theta)), std=tuple(map(float, ref.std)),
                   converged=bool(ref.converged), reason=ref.reason, seconds=ref.seconds, iterations=ref.iterations,
                   misfit_over_noise=dict(ref.misfit), at_edge=ref.at_edge,
                   newton_decrement=float(f.decrement), last_step_in_std=float(f.last_step))


def late_task(task: tuple[str, tuple]) -> Any:
    """``("refine", task)`` or ``("replicates", task)``: the tasks that follow the reported runs, in one map so
    that the long refinements start first and the replicates fill the workers around them."""
    kind, inner = task
    return refine_task(inner) if kind == "refine" else replicates_task(inner)
