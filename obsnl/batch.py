"""Batch work over many models: analyse each and write the report folder.

The one place where analyses and report files meet (the report never runs an analysis).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from obsnl.executor import Executor
from obsnl.model.bounds.budget import time_budget
from obsnl.model.core import Model
from obsnl.model.files import read_model
from obsnl.observability.analyze import analyze
from obsnl.observability.limits import check_analysis_limits, check_file_limits
from obsnl.observability.results import AnalysisResult
from obsnl.report.files import check_target
from obsnl.report.folders import report_files, write_tables

__all__ = ["report_models", "report_paths"]


def _analyze_task(task: tuple[dict, str, int, float | None]) -> AnalysisResult:
    """One model of a report, from its specification (``Model.to_dict``)."""
    spec, method, seed, max_seconds = task
    return analyze(Model.from_dict(spec), method=method, seed=seed, max_seconds=max_seconds)


def report_models(
    models: Sequence[Model],
    out: str | Path,
    *,
    method: str = "auto",
    seed: int = 0,
    force: bool = False,
    max_seconds: float | None = None,
    executor: Executor | None = None,
) -> tuple[AnalysisResult, ...]:
    """Analyse ``models`` and write one table per model (``.md``, ``.tex``, ``.json``), ``index.md``
    and ``timings.md`` into ``out``.

    Parameters
    ----------
    models : sequence of Model
        Models with distinct names (the names become file names).
    out : str or Path
        The report folder.
    method : str
        As :func:`obsnl.analyze`.
    seed : int
        As :func:`obsnl.analyze` (one seed for every model).
    max_seconds : float or None
        As :func:`obsnl.analyze`.
    force : bool
        Overwrite existing files.
    executor : Executor or None
        Where the models are analysed (:class:`obsnl.executor.Executor`; default: this process). A
        task carries the model's specification (``Model.to_dict()``) and the seed.

    Returns
    -------
    tuple of AnalysisResult
        One per model, in order.

    Raises
    ------
    ObsnlError
        A file to write exists and ``force`` is False (checked before any analysis; nothing is
        written then), or a model name that cannot be a file name.
    """
    for t in report_files([m.name for m in models], out):
        check_target(t, force=force, root=out)
    if executor is None or executor.kind == "serial":
        results = tuple(analyze(m, method=method, seed=seed, max_seconds=max_seconds) for m in models)
    else:
        results = tuple(
            executor.map(
                _analyze_task,
                [(m.to_dict(), method, seed, max_seconds) for m in models],
                label=lambda task: f"the analysis of model {task[0]['name']!r}",
            )
        )
    write_tables(results, out, force=force)
    return results


def report_paths(
    paths: Sequence[str | Path],
    out: str | Path,
    *,
    max_seconds: float | None = None,
    method: str = "auto",
    seed: int = 0,
    force: bool = False,
    executor: Executor | None = None,
) -> tuple[AnalysisResult, ...]:
    """:func:`report_models` of model files, within one time budget (reading, splitting, analysing).

    Parameters
    ----------
    paths : sequence of str or Path
        Model files (or ``obsnl:NAME``), each read with its size checked before any expression is parsed;
        every model is checked against the analysis limits before the first is analysed.
    out : str or Path
        The report folder.
    max_seconds : float or None
        Time limit of the whole job (each model on a worker gets the same limit).
    method : str
        As for :func:`report_models`.
    seed : int
        As for :func:`report_models`.
    force : bool
        Overwrite existing files.
    executor : Executor or None
        As for :func:`report_models`; its scheduler is probed before any work.

    Returns
    -------
    tuple of AnalysisResult
        One per model, in order.
    """
    if isinstance(executor, Executor):  # a scheduler that does not answer: refused at once
        executor.probe()
    with time_budget(max_seconds):
        models = [read_model(p, check=check_file_limits) for p in paths]
        for m in models:
            check_analysis_limits(m)
        return report_models(
            models, out, method=method, seed=seed, force=force, max_seconds=max_seconds, executor=executor
        )
