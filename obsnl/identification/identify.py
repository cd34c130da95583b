"""Identify a structure: the structural analysis first, then the filter (``obsnl identify``, ``obsnl.identify``).

:func:`identify` takes a model and its measured data (a CSV file, columns, or
:class:`~obsnl.estimation.measured.Measured`), refuses a parameter that the model's structure cannot
reveal (unless ``allow_unidentifiable``) and runs :func:`obsnl.identification.runs.identify_measured`.
:func:`study` does the same for a simulated experiment (the model's ``[values]`` driven by a record).
:func:`write_identification` writes ``identify.json`` and the figures into a folder.

The structural verdict is read through :func:`structurally_unidentifiable`, in one place: the joint
verdict of the analysis (``result.joint.unobservable``) where the analysis has one, else the per-branch
union (a parameter unobservable in every branch). The union is stricter than the joint verdict: a
parameter seen in each branch only within a combination (Bouc-Wen ``beta sign + gamma``) is
unobservable in every branch and yet revealed by the branches together.
"""

from __future__ import annotations

import dataclasses
import json
import math
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from numbers import Real
from pathlib import Path
from typing import Any

import numpy as np

from obsnl._progress import Progress
from obsnl.errors import CompileError, DataError, OptionError, OutputError
from obsnl.estimation.accelerogram import Record
from obsnl.estimation.codegen import to_casadi
from obsnl.estimation.intersample import intersample_kinds
from obsnl.estimation.jitcache import compiler_available
from obsnl.estimation.measured import MIN_SAMPLES, Measured, as_measured
from obsnl.estimation.numeric import NumericModel
from obsnl.estimation.records import read_record
from obsnl.executor import Executor
from obsnl.identification.experiments import Tuning
from obsnl.identification.replicates import check_passes, check_replicates
from obsnl.identification.runs import MEASURED_GRID, Identification, identify_measured
from obsnl.identification.setup import OBJECTIVES
from obsnl.identification.simulation import check_noise_ratio, simulation_study
from obsnl.identification.structural import StructuralCheck, structural_check
from obsnl.model.core import Model
from obsnl.model.files import as_model
from obsnl.observability.analyze import CheckedAnalysis, check_analysis, run_analysis
from obsnl.observability.contract.branch_table import BranchTable
from obsnl.observability.contract.table_check import check_table, compare_table, table_analysis

__all__ = [
    "identify",
    "study",
    "CheckedIdentification",
    "check_identify",
    "check_study",
    "run_identification",
    "write_identification",
    "IDENTIFY_FILES",
]

#: What :func:`write_identification` writes into its folder.
IDENTIFY_FILES = ("identify.json", "fit.png", "traces.png", "profiles.png")


def _prepare(c: CheckedIdentification) -> tuple[NumericModel, StructuralCheck]:
    """The structural analysis (its refusal of an unidentifiable parameter) and the compiled model."""
    result = run_analysis(c.analysis)
    if c.table is not None:  # a table that contradicts the model is refused first; its analysis is the structural one
        compare_table(c.table, result, c.model)
    structural = structural_check(
        result,
        c.model.name,
        tuple(s.name for s in c.model.parameters),
        table=c.table,
        method=c.method,
        allow_unidentifiable=c.allow_unidentifiable,
    )
    return to_casadi(c.model, switching=c.table.switching if c.table else None), structural


def _analysis(model: Model, table: BranchTable | None, seed: int) -> CheckedAnalysis:
    """The structural analysis, checked before any work: the one that confirms ``table`` (its method and seed; a
    table made for another model is refused here), else the default method with ``seed``."""
    return table_analysis(table, model) if table is not None else check_analysis(model, seed=seed)


def _guesses(model: Model, guess: Mapping[str, float] | None) -> dict[str, float]:
    """The filter's starting point: ``guess`` over the model's ``[guess]``, each a finite nonzero number inside the
    parameter's declared bounds."""
    names = tuple(s.name for s in model.parameters)
    g = {k: float(v) for k, v in (getattr(model, "guess", None) or {}).items() if k in names}
    unknown = sorted(set(guess or {}) - set(names))
    if unknown:  # a misspelt guess is refused, as the command line refuses --guess kk=3
        raise OptionError(
            f"guess= names {unknown[0]!r}, which is not a parameter of {model.name!r} "
            f"({', '.join(names)}); check the spelling"
        )
    g.update({k: float(v) for k, v in (guess or {}).items()})  # numbers checked at the door (_check_kinds)
    for k, v in g.items():  # the filters estimate log|p| with the guess's sign: 0, inf and NaN cannot start
        if not (math.isfinite(v) and 0 < abs(v) < 1e100):
            raise OptionError(
                f"the guess of {k} is {v!r} (guess= or the model's [guess]); give a finite nonzero "
                f"number below 1e100 in magnitude (the filter estimates log|{k}| from it)"
            )
        lo, hi = (model.bounds or {}).get(k, (-math.inf, math.inf))
        if not lo <= v <= hi:  # the fit searches inside the declared bounds: a guess outside cannot start it
            raise OptionError(
                f"the guess of {k} is {v:g}, outside its declared bounds [{lo:g}, {hi:g}] (the model's [bounds]); "
                f"give a guess inside them"
            )
    return g


