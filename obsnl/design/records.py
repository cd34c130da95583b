"""A model file and records as one experiment: what the ``analyze``, ``sensors`` and ``design`` commands
run, from paths to a result.

Each function reads the model file with its size checked before any expression is parsed
(:func:`obsnl.observability.limits.check_file_limits`), refuses an analysis too large for the engines
before any heavy work, reads each record as the model's one known input, and runs the whole job under one
time budget (:func:`obsnl.model.bounds.budget.time_budget`) when a limit is given. A record simulated
with the model's ``[values]`` tells which branches and switching surfaces the experiment visits: what it
can reveal.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from obsnl._text import quote
from obsnl.errors import OptionError
from obsnl.model.bounds.budget import check_seconds, time_budget
from obsnl.model.core import Model
from obsnl.model.files import as_model
from obsnl.observability.analyze import analyze
from obsnl.observability.limits import check_analysis_limits, check_file_limits, out_of_memory
from obsnl.observability.results import AnalysisResult

if TYPE_CHECKING:  # the record readers and the simulation load when a record is given
    from obsnl.design.experiment import ExperimentDesign
    from obsnl.design.sensor_search import SensorSearch
    from obsnl.estimation.accelerogram import Record
    from obsnl.executor import Executor
    from obsnl.observability.joint.visited import Visits

__all__ = ["one_input_record", "record_visits", "analyze_file", "sensors_file", "design_file"]


def _model(model: Model | str | Path) -> Model:
    """``model``, or the model file at that path read with its size checked first."""
    return as_model(model, check=check_file_limits)


def _check_output(output: str | Path | None, force: bool) -> None:
    """Refuse, before any work, a file the caller is to write the rendering to that cannot be written
    (None or ``"-"``: standard output)."""
    if output is not None and not str(output).strip():  # else the work runs, then "." is refused as a folder
        raise OptionError("the output file name is empty; name a file, or - for standard output")
    if output and output != "-":
        from obsnl.report.files import check_target

        check_target(output, force=force)


#: How the file jobs name their record option in messages: as the Python keyword, which the command line prints as
#: its flag (``--record``).
_RECORD = "record="


def one_input_record(model: Model, path: str | Path, *, option: str = "a record") -> Record:
    """The record at ``path`` as the one known input of ``model``.

    Parameters
    ----------
    model : Model
        A model with exactly one input.
    path : str or Path
        A record file (.csv or PEER .AT2).
    option : str
        How the caller names the record in messages (``"--record"`` on the command line).

    Returns
    -------
    Record
        The record read.

    Raises
    ------
    OptionError
        When the model has no input or more than one.
    """
    from obsnl.estimation.records import read_record

    if len(model.inputs) != 1:
        raise OptionError(
            f"{option} drives one input, model {model.name!r} has {len(model.inputs)}; give a model "
            "with one known input"
        )
    return read_record(path)


def record_visits(model: Model, record: Record) -> Visits:
    """The sign patterns and crossings a simulation of the model's ``[values]`` under ``record`` visits along its
    continuous trajectory (:func:`obsnl.design.continuous.continuous_visits`: crossings located between samples, a
    state resting on a switching surface on no branch, the input between samples as the model's ``[intersample]``
    table says, from the known initial state).

    Parameters
    ----------
    model : Model
        A model with one input and numbers for its parameters in ``[values]``.
    record : Record
        The record driving that input.

    Returns
    -------
    Visits
        The visited patterns and the crossings of each switching function.
    """
    from obsnl.design.continuous import continuous_visits

    t = record.dt * np.arange(len(record.accel))
    return continuous_visits(model, t, {model.inputs[0].name: record.accel})


def analyze_file(
    model: Model | str | Path,
    *,
    record: str | Path | None = None,
    method: str = "auto",
    seed: int | None = None,
    max_seconds: float | None = None,
    branches: Sequence[str] | None = None,
    joint: bool = True,
    unknown_input_derivatives: int | str | None = None,
    output: str | Path | None = None,
    force: bool = False,
) -> AnalysisResult:
    """Analyse a model file, optionally only what one record visits, all within one time budget.

    Parameters
    ----------
    model : Model, str or Path
        The model or its file (read with its size checked first).
    record : str, Path or None
        A record driving the model's one input: the analysis covers the branches and crossings a
        simulation of the model's ``[values]`` under it visits.
    method : str
        As for :func:`obsnl.analyze`.
    seed : int or None
        As for :func:`obsnl.analyze`.
    branches : sequence of str or None
        As for :func:`obsnl.analyze`.
    joint : bool
        As for :func:`obsnl.analyze`.
    unknown_input_derivatives : int or str or None
        As for :func:`obsnl.analyze`.
    max_seconds : float or None
        Time limit of the whole job: reading and factoring the model, the record's simulation, the
        split into branches and the analysis.
    output : str, Path or None
        The file the caller will write the rendering to: refused before any work when it cannot be
        written (None or ``"-"``: standard output).
    force : bool
        Whether ``output`` may be overwritten.

    Returns
    -------
    AnalysisResult
        The analysis.

    Raises
    ------
    AnalysisError
        A model too large for the engines (before any work) or out of memory.
    """
    _check_output(output, force)
    with time_budget(max_seconds):
        model = _model(model)
        k = check_analysis_limits(
            model, unknown_input_derivatives, option="unknown_input_derivatives="
        )  # before the simulation
        try:
            visits = record_visits(model, one_input_record(model, record, option=_RECORD)) if record else None
            return analyze(
                model,
                method=method,
                seed=seed,
                max_seconds=max_seconds,
                branches=branches,
                visited=visits.patterns if visits else None,
                crossings=visits.crossings if visits else None,
                joint=joint,
                unknown_input_derivatives=unknown_input_derivatives,
            )
        except MemoryError:  # outside analyze itself (the record's simulation); raised below, arrays freed
            pass
    raise out_of_memory(model, k)


def sensors_file(
    model: Model | str | Path,
    *,
    record: str | Path | None = None,
    rank_size: int | None = None,
    noise: float | None = None,
    output: str | Path | None = None,
    force: bool = False,
    target: str | Sequence[str] = "parameters",
    max_size: int | None = None,
    seed: int = 0,
    max_seconds: float | None = None,
    executor: Executor | None = None,
    progress: bool | Callable[[int], Any] = False,
) -> SensorSearch:
    """The minimal sensor sets of a model file, ranked along one record's response when one is given.

    Parameters
    ----------
    model : Model, str or Path
        The model or its file; its outputs are the candidate sensors.
    record : str, Path or None
        A record driving the model's one input: the sufficient sets of ``rank_size`` sensors are
        ranked by the Cramér-Rao bound along the response of the model's ``[values]`` to it.
    rank_size : int or None
        Size of the sets ranked (default: the smallest minimal set's); only with a record.
    noise : float or None
        Relative noise of every output for the ranking (std = ``noise`` x RMS), between 0 and 10 (None:
        0.01); only with a record.
    output : str, Path or None
        The file the rendering will be written to, checked before any work (as for :func:`analyze_file`).
    force : bool
        Replace that file.
    target : str or sequence of str
        ``"parameters"``, ``"all"`` (states too) or names, as for :func:`obsnl.design.sensors.sensors`.
    max_size : int or None
        The largest set tried.
    seed : int
        The analyses' seed.
    max_seconds : float or None
        The time limit of each analysis (checked before the search starts).
    executor : Executor or None
        Where the analyses run; its scheduler is probed before any work.
    progress : bool or callable
        A progress bar, or a callable given the sets tried.

    Returns
    -------
    SensorSearch
        The search, ranked when a record was given.
    """
    from obsnl.design.sensors import rank_sufficient_sets, sensors

    if executor is not None:  # a Dask scheduler that does not answer is refused before any work
        executor.probe()
    _check_output(output, force)
    check_seconds(max_seconds)  # of each analysis: refused before the search starts
    if record is None and (rank_size is not None or noise is not None):  # would be ignored: refused, not dropped
        raise OptionError(f"the rank size and the noise level rank the sensor sets along a record: add {_RECORD}")
    if noise is not None and not (isinstance(noise, (int, float)) and 0.0 < noise < 10.0):
        raise OptionError(f"noise {quote(noise, 30)} is not a relative level between 0 and 10 (0.01 is 1 %)")
    with time_budget(None):
        model = _model(model)
    rec = None
    if record is not None:  # read before the search: a bad record is refused before any work
        if rank_size is not None and not (isinstance(rank_size, int) and 1 <= rank_size <= len(model.output_names)):
            raise OptionError(
                f"the rank size is a number of sensors from 1 to {len(model.output_names)} (the "
                f"model's outputs), got {quote(rank_size, 30)}"
            )
        rec = one_input_record(model, record, option=_RECORD)
    result = sensors(
        model,
        target=target,
        max_size=max_size,
        seed=seed,
        max_seconds=max_seconds,
        executor=executor,
        progress=progress,
    )
    if rec is None:
        return result
    t = rec.dt * np.arange(len(rec.accel))
    return rank_sufficient_sets(
        result, model, t=t, inputs=rec.accel, size=rank_size, noise=0.01 if noise is None else noise
    )


def design_file(
    model: Model | str | Path,
    records: Sequence[str | Path],
    *,
    max_seconds: float | None = None,
    figure: str | Path | None = None,
    output: str | Path | None = None,
    force: bool = False,
    target: str | Sequence[str] = "all",
    sensors: str | Sequence[str] | None = None,
    scales: str | Sequence[float] | None = None,
    seed: int = 0,
    intersample: str | Mapping[str, str] | Sequence[str] | None = None,
) -> ExperimentDesign:
    """The experiment design of a model file under records, within one time budget.

    Parameters
    ----------
    model : Model, str or Path
        The model or its file; its ``[values]`` are simulated.
    records : sequence of str or Path
        Record files, each driving the model's one input; records whose files share a name are named by
        their paths.
    max_seconds : float or None
        Time limit of the whole job (reading, simulations, verdicts).
    figure : str, Path or None
        A PNG file for the plot of the visited branches per scale (checked before any work, written after).
    output : str, Path or None
        The file the caller will write the rendering to: refused before any work when it cannot be
        written, or when it is ``figure``.
    force : bool
        Overwrite ``figure`` (and ``output``).
    target : str or sequence of str
        What must be identifiable, as for :func:`obsnl.design.experiment.design`.
    sensors : str, sequence of str or None
        The outputs measured (None: every output).
    scales : str, sequence of float or None
        The record scales tried, or comma-separated text (``"0.1,1,10"``; None: the default ladder).
    seed : int
        The analyses' seed.
    intersample : str, mapping, sequence of str or None
        How the inputs run between samples, as for :func:`obsnl.design.experiment.design`.

    Returns
    -------
    ExperimentDesign
        The design.
    """
    from obsnl.design.experiment import design
    from obsnl.report.experiment import plot_visits
    from obsnl.report.files import OutputFolder, check_target

    _check_output(output, force)
    if not records:
        raise OptionError(f"give at least one {_RECORD} (.csv or .AT2)")
    ladder: Any = scales  # what is not a positive number design refuses, quoted as given
    if isinstance(scales, str):  # "0.1,1,10"
        try:  # "1_0" is refused as written (Python's float would read it as 10, a record cell refuses it)
            ladder = [float(x) if "_" not in x else x for x in scales.split(",") if x.strip()]
        except ValueError:
            pass
    if figure is not None:  # refused before any work (an empty name too: never ignored)
        if Path(figure).suffix.lower() != ".png":
            raise OptionError(f"the figure is a PNG; name a .png file, not {quote(str(figure))}")
        if output and output != "-" and Path(output).resolve() == Path(figure).resolve():
            raise OptionError("the figure and the output name the same file; give two files")
        check_target(figure, force=force)
    with time_budget(max_seconds):
        model = _model(model)
        check_analysis_limits(model)
        read = [one_input_record(model, path, option=_RECORD) for path in records]
        stems = [r.name for r in read]
        if len(set(stems)) < len(stems):  # same file names in different folders: name them by their paths
            read = [dataclasses.replace(r, name=str(path)) for r, path in zip(read, records)]
        result = design(
            model,
            read,
            target=target,
            sensors=sensors,
            scales=ladder,
            seed=seed,
            max_seconds=max_seconds,
            intersample=intersample,
        )
    if figure:
        fig = Path(figure)
        with OutputFolder(fig.parent, [fig.name], force=force, folder_link_ok=True) as out:
            plot_visits(result, out.path(fig.name))
            out.commit()
    return result
