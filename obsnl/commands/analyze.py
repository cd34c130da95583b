"""``obsnl analyze``: the observability and identifiability of every branch of a model, as one request.

:class:`AnalyzeRequest` holds the options, typed; :func:`run_analyze` checks the output file before any work,
reads the model once with its size checked, checks the options and the limits once
(:func:`obsnl.observability.analyze.check_analysis`), simulates the record when one is given, and runs the checked
analysis (:func:`obsnl.observability.analyze.run_analysis`), all within one time budget; it renders the result
(:func:`obsnl.report.tables.render`) and writes it to the output file when one is named. :func:`analyze_printed` is
what the command prints, with the line that names the first inconclusive branch.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from obsnl.commands.inputs import RECORD_OPTION, check_file_option, one_input_record
from obsnl.report.printed import Printed, check_format, check_rendering_target, write_rendering

if TYPE_CHECKING:
    from obsnl.model.core import Model
    from obsnl.observability.analyze import CheckedAnalysis
    from obsnl.observability.joint.visited import Visits
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

    def __post_init__(self) -> None:
        """Refuse, before the model is read, a format the command does not render and a file option of the wrong
        kind; read labels given as text (``"a,b"``) as the command line reads them."""
        from obsnl.report.tables import FORMATS

        check_format(self.fmt, FORMATS)
        check_file_option(self.record, RECORD_OPTION)
        check_file_option(self.output, "output=")
        if isinstance(self.branches, str):  # "ab" is one label, not the labels a and b
            object.__setattr__(self, "branches", [b.strip() for b in self.branches.split(",") if b.strip()])


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
    from obsnl.model.bounds.budget import time_budget
    from obsnl.model.files import as_model
    from obsnl.observability.analyze import check_analysis, run_analysis
    from obsnl.observability.limits import check_file_limits
    from obsnl.report.tables import render

    check_rendering_target(request.output, force=request.force)
    with time_budget(request.max_seconds):  # reading, the checks, the record's simulation and the analysis
        model = as_model(request.model, check=check_file_limits)
        checked = check_analysis(  # before the record's simulation
            model,
            method=request.method,
            seed=request.seed,
            max_seconds=request.max_seconds,
            branches=request.branches or None,
            joint=request.joint,
            unknown_input_derivatives=request.unknown_input_derivatives,
            option="unknown_input_derivatives=",
        )
        visits = _record_visits(checked, request.record) if request.record else None
        result = run_analysis(
            checked, visited=visits.patterns if visits else None, crossings=visits.crossings if visits else None
        )
    text = render(result, request.fmt)
    return AnalyzeResult(result, text, write_rendering(text, request.output, force=request.force))


def _record_visits(checked: CheckedAnalysis, path: str | Path) -> Visits:
    """The sign patterns and crossings a simulation of the model's ``[values]`` under the record at ``path`` visits
    along its continuous trajectory (:func:`obsnl.design.continuous.continuous_visits`: crossings located between
    samples, a state resting on a switching surface on no branch, the input between samples as the model's
    ``[intersample]`` table says, from the known initial state)."""
    from obsnl.design.continuous import continuous_visits  # casadi: loaded only with a record
    from obsnl.observability.limits import out_of_memory

    model = checked.model
    record = one_input_record(model, path, option=RECORD_OPTION)
    try:
        return continuous_visits(model, record.t, {model.inputs[0].name: record.accel})
    except MemoryError:  # numpy's _ArrayMemoryError too; raised below, once the simulation's arrays are freed
        pass
    raise out_of_memory(model, checked.unknown_input_derivatives)


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
