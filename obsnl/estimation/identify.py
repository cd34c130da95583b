"""One identification run of a simulated experiment: the model's ``[values]`` are the truth, the record
drives it, noise is added to input and output, the UKF or the DUKF estimates, and the practical
identifiability of each parameter is judged at the estimate.

:func:`simulation_study` is what ``obsnl identify`` runs; it returns a plain, JSON-ready document
(rendered by :func:`obsnl.report.identification.identify_text`).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from obsnl.errors import EstimatorError, OptionError
from obsnl.estimation.codegen import NumericModel
from obsnl.estimation.experiments import (Tuning, make_data, make_filter, mc_replicates, mc_spread, mc_truth,
                                          run_passes)
from obsnl.estimation.practical import practical_identifiability
from obsnl.estimation.records import Record
from obsnl.estimation.setup import Setup, coordinates, output_misfit
from obsnl.executor import Executor
from obsnl.observability.branch_table import BranchTable

__all__ = ["check_replicates", "simulation_study"]


def check_replicates(replicates: int) -> int:
    """The Monte-Carlo rule, in one place: 0 (off) or at least 3 replicates.

    Parameters
    ----------
    replicates
        The number asked for.

    Returns
    -------
    int
        ``replicates``, checked.

    Raises
    ------
    EstimatorError
        Any other number (a spread of fewer than 3 replicates says nothing).

    Examples
    --------
    >>> check_replicates(0), check_replicates(32)
    (0, 32)
    """
    if not isinstance(replicates, int) or isinstance(replicates, bool) or replicates < 0 or 0 < replicates < 3:
        raise OptionError(f"--replicates must be 0 (off) or at least 3, got {replicates!r}")
    return replicates


def simulation_study(num: NumericModel, record: Record, *, guess: Mapping[str, float], method: str = "ukf",
                     table: BranchTable | None = None, seed: int = 0, noise: float = 1e-3,
                     tuning: Tuning = Tuning(0.2, 0.0, 1.0), passes: int = 3, replicates: int = 0,
                     jit: bool = False, progress: Callable[[], Any] | None = None,
                     executor: Executor | None = None, source: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Identify ``num`` from its own simulated response to ``record`` (the truth: ``num.values``).

    Parameters
    ----------
    num
        The compiled model (:func:`obsnl.to_casadi`); ``num.values`` must hold every parameter.
    record
        The ground motion (or any single input).
    guess
        Initial guess of every parameter.
    method
        ``"ukf"`` or ``"dukf"`` (needs ``table``).
    table
        The branch table of the model (DUKF).
    seed, noise
        Noise seed and noise-to-signal RMS ratio of input and output.
    tuning, passes
        Filter tuning and passes over the record.
    replicates
        Monte-Carlo replicates of the practical-identifiability check (0: off, else at least 3).
    jit
        Compile the filter to C.
    progress
        Called once per Monte-Carlo replicate.
    executor, source
        Where the Monte-Carlo replicates run (:class:`obsnl.executor.Executor`; default: this process)
        in batches of 8; a task carries ``source``, the model's specification (``Model.to_dict()``
        of the model that ``num`` was compiled from), never ``num``. Replicate ``b`` draws its noise
        from ``[seed, b]``: the spread does not depend on the executor.

    Returns
    -------
    dict
        JSON-ready: parameters (true, guess, estimate, error_percent), cost, misfit, flags.

    Raises
    ------
    EstimatorError
        A missing true value or guess, a bad option.
    """
    check_replicates(replicates)
    if method == "dukf" and table is None:
        raise EstimatorError("--method dukf needs --table TABLE.json (write one with `obsnl analyze MODEL`)")
    if passes < 1 or tuning.s0 <= 0 or noise <= 0 or not tuning.gate > 0:
        raise EstimatorError("--passes must be >= 1, --s0, --noise and --gate > 0")
    missing = [q for q in num.parameters if q not in guess]
    if missing:
        raise EstimatorError(f"no initial guess for {missing}; give --guess {missing[0]}=VALUE")
    truth = {q: num.values.get(q) for q in num.parameters}
    if any(v is None for v in truth.values()):
        raise EstimatorError(f"model {num.name!r} needs [values] for every parameter (the truth of the simulation)")
    setup = Setup(model=num, record=record, truth=truth, guess=dict(guess), noise=noise, jit=jit,
                  coordinates=coordinates(num, "log", reference=guess))
    filt = make_filter(setup, method, table=table)
    data = make_data(setup, seed)
    trs, _ = run_passes(setup, filt, data, tuning, passes=passes)
    theta = trs[-1].theta[-1]
    misfit = output_misfit(setup, theta, data)
    prac = practical_identifiability(setup, theta, data, first=trs[0], prior_std=tuning.s0, misfit=misfit)
    if replicates and not prac.inconclusive:
        y_hat = mc_truth(setup, theta, data)
        if y_hat is None:
            outcomes = []
        elif executor is None or executor.kind == "serial":
            outcomes = mc_replicates(setup, filt, data, y_hat, tuning, passes=passes, seed=seed,
                                     indices=range(replicates), progress=progress)
        else:
            if source is None:
                raise OptionError("replicates on an executor need source=Model.to_dict() of the model (tasks carry "
                                  "the model's specification, not the compiled model)")
            spec = (dict(source), None if table is None else table.to_json(), record, dict(guess), noise, jit, method)
            tasks = [(spec, tuple(map(float, theta)), tuning, passes, seed, seed, tuple(range(lo, min(replicates, lo + 8))))
                     for lo in range(0, replicates, 8)]
            chunks = executor.map(_replicates_task, tasks, done=(lambda i, r: [progress() for _ in r])
                                  if progress else None)
            outcomes = [o for chunk in chunks for o in chunk]
        prac = prac.with_spread(mc_spread(setup, outcomes, replicates=replicates, seed=seed,
                                          simulated=y_hat is not None))
    err = 100 * (theta - setup.theta_true) / abs(setup.theta_true)
    return {"model": num.name, "record": record.to_dict(), "method": method, "seed": seed,
            "noise_ratio": noise, "tuning": tuning.to_dict(), "passes": passes,
            "parameters": {q: {"true": float(t), "guess": float(guess[q]), "estimate": float(e), "error_percent": float(r)}
                           for q, t, e, r in zip(num.parameters, setup.theta_true, theta, err)},
            "seconds": float(sum(t.seconds for t in trs)), "repairs": int(sum(t.total_repairs for t in trs)),
            "interventions": {k: sum(t.counts()[k] for t in trs) for k in trs[0].counts()},
            "implicit_sigma_point_steps": int(sum(t.implicit.sum() for t in trs)),
            "passes_run": len(trs), "output_misfit": misfit if math.isfinite(misfit) else None,
            "practically_unidentifiable": None if prac.inconclusive else list(prac.flagged),
            "practical_identifiability": prac.to_dict()}