def _read_table(table: BranchTable | str | Path | None) -> BranchTable | None:
    if isinstance(table, (str, Path)):
        from obsnl.observability.contract.branch_table import read_branch_table

        return read_branch_table(table)
    return table


def _at_the_door(passes: int, replicates: int, guess: Any, noise: Any, **kinds: Any) -> None:
    """What :func:`check_identify` and :func:`check_study` check first, in this order: the counts, then every
    argument's kind (:func:`_check_kinds`)."""
    check_passes(passes)
    check_replicates(replicates)
    _check_kinds(guess, noise, **kinds)


def _probed(checked: CheckedIdentification) -> CheckedIdentification:
    """``checked``, its executor's scheduler probed: one that cannot run the work is refused now, not after the
    filter (:meth:`obsnl.executor.Executor.probe`)."""
    if checked.executor is not None:
        checked.executor.probe()
    return checked


def _check_kinds(
    guess: Any,
    noise: Any,
    *,
    table: Any = None,
    tuning: Any = None,
    executor: Any = None,
    jit: Any = None,
    seed: Any = 0,
    progress: Any = None,
    known_initial: Any = None,
    objective: Any = "output",
    **flags: Any,
) -> None:
    """Refuse an argument of the wrong kind that Python would read silently (``refine="no"`` is true, ``jit="no"``
    compiles, a guess of ``None`` fails deep inside, ``table=5`` an attribute error): each with one line naming it
    and the kind it takes, as the command line refuses a bad option."""
    for name, v in flags.items():
        if not isinstance(v, (bool, np.bool_)):
            raise OptionError(f"{name}= takes True or False, got {v!r}")
    if jit is not None and not isinstance(jit, (bool, np.bool_)):
        raise OptionError(f"jit= takes True, False or None (compiled where a C compiler is on PATH), got {jit!r}")
    if table is not None and not isinstance(table, (BranchTable, str, Path)):
        raise OptionError(f"table= takes a BranchTable or the path of a branch-table file, got {table!r}")
    if tuning is not None and not isinstance(tuning, Tuning):
        raise OptionError(
            f"tuning= takes one Tuning, e.g. tuning=Tuning(s0=0.3, q_theta=0.0, q_x=1.0), or None "
            f"(tuned over a grid); got {tuning!r}"
        )
    if executor is not None and not isinstance(executor, Executor):
        raise OptionError(
            f"executor= takes an obsnl.executor.Executor, e.g. Executor(workers=2), or None (this "
            f"process); got {executor!r}"
        )
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise OptionError(f"seed= takes an integer >= 0, got {seed!r}")
    if progress is not None and not isinstance(progress, (bool, np.bool_)) and not callable(progress):
        raise OptionError(f"progress= takes True, False or a callable called after each step, got {progress!r}")
    if guess is not None and not isinstance(guess, Mapping):
        raise OptionError(f"guess= takes {{parameter: value}}, e.g. guess={{'k': 30.0}}; got {guess!r}")
    bad = next(
        (k for k, v in (guess or {}).items() if isinstance(v, (bool, np.bool_)) or not isinstance(v, Real)), None
    )
    if bad is not None:
        raise OptionError(f"guess= gives {bad} = {dict(guess or {})[bad]!r}; give a number")
    if noise is not None and not isinstance(noise, Mapping):
        raise OptionError(f"noise= takes {{channel: ratio}}, e.g. noise={{'disp': 0.01}}; got {noise!r}")
    if known_initial is not None and not isinstance(known_initial, Mapping):
        raise OptionError(
            f"known_initial= takes {{state: value}}, e.g. known_initial={{'x': 0.01, 'v': 0.0}}; got {known_initial!r}"
        )
    for k, v in (known_initial or {}).items():
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, Real) or not math.isfinite(v):
            raise OptionError(f"known_initial= gives {k} = {v!r}; give a finite number")
    if not isinstance(objective, str) or objective not in OBJECTIVES:
        raise OptionError(
            f"objective= takes one of {', '.join(repr(o) for o in OBJECTIVES)} (what the likelihood fit "
            f"minimises), got {objective!r}"
        )


