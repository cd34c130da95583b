"""``obsnl design``: the smallest record scale and the records that make a model identifiable, as one request.

:class:`DesignRequest` holds the options, typed; :func:`run_design` runs :func:`obsnl.design.records.design_file` (the
output file and the figure checked before any work, the model read once with its limits checked once, the records
read, all within one time budget), renders the design (:func:`obsnl.report.experiment.render_design`) and writes
it to the output file when one is named; :func:`design_printed` is what the command prints, with the line that says the
design is inconclusive.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from obsnl.report.printed import Printed, write_rendering

if TYPE_CHECKING:
    from obsnl.design.experiment import ExperimentDesign
    from obsnl.model.core import Model

__all__ = ["DesignRequest", "DesignResult", "run_design", "design_printed"]


@dataclass(frozen=True, kw_only=True)
class DesignRequest:
    """One experiment design of a model (file) under records.

    Parameters
    ----------
    model : Model, str or Path
        The model or its file; its ``[values]`` are simulated.
    records : sequence of str or Path
        The record files, each driving the model's one input (one at least).
    target : str or sequence of str
        What must be identifiable (``"all"``, ``"parameters"`` or names).
    sensors : str, sequence of str or None
        The outputs measured (``"a,b"``; None: every output).
    scales : str, sequence of float or None
        The record scales tried (``"0.1,1,10"`` as text too; None: the default ladder).
    seed : int
        The analyses' seed.
    intersample : str, mapping, sequence of str or None
        How the inputs run between samples (None or empty: the model's ``[intersample]``, else linear).
    max_seconds : float or None
        Time limit of the whole job (reading, simulations, verdicts).
    figure : str, Path or None
        A PNG file for the plot of the visited branches per scale (checked before any work).
    fmt : {"text", "json", "md", "tex"}
        The format of the rendering.
    output : str, Path or None
        A file that takes the rendering instead of standard output (checked before any work).
    force : bool
        Overwrite ``output`` and the figure.
    """

    model: Model | str | Path
    records: Sequence[str | Path] = ()
    target: str | Sequence[str] = "all"
    sensors: str | Sequence[str] | None = None
    scales: str | Sequence[float] | None = None
    seed: int = 0
    intersample: str | Mapping[str, str] | Sequence[str] | None = None
    max_seconds: float | None = None
    figure: str | Path | None = None
    fmt: str = "text"
    output: str | Path | None = None
    force: bool = False


@dataclass(frozen=True)
class DesignResult:
    """What :func:`run_design` returns: the design, its rendering and the file it was written to (None: not written)."""

    design: ExperimentDesign
    rendering: str
    written: Path | None = None

    def to_dict(self) -> dict[str, Any]:
        """The design's document and the file written."""
        return {"design": self.design.to_dict(), "written": None if self.written is None else str(self.written)}


def run_design(request: DesignRequest) -> DesignResult:
    """Design the experiment of the request's model under its records, render the design and write it to
    ``request.output`` when one is named (the figure too, when one is named).

    Parameters
    ----------
    request : DesignRequest

    Returns
    -------
    DesignResult
    """
    from obsnl.design.records import design_file
    from obsnl.report.experiment import render_design

    found = design_file(
        request.model,
        request.records,
        max_seconds=request.max_seconds,
        figure=request.figure,
        output=request.output,
        force=request.force,
        target=request.target,
        sensors=request.sensors,
        scales=request.scales,
        seed=request.seed,
        intersample=request.intersample,
    )
    text = render_design(found, request.fmt)
    return DesignResult(found, text, write_rendering(text, request.output, force=request.force))


def design_printed(result: DesignResult) -> Printed:
    """What ``obsnl design`` prints: the rendering (nothing when it went to a file), and the line that says the
    design is inconclusive (:func:`obsnl.report.experiment.undecided_line`).

    Parameters
    ----------
    result : DesignResult

    Returns
    -------
    Printed
    """
    from obsnl.report.experiment import undecided_line

    return Printed(result.rendering if result.written is None else None, undecided_line(result.design))
