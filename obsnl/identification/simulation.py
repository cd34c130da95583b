"""A simulation study: identification on records simulated from the model's own values."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from numbers import Real
from typing import Any

import numpy as np

from obsnl._text import quote
from obsnl.errors import OptionError
from obsnl.estimation.accelerogram import Record
from obsnl.estimation.codegen import NumericModel
from obsnl.executor import Executor
from obsnl.identification.experiments import Tuning, make_data
from obsnl.identification.results import Identification
from obsnl.identification.runs import (
    FIT_SUBSTEPS,
    MEASURED_GRID,
    assemble_identification,
    protocol_assumptions,
    tune_and_run,
)
from obsnl.identification.setup import Setup, coordinates
from obsnl.identification.summaries import NoiseLevel, RecordSummary
from obsnl.observability.contract.branch_table import BranchTable

__all__ = ["simulation_study", "check_noise_ratio"]


def check_noise_ratio(noise: Any) -> float:
    """The one noise-to-signal RMS ratio of a simulation study, checked: a real number > 0, finite.

    Parameters
    ----------
    noise : Any
        What was given.

    Returns
    -------
    float

    Raises
    ------
    OptionError
        Anything else (text, a boolean, 0, a negative number, NaN, infinity, None), in one line.

    Examples
    --------
    >>> check_noise_ratio(0.02)
    0.02
    >>> check_noise_ratio(True)
    Traceback (most recent call last):
    ...
    obsnl.errors.OptionError: noise= takes one noise-to-signal ratio > 0 for every channel, got True
    """
    value = math.nan if isinstance(noise, (bool, np.bool_)) or not isinstance(noise, Real) else float(noise)
    if not (math.isfinite(value) and value > 0):
        raise OptionError(f"noise= takes one noise-to-signal ratio > 0 for every channel, got {quote(noise, 30)}")
    return value


def simulation_study(
    num: NumericModel,
    record: Record,
    *,
    guess: Mapping[str, float],
    method: str = "ukf",
    table: BranchTable | None = None,
    seed: int = 0,
    noise: float = 1e-3,
    tuning: Tuning | None = None,
    passes: int = 3,
    replicates: int = 0,
    jit: bool = False,
    progress: Callable[[], Any] | None = None,
    executor: Executor | None = None,
    hold: bool = False,
    refined: bool = True,
) -> Identification:
    """Identify ``num`` from its own simulated response to ``record`` (the truth: ``num.values``).

    Parameters
    ----------
    num : NumericModel
        The compiled model (:func:`obsnl.estimation.to_casadi`); ``num.values`` must hold every parameter.
    record : Record
        The record driving the model's inputs (one column per input).
    guess : mapping of str to float
        Initial guess of every parameter.
    method : {"ukf", "dukf"}
        The filter (the DUKF needs ``table``).
    table : BranchTable or None
        The model's branch table.
    seed : int
        Noise seed.
    noise : float
        Noise-to-signal RMS ratio of inputs and outputs.
    tuning : Tuning or None
        Filter tuning (None: chosen from ``MEASURED_GRID`` by the output misfit after one pass, as for
        measured data; no true value is used).
    passes : int
        Passes over the record.
    replicates : int
        Monte-Carlo replicates of the practical-identifiability check (0: off, else at least 3).
    jit : bool
        Compile the filter and the likelihood fit to C.
    progress : callable or None
        Called after every pass (tuning passes included) and once per Monte-Carlo replicate.
    executor : Executor or None
        Where the profile likelihoods and the Monte-Carlo replicates run (default: this process).
    hold : bool
        Hold poorly informed parameters at their guess (default off).
    refined : bool
        Refine by maximum likelihood (default on; :func:`identify_measured`).

    Returns
    -------
    Identification
        With true values and errors (per cent; absolute where the truth is 0).

    Raises
    ------
    OptionError
        A missing true value or guess, a bad option.
    """
    missing = [q for q in num.parameters if q not in guess]
    if missing:
        raise OptionError(
            f"no initial guess for {', '.join(missing)}; give guess= {missing[0]}=VALUE for each, or a "
            f"[guess] table in the model file"
        )
    given = {q: num.values.get(q) for q in num.parameters}
    truth = {q: v for q, v in given.items() if v is not None}
    if len(truth) < len(given):
        raise OptionError(f"model {num.name!r} needs [values] for every parameter (the truth of the simulation)")
    noise = check_noise_ratio(noise)
    setup = Setup(
        model=num,
        record=record,
        truth=truth,
        guess=dict(guess),
        noise=noise,
        jit=jit,
        fit_substeps=FIT_SUBSTEPS,
        coordinates=coordinates(num, "log", reference=guess),
    )
    data = make_data(setup, seed)
    grid = MEASURED_GRID if tuning is None else (tuning,)
    tuning_, scores, trs, held, prac, misfit = tune_and_run(
        setup,
        data,
        method=method,
        table=table,
        grid=grid,
        passes=passes,
        replicates=replicates,
        seed=seed,
        progress=progress,
        hold=hold,
        executor=executor,
    )
    levels = {c: NoiseLevel(noise, "given (simulated)") for c in num.inputs + num.outputs}
    return assemble_identification(
        setup,
        data,
        mode="simulation",
        method=method,
        passes=passes,
        tuning=tuning_,
        scores=scores,
        trs=trs,
        held=held,
        prac=prac,
        misfit=misfit,
        noise=levels,
        record=RecordSummary.from_dict(record.to_dict()),
        seed=seed,
        refined=refined,
        progress=progress,
        executor=executor,
        assumptions=protocol_assumptions(
            refined,
            f"simulation study: the truth is the model's [values], simulated "
            f"with {FIT_SUBSTEPS} RK4 substeps per sample (crossings of a jump located, sliding "
            f"modes followed), Gaussian noise seed {seed}",
            "errors: per cent of the truth; absolute where the truth is 0",
        ),
    )