def _known_initial(model: Model, given: Mapping[str, float] | None) -> tuple[Model, dict[str, float]]:
    """The model with the states of ``given`` declared known (so the structural analysis counts them known too),
    and the value of every known initial state: ``given`` over the model's ``initial_condition_values``."""
    states = [s.name for s in model.states]
    wrong = [k for k in (given or {}) if k not in states]
    if wrong:
        raise OptionError(
            f"known_initial= names {wrong[0]!r}, which is not a state of {model.name!r} "
            f"({', '.join(states)}); check the spelling"
        )
    if given:
        names = [s.name for s in model.known_initial_conditions]
        values = {s.name: v for s, v in model.initial_condition_values.items()}
        model = model.replace(
            known_initial_conditions=names + [k for k in given if k not in names],
            initial_condition_values={**values, **{k: float(v) for k, v in given.items()}},
        )
    constants = {sym: model.values[sym.name] for sym in model.known_constants if sym.name in model.values}
    known = {}
    for sym in model.known_initial_conditions:
        expr = model.initial_condition_values.get(sym)
        try:
            value = float(expr.subs(constants)) if expr is not None else math.nan
        except TypeError:  # a symbol without a value
            value = math.nan
        if not math.isfinite(value):
            raise OptionError(
                f"the initial state {sym.name} of {model.name!r} is declared known but has no numeric "
                f"value: give initial_condition_values {sym.name} = VALUE in the model, or "
                f"known_initial={{'{sym.name}': VALUE}}"
            )
        known[sym.name] = value
    return model, known


def identify(
    model: Model | str | Path,
    data: Measured | Mapping[str, Any] | str | Path,
    *,
    guess: Mapping[str, float] | None = None,
    noise: Mapping[str, float] | None = None,
    method: str = "ukf",
    table: BranchTable | str | Path | None = None,
    passes: int = 3,
    replicates: int = 0,
    seed: int = 0,
    tuning: Tuning | None = None,
    allow_unidentifiable: bool = False,
    jit: bool | None = None,
    hold: bool = False,
    progress: bool | Callable[[], Any] | None = True,
    executor: Executor | None = None,
    refine: bool = True,
    intersample: str | Mapping[str, str] | Sequence[str] | None = None,
    known_initial: Mapping[str, float] | None = None,
    objective: str = "output",
) -> Identification:
    """Identify a structure's parameters from its measured inputs and outputs.

    Parameters
    ----------
    model : Model or str or Path
        A :class:`~obsnl.Model` or a model file.
    data : Measured or mapping of str to Any or pandas.DataFrame or str or Path
        A CSV file (time column ``time_s`` or ``t``, one column per model input and output, named as
        in the model), ``{column: samples}``, a DataFrame (its time a column or its index:
        :func:`~obsnl.estimation.measured.frame_columns`), or :class:`~obsnl.estimation.measured.Measured`.
    guess : mapping of str to float or None
        Initial guesses (default: the model file's ``[guess]`` table; these override it).
    noise : mapping of str to float or None
        Noise-to-signal RMS ratio per channel; channels not named are estimated from the data.
    method : {"ukf", "dukf"}
        The filter (the DUKF needs ``table``).
    table : BranchTable or str or Path or None
        The model's branch table, a file or a value.
    passes, replicates, seed : int
        Passes over the record; Monte-Carlo replicates (0: off) and their seed (also the analysis seed).
    tuning : Tuning or None
        One filter configuration; default: tuned over ``MEASURED_GRID`` by the output misfit.
    allow_unidentifiable : bool
        Run although the structural analysis calls a parameter unidentifiable.
    jit : bool or None
        Compile the filter and the likelihood fit to C (cached on disk: the first run of a model compiles; the
        same numbers to rounding). None (default): compiled when a C compiler is on PATH, else, or when compiling
        fails, not (with a warning on standard error); ``result.compiled`` says which.
    hold : bool
        Hold poorly informed parameters at their guess once the filter reaches the noise floor
        (:func:`obsnl.identification.runs.identify_measured`; default off).
    progress : bool or callable or None
        True (default): a progress bar on standard error over the filter passes (tuning included), the
        refinement, the profiles and the replicates; False: none; a callable: called after each of those steps.
    executor : Executor or None
        Where the profile likelihoods and the Monte-Carlo replicates run (:class:`obsnl.executor.Executor`:
        local processes or a Dask cluster; default: this process, one after the other). The same numbers on
        any executor; on a 2-core machine ``Executor(workers=2)`` about halves the profiles' time.
    refine : bool
        Refine the filter's estimate by maximum likelihood (the default last step): Fisher std, 95 %
        profile-likelihood intervals, flags from the intervals, ``converged`` from the optimizer's
        first-order conditions (:mod:`obsnl.identification.likelihood`). ``False``: the filter alone.
    intersample : str or mapping or sequence of str or None
        How the inputs behave between samples (:func:`obsnl.estimation.intersample.intersample_kinds`: a kind for
        every input, ``{input: kind}`` or ``"NAME=KIND"`` strings; kinds ``zoh``, ``linear``, ``bandlimited``).
        Default: the model's ``[intersample]`` table, else linear; what is given here overrides it per input.
    known_initial : mapping of str to float or None
        Initial states known, ``{state: value}`` (a free decay from a measured displacement), over the model's
        ``known_initial_conditions`` with ``initial_condition_values``: the structural analysis counts them known,
        the filter starts from them, the fit holds them. The other initial states are estimated.
    objective : {"output", "prediction"}
        What the maximum-likelihood fit minimises. ``"output"`` (default): the output error of the model simulated
        from its fitted initial state, the likelihood when measurement noise is the only disturbance.
        ``"prediction"``: the prediction error of a constant-gain predictor whose gain is fitted with the
        parameters (the innovations form), for a plant that drifts under unmeasured disturbances or runs in closed
        loop; its residuals are the innovations, and adequacy judges their whiteness, not their level.

    Returns
    -------
    Identification

    Raises
    ------
    AnalysisError
        A structurally unidentifiable parameter (named), unless ``allow_unidentifiable``.
    DataError, OptionError, TableError
        Bad data, options, or a branch table made for another model.

    Examples
    --------
    >>> import obsnl
    >>> m = obsnl.Model(name="drift", states=["x"], parameters=["a", "b"], inputs=["u"],
    ...                 equations={"x": "(a + b)*u"}, outputs={"y": "x"})
    >>> obsnl.identify(m, {"t": [0, 1, 2], "u": [1, 1, 1], "y": [0, 1, 2]}, guess={"a": 1, "b": 1})
    Traceback (most recent call last):
    ...
    obsnl.errors.AnalysisError: a, b of 'drift' are structurally unidentifiable from its outputs (the joint verdict); write identifiable combinations with `obsnl reparametrize MODEL -o NEW.toml` and identify NEW.toml, or pass allow_unidentifiable=True
    """
    return run_identification(
        _probed(
            check_identify(
                model,
                data,
                guess=guess,
                noise=noise,
                method=method,
                table=table,
                passes=passes,
                replicates=replicates,
                seed=seed,
                tuning=tuning,
                allow_unidentifiable=allow_unidentifiable,
                jit=jit,
                hold=hold,
                progress=progress,
                executor=executor,
                refine=refine,
                intersample=intersample,
                known_initial=known_initial,
                objective=objective,
            )
        )
    )