_STUDIES: dict[str, tuple[Setup, Any]] = {}


def _replicates_task(task: tuple) -> list[tuple]:
    """Monte-Carlo replicates of :func:`simulation_study` from the experiment's specification."""
    import hashlib
    import pickle

    from obsnl.estimation.codegen import to_casadi
    from obsnl.model.core import Model

    spec, theta, tuning, passes, seed, mc_seed, indices = task
    key = hashlib.sha256(pickle.dumps(spec)).hexdigest()
    if key not in _STUDIES:
        source, table_json, record, guess, noise, jit, method = spec
        table = None if table_json is None else BranchTable.from_dict(json.loads(table_json))
        num = to_casadi(Model.from_dict(source), switching=table.switching if table else None)
        truth = {q: num.values.get(q) for q in num.parameters}
        setup = Setup(model=num, record=record, truth=truth, guess=guess, noise=noise, jit=jit,
                      coordinates=coordinates(num, "log", reference=guess))
        _STUDIES.clear()
        _STUDIES[key] = (setup, make_filter(setup, method, table=table))
    setup, filt = _STUDIES[key]
    data = make_data(setup, seed)
    y_hat = mc_truth(setup, np.asarray(theta), data)
    return [] if y_hat is None else mc_replicates(setup, filt, data, y_hat, tuning, passes=passes, seed=mc_seed,
                                                  indices=indices)
