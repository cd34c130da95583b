"""``obsnl analyze``: the observability and identifiability of every branch of a model, as one request.

:class:`AnalyzeRequest` holds the options, typed; :func:`run_analyze` runs :func:`obsnl.design.records.analyze_file` (the
output file checked before any work, the model read once with its size checked, the limits checked once, all
within one time budget), renders the result (:func:`obsnl.report.tables.render`) and writes it to the output
file when one is named; :func:`analyze_printed` is what the command prints, with the line that names the first
inconclusive branch.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from obsnl.report.printed import Printed, write_rendering

if TYPE_CHECKING:
    from obsnl.model.core import Model
    from obsnl.observability.results import AnalysisResult

__all__ = ["AnalyzeRequest", "AnalyzeResult", "run_analyze", "analyze_printed"]


@dataclass(frozen=True, kw_only=True)
class AnalyzeRequest:
    """One analysis of a model (file).

    Parameters
    ----------
    model : Model, str or Path
        The model or its file.
    fmt : {"text", "json", "md", "tex", "json-table"}
        The format of the rendering.
    method : {"auto", "orc", "sedoglavic"}
        The observability engine.
    seed : int or None
        As for :func:`obsnl.analyze`.
    max_seconds : float or None
        Time limit of the whole job (reading, the record's simulation, the split into branches, the analysis).
    branches : sequence of str or None
        Only these branches (None or empty: every branch).
    record : str, Path or None
        Only what the model's ``[values]`` visit under this record driving its one input.
    joint : bool
        Also the joint verdict.
    unknown_input_derivatives : int, str or None
        As for :func:`obsnl.analyze`.
    output : str, Path or None
        A file for the rendering (None or ``"-"``: standard output), checked before any work.
    force : bool
        Overwrite ``output``.
    """

    model: Model | str | Path
    fmt: str = "text"
    method: str = "auto"
    seed: int | None = None
    max_seconds: float | None = None
    branches: Sequence[str] | None = None
    record: str | Path | None = None
    joint: bool = True
    unknown_input_derivatives: int | str | None = None
    output: str | Path | None = None
    force: bool = False


@dataclass(frozen=True)
class AnalyzeResult:
    """What :func:`run_analyze` returns: the analysis, its rendering and the file it was written to (None: not written)."""

    analysis: AnalysisResult
    rendering: str
    written: Path | None = None

    def to_dict(self) -> dict[str, Any]:
        """The analysis's document and the file written."""
        return {"analysis": self.analysis.to_dict(), "written": None if self.written is None else str(self.written)}


def run_analyze(request: AnalyzeRequest) -> AnalyzeResult:
    """Analyse the request's model, render the result and write it to ``request.output`` when one is named.

    Parameters
    ----------
    request : AnalyzeRequest

    Returns
    -------
    AnalyzeResult
    """
    from obsnl.design.records import analyze_file
    from obsnl.report.tables import render

    result = analyze_file(
        request.model,
        record=request.record,
        method=request.method,
        seed=request.seed,
        max_seconds=request.max_seconds,
        branches=request.branches or None,
        joint=request.joint,
        unknown_input_derivatives=request.unknown_input_derivatives,
        output=request.output,
        force=request.force,
    )
    text = render(result, request.fmt)
    return AnalyzeResult(result, text, write_rendering(text, request.output, force=request.force))


def analyze_printed(result: AnalyzeResult) -> Printed:
    """What ``obsnl analyze`` prints: the rendering (nothing when it went to a file), and the line that names the
    first inconclusive branch (:func:`obsnl.report.structure.inconclusive_line`).

    Parameters
    ----------
    result : AnalyzeResult

    Returns
    -------
    Printed
    """
    from obsnl.report.structure import inconclusive_line

    text = result.rendering if result.written is None else None
    return Printed(text, inconclusive_line([result.analysis]))