@dataclass(frozen=True, kw_only=True)
class CheckedIdentification:
    """An identification checked and resolved once, by :func:`check_identify` (measured data) or :func:`check_study`
    (a simulation study); :func:`run_identification` runs it without checking again. ``obsnl identify`` makes one when
    its request is made (:class:`obsnl.commands.identify.IdentifyRequest`).

    Attributes
    ----------
    model : Model
        The model, read from its file where a file was given, with the known initial states declared known.
    known_initial : mapping of str to float
        The value of every known initial state (the model's, and ``known_initial=``).
    data : Measured or None
        The measured data (None in a simulation study).
    record : Record or None
        The study's record, cut to its first ``samples`` (None for measured data).
    inputs : numpy.ndarray
        The inputs as sampled, ``(T, inputs)``: kept on the result for the residual analysis and the frequency
        response.
    intersample : mapping of str to str
        How each input runs between samples, ``{input: kind}`` (measured data; empty in a study, which simulates its
        record linearly between samples).
    guess : mapping of str to float
        The filter's starting point: the guesses given over the model's ``[guess]``, each checked.
    noise : mapping of str to float, or float, or None
        Noise-to-signal ratios per channel (measured data; channels not named are estimated), or the study's one ratio.
    table : BranchTable or None
        The branch table, read from its file where a file was given.
    analysis : CheckedAnalysis
        The structural analysis, checked: the one that confirms ``table`` (its method and seed) where one is given.
    method, passes, replicates, seed, tuning, allow_unidentifiable, jit, hold, progress, executor, refine, objective
        As :func:`identify` takes them, checked.
    """

    model: Model
    known_initial: Mapping[str, float]
    data: Measured | None
    record: Record | None
    inputs: np.ndarray = field(repr=False)
    intersample: Mapping[str, str]
    guess: Mapping[str, float]
    noise: Mapping[str, float] | float | None
    table: BranchTable | None
    analysis: CheckedAnalysis
    method: str
    passes: int
    replicates: int
    seed: int
    tuning: Tuning | None
    allow_unidentifiable: bool
    jit: bool | None
    hold: bool
    progress: bool | Callable[[], Any] | None
    executor: Executor | None
    refine: bool
    objective: str


