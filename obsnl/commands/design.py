"""``obsnl design``: the smallest record scale and the records that make a model identifiable, as one request.

:class:`DesignRequest` holds the options, typed; :func:`run_design` checks the output file and the figure before
any work, reads the model once with its limits checked once and the records as its one input, and designs the
experiment (:func:`obsnl.design.experiment.design`), all within one time budget; it renders the design
(:func:`obsnl.report.experiment.render_design`), draws the figure when one is named and writes the rendering to the
output file when one is named. :func:`design_printed` is what the command prints, with the line that says the design
is inconclusive.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from obsnl._text import quote
from obsnl.commands.inputs import RECORD_OPTION, check_file_option, one_input_record
from obsnl.errors import OptionError
from obsnl.report.printed import Printed, check_format, check_rendering_target, write_rendering

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

    def __post_init__(self) -> None:
        """Refuse, before any work, a format the command does not render and a file option of the wrong kind; one
        record file given alone is the one record (not a sequence of its characters)."""
        from obsnl.report.experiment import DESIGN_FORMATS

        check_format(self.fmt, DESIGN_FORMATS)
        if isinstance(self.records, (str, os.PathLike)):
            object.__setattr__(self, "records", (self.records,))
        for path in self.records:
            check_file_option(path, RECORD_OPTION)
        check_file_option(self.figure, "figure=")
        check_file_option(self.output, "output=")


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
    from obsnl.design.experiment import design
    from obsnl.model.bounds.budget import time_budget
    from obsnl.model.files import as_model
    from obsnl.observability.limits import check_analysis_limits, check_file_limits
    from obsnl.report.experiment import plot_visits, render_design
    from obsnl.report.files import OutputFolder, check_target

    output, figure, records = request.output, request.figure, request.records
    check_rendering_target(output, force=request.force)
    if not records:
        raise OptionError(f"give at least one {RECORD_OPTION} (.csv or .AT2)")
    if figure is not None:  # refused before any work (an empty name too: never ignored)
        if Path(figure).suffix.lower() != ".png":
            raise OptionError(f"the figure is a PNG; name a .png file, not {quote(str(figure))}")
        if output and output != "-" and Path(output).resolve() == Path(figure).resolve():
            raise OptionError("the figure and the output name the same file; give two files")
        check_target(figure, force=request.force)
    with time_budget(request.max_seconds):  # reading, the simulations and the verdicts
        model = as_model(request.model, check=check_file_limits)
        check_analysis_limits(model)
        read = [one_input_record(model, path, option=RECORD_OPTION) for path in records]
        stems = [r.name for r in read]
        if len(set(stems)) < len(stems):  # same file names in different folders: name them by their paths
            read = [dataclasses.replace(r, name=str(path)) for r, path in zip(read, records)]
        found = design(
            model,
            read,
            target=request.target,
            sensors=request.sensors,
            scales=_ladder(request.scales),
            seed=request.seed,
            max_seconds=request.max_seconds,
            intersample=request.intersample,
        )
    if figure:
        fig = Path(figure)
        with OutputFolder(fig.parent, [fig.name], force=request.force, folder_link_ok=True) as out:
            plot_visits(found, out.path(fig.name))
            out.commit()
    text = render_design(found, request.fmt)
    return DesignResult(found, text, write_rendering(text, request.output, force=request.force))


def _ladder(scales: str | Sequence[float] | None) -> Any:
    """The record scales as :func:`obsnl.design.experiment.design` takes them: comma-separated text
    (``"0.1,1,10"``) read as numbers; what is not a positive number design refuses, quoted as given (``"1_0"`` is
    kept as written: Python's float would read it as 10, a record cell refuses it)."""
    if not isinstance(scales, str):
        return scales
    try:
        return [float(x) if "_" not in x else x for x in scales.split(",") if x.strip()]
    except ValueError:
        return scales


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
