"""Batch work over many models: analyse each and write the report folder.

The one place where analyses and report files meet (the report never runs an analysis).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from obsnl.model.core import Model
from obsnl.observability.analyze import analyze
from obsnl.observability.results import AnalysisResult
from obsnl.report.files import check_target, report_files, write_tables

__all__ = ["report_models"]


def report_models(models: Sequence[Model], out: str | Path, *, method: str = "auto", seed: int = 0,
                  force: bool = False, max_seconds: float | None = None) -> tuple[AnalysisResult, ...]:
    """Analyse ``models`` and write one table per model (``.md``, ``.tex``, ``.json``), ``index.md``
    and ``timings.md`` into ``out``.

    Parameters
    ----------
    models
        Models with distinct names (the names become file names).
    out
        The report folder.
    method, seed, max_seconds
        As :func:`obsnl.analyze` (one seed for every model).
    force
        Overwrite existing files.

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
    results = tuple(analyze(m, method=method, seed=seed, max_seconds=max_seconds) for m in models)
    write_tables(results, out, force=True)
    return results