def check_identify(
    model: Model | str | Path,
    data: Measured | Mapping[str, Any] | str | Path,
    *,
    guess: Mapping[str, float] | None = None,
    noise: Mapping[str, float] | None = None,
    method: str = "ukf",
    table: BranchTable | str | Path | None = None,
    passes: int = 3,
    replicates: int = 0,
    seed: int = 0,
    tuning: Tuning | None = None,
    allow_unidentifiable: bool = False,
    jit: bool | None = None,
    hold: bool = False,
    progress: bool | Callable[[], Any] | None = True,
    executor: Executor | None = None,
    refine: bool = True,
    intersample: str | Mapping[str, str] | Sequence[str] | None = None,
    known_initial: Mapping[str, float] | None = None,
    objective: str = "output",
) -> CheckedIdentification:
    """Check and resolve what :func:`identify` takes, before any work: the counts and every argument's kind, the
    model and the data read, the inputs between samples, the known initial states, the branch table read, the
    guesses, the structural analysis's options and the model's size
    (:func:`~obsnl.observability.analyze.check_analysis`; a table made for another model is refused here). The
    executor's scheduler is not asked here: :func:`identify` probes it next, and ``obsnl identify`` before it reads
    the model.

    Parameters
    ----------
    model : Model, str or Path
        The model or its file.
    data : Measured, mapping of str to Any, pandas.DataFrame, str or Path
        The measured data, as :func:`identify` reads them.
    guess, noise : mapping of str to float or None
        Guesses over the model's ``[guess]``; noise-to-signal ratios per channel.
    method : {"ukf", "dukf"}
        The filter.
    table : BranchTable, str, Path or None
        The branch table or its file.
    passes, replicates, seed : int
        Passes over the record, Monte-Carlo replicates, the seed.
    tuning : Tuning or None
        One filter configuration, or None to tune over a grid.
    allow_unidentifiable, hold, refine : bool
        As for :func:`identify`.
    jit : bool or None
        Compile to C (None: where a C compiler is found).
    progress : bool, callable or None
        The progress bar.
    executor : Executor or None
        Where the profiles and the replicates run.
    intersample : str, mapping of str to str, sequence of str or None
        How the inputs run between samples.
    known_initial : mapping of str to float or None
        Initial states known.
    objective : {"output", "prediction"}
        What the maximum-likelihood fit minimises.

    Returns
    -------
    CheckedIdentification

    Raises
    ------
    DataError, OptionError, TableError, ParseError
        As :func:`identify` raises them before any work.

    Examples
    --------
    >>> import obsnl
    >>> m = obsnl.Model(name="leak", states=["x"], parameters=["a"], inputs=["u"],
    ...                 equations={"x": "u - a*x"}, outputs={"y": "x"})
    >>> checked = check_identify(m, {"t": [0, 1, 2], "u": [1, 1, 1], "y": [0, 1, 2]}, guess={"a": 2})
    >>> checked.guess, checked.intersample, checked.inputs.shape
    ({'a': 2.0}, {'u': 'linear'}, (3, 1))
    """
    _at_the_door(
        passes,
        replicates,
        guess,
        noise,
        table=table,
        tuning=tuning,
        executor=executor,
        jit=jit,
        seed=seed,
        progress=progress,
        known_initial=known_initial,
        objective=objective,
        refine=refine,
        hold=hold,
        allow_unidentifiable=allow_unidentifiable,
    )
    model = as_model(model)
    ins, outs = [s.name for s in model.inputs], list(model.outputs)
    read = as_measured(data, inputs=ins, outputs=outs)
    kinds = intersample_kinds(intersample, ins, table=model.intersample)
    model, known = _known_initial(model, known_initial)
    table = _read_table(table)
    return CheckedIdentification(
        model=model,
        known_initial=known,
        data=read,
        record=None,
        inputs=read.u,
        intersample=kinds,
        guess=_guesses(model, guess),
        noise=noise,
        table=table,
        analysis=_analysis(model, table, seed),
        method=method,
        passes=passes,
        replicates=replicates,
        seed=seed,
        tuning=tuning,
        allow_unidentifiable=allow_unidentifiable,
        jit=jit,
        hold=hold,
        progress=progress,
        executor=executor,
        refine=refine,
        objective=objective,
    )


