"""``obsnl report``: analyse models and write their branch tables into a folder, as one request.

:class:`ReportRequest` holds the options, typed; :func:`run_report` runs :func:`obsnl.batch.report_paths` (a Dask scheduler
probed before any work, every model read with its size checked and held against the analysis limits before the
first is analysed, all within one time budget); :func:`report_printed` is what the command prints: the tables written and
the line that names the first inconclusive branch with its model's name.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from obsnl.commands.inputs import check_file_option
from obsnl.report.printed import Printed

if TYPE_CHECKING:
    from obsnl.executor import Executor
    from obsnl.observability.results import AnalysisResult

__all__ = ["ReportRequest", "ReportResult", "run_report", "report_printed"]


@dataclass(frozen=True, kw_only=True)
class ReportRequest:
    """One report of models into a folder.

    Parameters
    ----------
    models : sequence of str or Path
        Model files (or ``obsnl:NAME``).
    out : str or Path
        The report folder.
    method : {"auto", "orc", "sedoglavic"}
        The observability engine.
    seed : int
        The analyses' seed.
    max_seconds : float or None
        Time limit of the whole job (each model on a worker gets the same limit).
    force : bool
        Overwrite existing files.
    executor : Executor or None
        Where the models are analysed (its scheduler probed before any work).
    """

    models: Sequence[str | Path]
    out: str | Path
    method: str = "auto"
    seed: int = 0
    max_seconds: float | None = None
    force: bool = False
    executor: Executor | None = None

    def __post_init__(self) -> None:
        """One model file given alone is the one model (its characters were read as files); refuse, before any work, a
        model or a folder that is not a file name."""
        if isinstance(self.models, (str, os.PathLike)):
            object.__setattr__(self, "models", (self.models,))
        for path in self.models:
            check_file_option(path, "models=")
        check_file_option(self.out, "out=", what="folder")


@dataclass(frozen=True)
class ReportResult:
    """What :func:`run_report` returns: one analysis per model, in order, and the folder the tables went to."""

    results: tuple[AnalysisResult, ...]
    out: str | Path

    def to_dict(self) -> dict[str, Any]:
        """The analyses' documents and the folder."""
        return {"results": [r.to_dict() for r in self.results], "out": str(self.out)}


def run_report(request: ReportRequest) -> ReportResult:
    """Analyse the request's models and write their tables (:func:`obsnl.batch.report_paths`).

    Parameters
    ----------
    request : ReportRequest

    Returns
    -------
    ReportResult
    """
    from obsnl.batch import report_paths

    results = report_paths(
        request.models,
        request.out,
        max_seconds=request.max_seconds,
        method=request.method,
        seed=request.seed,
        force=request.force,
        executor=request.executor,
    )
    return ReportResult(results, request.out)


def report_printed(result: ReportResult) -> Printed:
    """What ``obsnl report`` prints: :func:`obsnl.report.folders.tables_written_line`, and the line that names the
    first inconclusive branch with its model's name (:func:`obsnl.report.structure.inconclusive_line`).

    Parameters
    ----------
    result : ReportResult

    Returns
    -------
    Printed
    """
    from obsnl.report.folders import tables_written_line
    from obsnl.report.structure import inconclusive_line

    return Printed(tables_written_line(len(result.results), result.out), inconclusive_line(result.results, named=True))