def run_identification(checked: CheckedIdentification) -> Identification:
    """Run a checked identification (:func:`check_identify`, :func:`check_study`): the structural analysis and its
    refusal, the filter, the maximum-likelihood refinement, the replicates; nothing is checked again.

    Parameters
    ----------
    checked : CheckedIdentification

    Returns
    -------
    Identification
        As :func:`identify` and :func:`study` return it.
    """
    if not isinstance(checked, CheckedIdentification):  # an AttributeError below otherwise
        raise OptionError(
            f"run_identification takes the CheckedIdentification that check_identify or check_study returns, got "
            f"{type(checked).__name__}; or call obsnl.identify with the model and the data"
        )
    c = checked
    model = c.model
    num, structural = _prepare(c)

    def run(compiled: bool) -> Identification:
        with _steps(c.progress, model, c.passes, c.replicates, c.tuning, c.refine) as bar:
            if c.record is not None:  # a simulation study: one noise level for every channel
                assert isinstance(c.noise, float)  # check_study keeps one ratio
                return simulation_study(
                    num,
                    c.record,
                    guess=dict(c.guess),
                    method=c.method,
                    table=c.table,
                    seed=c.seed,
                    noise=c.noise,
                    tuning=c.tuning,
                    passes=c.passes,
                    replicates=c.replicates,
                    jit=compiled,
                    progress=bar,
                    executor=c.executor,
                    hold=c.hold,
                    refined=c.refine,
                )
            assert c.data is not None  # check_identify resolves one or the other
            return identify_measured(
                num,
                c.data,
                guess=dict(c.guess),
                method=c.method,
                table=c.table,
                noise=c.noise if isinstance(c.noise, Mapping) else None,
                grid=MEASURED_GRID if c.tuning is None else (c.tuning,),
                passes=c.passes,
                replicates=c.replicates,
                seed=c.seed,
                jit=compiled,
                hold=c.hold,
                progress=bar,
                executor=c.executor,
                refined=c.refine,
                intersample=dict(c.intersample),
                known_initial=dict(c.known_initial),
                objective=c.objective,
                bounds={k: v for k, v in (model.bounds or {}).items() if k in c.guess},
            )

    return dataclasses.replace(
        _cross_check(_compiled_or_not(c.jit, run), structural),
        fitted_model=model,
        u_measured=c.inputs,
        inputs=tuple(s.name for s in model.inputs),
    )


def _compiled_or_not(jit: bool | None, run: Callable[[bool], Identification]) -> Identification:
    """``run(jit)`` as asked; for ``jit=None``, compiled where a C compiler is on PATH, and uncompiled (with a
    warning on standard error) where compiling fails or the library cache is unsafe: the same numbers either
    way, only the time differs."""
    if jit is None and compiler_available():
        try:
            return dataclasses.replace(run(True), compiled=True)
        except (CompileError, OutputError) as exc:  # OutputError: only the cache folder is written during a run
            sys.stderr.write(f"obsnl: warning: {exc}; running uncompiled instead (the same numbers, slower)\n")
        return dataclasses.replace(run(False), compiled=False)
    return dataclasses.replace(run(bool(jit)), compiled=bool(jit))


def _steps(
    progress: bool | Callable[[], Any] | None,
    model: Model,
    passes: int,
    replicates: int,
    tuning: Tuning | None,
    refine: bool,
) -> Progress:
    """The progress of one identification: its filter passes (the tuning grid's included), the refinement and
    one profile per parameter, then the Monte-Carlo replicates."""
    total = (
        passes
        + (len(MEASURED_GRID) if tuning is None else 0)
        + max(replicates, 0)
        + (1 + len(model.parameters) if refine else 0)
    )
    return Progress(progress, total, "identify", "step")


def _cross_check(res: Identification, structural: StructuralCheck) -> Identification:
    """The structural note, and each flat profile held against the structural verdict."""
    bad = set(structural.unidentifiable)
    params = []
    for p in res.parameters:
        flat = p.interval_method is not None and p.interval_method.endswith("flat")
        if flat:
            said = (
                "as the structural analysis says"
                if p.name in bad
                else "although the structural analysis calls it identifiable: this record does not excite what "
                "reveals it"
            )
            p = dataclasses.replace(p, reason=f"{p.reason}; {said}")
        params.append(p)
    return dataclasses.replace(
        res, parameters=tuple(params), structural=structural, assumptions=res.assumptions + (structural.note(),)
    )


def study(
    model: Model | str | Path,
    record: Record | str | Path,
    *,
    guess: Mapping[str, float] | None = None,
    noise: float = 1e-3,
    method: str = "ukf",
    table: BranchTable | str | Path | None = None,
    passes: int = 3,
    replicates: int = 0,
    seed: int = 0,
    tuning: Tuning | None = None,
    samples: int | None = None,
    allow_unidentifiable: bool = False,
    jit: bool | None = None,
    hold: bool = False,
    progress: bool | Callable[[], Any] | None = True,
    executor: Executor | None = None,
    refine: bool = True,
) -> Identification:
    """A simulation study: the model's ``[values]`` driven by ``record``, noise added, identified.

    Same structural check as :func:`identify`; see
    :func:`obsnl.identification.simulation.simulation_study` for the rest.

    Parameters
    ----------
    model : Model, str or Path
        The model or its file.
    record : Record, str or Path
        The input record or its file.
    guess : mapping of str to float or None
        Initial guesses (over the model's ``[guess]``).
    noise : float
        Noise-to-signal RMS ratio.
    method : str
        ``"ukf"`` or ``"dukf"``.
    table : BranchTable, str, Path or None
        Branch table (DUKF).
    passes, replicates, seed : int
        Filter passes, Monte Carlo replicates (0: none) and seed.
    tuning : Tuning or None
        Filter configuration (None: tuned by the output misfit, as for measured data).
    samples : int or None
        Use only the first samples of the record.
    allow_unidentifiable : bool
        Go on with structurally unidentifiable parameters.
    jit : bool or None
        Compile the filter and the likelihood fit to C (None, the default: where a C compiler is on PATH; see
        :func:`identify`).
    progress : bool, callable or None
        A progress bar on standard error (True, the default), none (False), or a callback per step.
    executor : Executor or None
        Where the profile likelihoods and the Monte-Carlo replicates run (default: this process).
    hold : bool
        Hold poorly informed parameters at their guess (default: off, nothing is held).
    refine : bool
        Refine by maximum likelihood (default on; see :func:`identify`).

    Returns
    -------
    Identification

    Raises
    ------
    OptionError
        When the model has not exactly one input.
    DataError
        When ``samples`` is below 2 (0 is not read as "the whole record").
    AnalysisError
        When parameters are structurally unidentifiable and not allowed.

    Examples
    --------
    >>> callable(study)
    True
    """
    return run_identification(
        _probed(
            check_study(
                model,
                record,
                guess=guess,
                noise=noise,
                method=method,
                table=table,
                passes=passes,
                replicates=replicates,
                seed=seed,
                tuning=tuning,
                samples=samples,
                allow_unidentifiable=allow_unidentifiable,
                jit=jit,
                hold=hold,
                progress=progress,
                executor=executor,
                refine=refine,
            )
        )
    )


def check_study(
    model: Model | str | Path,
    record: Record | str | Path,
    *,
    guess: Mapping[str, float] | None = None,
    noise: float = 1e-3,
    method: str = "ukf",
    table: BranchTable | str | Path | None = None,
    passes: int = 3,
    replicates: int = 0,
    seed: int = 0,
    tuning: Tuning | None = None,
    samples: int | None = None,
    allow_unidentifiable: bool = False,
    jit: bool | None = None,
    hold: bool = False,
    progress: bool | Callable[[], Any] | None = True,
    executor: Executor | None = None,
    refine: bool = True,
) -> CheckedIdentification:
    """Check and resolve what :func:`study` takes, before any work: as :func:`check_identify`, with the record read
    and cut to ``samples``, the noise ratio, and the model's one input.

    Parameters
    ----------
    model : Model, str or Path
        The model or its file (with the ``[values]`` simulated).
    record : Record, str or Path
        The input record or its file.
    guess : mapping of str to float or None
        Guesses over the model's ``[guess]``.
    noise : float
        The noise-to-signal RMS ratio of every channel (> 0).
    method : {"ukf", "dukf"}
        The filter.
    table : BranchTable, str, Path or None
        The branch table or its file.
    passes, replicates, seed : int
        Passes over the record, Monte-Carlo replicates, the seed.
    tuning : Tuning or None
        One filter configuration, or None to tune over a grid.
    samples : int or None
        Use only the first samples of the record.
    allow_unidentifiable, hold, refine : bool
        As for :func:`study`.
    jit : bool or None
        Compile to C (None: where a C compiler is found).
    progress : bool, callable or None
        The progress bar.
    executor : Executor or None
        Where the profiles and the replicates run.

    Returns
    -------
    CheckedIdentification

    Raises
    ------
    DataError, OptionError, TableError, ParseError
        As :func:`study` raises them before any work (a branch table that contradicts a model of several inputs is
        named before the inputs are: its check analyses the model).

    Examples
    --------
    >>> import obsnl
    >>> from obsnl.estimation.accelerogram import Record
    >>> m = obsnl.Model(name="leak", states=["x"], parameters=["a"], inputs=["u"],
    ...                 equations={"x": "u - a*x"}, outputs={"y": "x"}, values={"a": 1.0}, guess={"a": 2.0})
    >>> check_study(m, Record("r", [0.0] * 60, 0.01), noise="high")
    Traceback (most recent call last):
    ...
    obsnl.errors.OptionError: noise= takes one noise-to-signal ratio > 0 for every channel, got 'high'
    """
    _at_the_door(
        passes,
        replicates,
        guess,
        None,
        table=table,
        tuning=tuning,
        executor=executor,
        jit=jit,
        seed=seed,
        progress=progress,
        refine=refine,
        hold=hold,
        allow_unidentifiable=allow_unidentifiable,
    )
    noise = check_noise_ratio(noise)  # before any work (simulation_study checks it too, for a direct caller)
    model = as_model(model)
    record = read_record(record) if isinstance(record, (str, Path)) else record
    if samples is not None:  # 0 is refused by head, never read as "all of them"
        record = record.head(samples)
    if len(record.accel) < MIN_SAMPLES:  # the same floor as measured data: a 5-sample study only says nonsense
        raise DataError(
            f"a simulation study needs at least {MIN_SAMPLES} samples of the record, got "
            f"{len(record.accel)}: give a longer record or a larger samples="
        )
    table = _read_table(table)
    if table is not None and len(model.inputs) != 1:  # a contradicting table is named first
        check_table(table, model)
    if len(model.inputs) != 1:
        raise OptionError(
            f"a simulation study drives one input with record=; {model.name!r} has "
            f"{[s.name for s in model.inputs]}: give measured data with data="
        )
    return CheckedIdentification(
        model=model,
        known_initial={},
        data=None,
        record=record,
        inputs=np.asarray(record.accel, float).reshape(len(record.accel), -1),
        intersample={},
        guess=_guesses(model, guess),
        noise=noise,
        table=table,
        analysis=_analysis(model, table, seed),
        method=method,
        passes=passes,
        replicates=replicates,
        seed=seed,
        tuning=tuning,
        allow_unidentifiable=allow_unidentifiable,
        jit=jit,
        hold=hold,
        progress=progress,
        executor=executor,
        refine=refine,
        objective="output",
    )


def write_identification(result: Identification, out: str | Path, *, force: bool = False) -> list[Path]:
    """Write ``identify.json``, ``fit.png`` (measured vs simulated per output over the whole record, a zoomed
    window and the residual), ``traces.png`` (parameter traces over the passes with +-2 sigma bands),
    ``profiles.png`` (the profile likelihood of each parameter; an empty sheet after ``refine=False``) and the
    engineer's figures (:mod:`obsnl.identification.engineering`: ``residuals.png``; ``frf.png`` for a model that
    linearises at rest; ``hysteresis.png`` for a model with a hysteretic state) into the folder ``out``, all of
    them or none.

    Parameters
    ----------
    result : Identification
        The result.
    out : str or Path
        The folder.
    force : bool
        Replace existing files (a link is replaced, never followed).

    Returns
    -------
    list of Path

    Raises
    ------
    OutputError
        ``out`` is a file or a link, cannot be written, or one of the files exists (or is a link) and
        ``force`` is not set (:class:`obsnl.report.files.OutputFolder`).
    DataError
        ``result`` carries no record (``t``, ``y_measured``, ``y_fit``) to draw.

    Examples
    --------
    >>> IDENTIFY_FILES[0]
    'identify.json'
    """
    from obsnl.identification.engineering import figure_files, write_figures
    from obsnl.identification.profile import THRESHOLD
    from obsnl.report.figures import plot_profiles, plot_traces
    from obsnl.report.files import OutputFolder
    from obsnl.report.identification.diagnostics import plot_fit_record

    t, measured, simulated = result.t, result.y_measured, result.y_fit
    if t is None or measured is None or simulated is None:
        raise DataError(
            "write_identification: the result carries no record (t, y_measured, y_fit) to draw; pass "
            "the one obsnl.identify returned"
        )
    truth = {p.name: p.true for p in result.parameters if p.true is not None}
    extra = figure_files(result)
    with OutputFolder(out, IDENTIFY_FILES + extra, force=force) as folder:  # no link followed, all files or none
        folder.write_text("identify.json", json.dumps(result.to_dict(), indent=1, allow_nan=False) + "\n")
        units = getattr(result.fitted_model, "metadata", {}).get("units")  # a model file's units table, if any
        plot_fit_record(
            folder.path("fit.png"),
            t=t,
            measured=measured,
            simulated=simulated,
            outputs=result.outputs,
            fit=result.fit,
            units=units if isinstance(units, dict) else None,
        )
        write_figures(result, folder, extra)
        plot_traces(
            folder.path("traces.png"), traces=result.traces, truth=truth, held=result.held, flagged=result.flagged
        )
        plot_profiles(folder.path("profiles.png"), profiles=result.profiles, threshold=THRESHOLD, truth=truth)
        return folder.commit()
