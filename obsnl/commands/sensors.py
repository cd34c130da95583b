"""``obsnl sensors``: which sensors make every target identifiable, as one request.

:class:`SensorsRequest` holds the options, typed; :func:`run_sensors` probes a Dask scheduler and checks the output
file, the time limit and the ranking's options before any work, reads the model and the record once, searches the
minimal sensor sets (:func:`obsnl.design.sensors.sensors`) and ranks the sufficient ones along the record when one is
given (:func:`obsnl.design.sensors.rank_sufficient_sets`); it renders the search
(:func:`obsnl.report.sensors.render_sensors`) and writes it to the output file when one is named.
:func:`sensors_printed` is what the command prints, with the line that names the sets left undecided.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from obsnl._text import quote
from obsnl.commands.inputs import RECORD_OPTION, check_file_option, one_input_record
from obsnl.errors import OptionError
from obsnl.report.printed import Printed, check_format, check_rendering_target, write_rendering

if TYPE_CHECKING:
    from obsnl.design.sensor_search import SensorSearch
    from obsnl.executor import Executor
    from obsnl.model.core import Model

__all__ = ["SensorsRequest", "SensorsResult", "run_sensors", "sensors_printed"]


@dataclass(frozen=True, kw_only=True)
class SensorsRequest:
    """One search of the minimal sensor sets of a model (file).

    Parameters
    ----------
    model : Model, str or Path
        The model or its file; its outputs are the candidate sensors.
    target : str or sequence of str
        ``"parameters"``, ``"all"`` (states too) or names.
    max_size : int or None
        The largest set tried.
    seed : int
        The analyses' seed.
    max_seconds : float or None
        The time limit of each analysis.
    progress : bool
        A progress bar.
    record : str, Path or None
        Rank the sufficient sets by the Cramer-Rao bound along the response to this record.
    rank_size : int or None
        Size of the sets ranked (with ``record``).
    noise : float or None
        Relative noise of every output for the ranking (with ``record``; None: 0.01).
    executor : Executor or None
        Where the analyses run (its scheduler probed before any work).
    fmt : {"text", "json", "md", "tex"}
        The format of the rendering.
    output : str, Path or None
        A file that takes the rendering instead of standard output (checked before any work).
    force : bool
        Overwrite ``output``.
    """

    model: Model | str | Path
    target: str | Sequence[str] = "parameters"
    max_size: int | None = None
    seed: int = 0
    max_seconds: float | None = None
    progress: bool = False
    record: str | Path | None = None
    rank_size: int | None = None
    noise: float | None = None
    executor: Executor | None = None
    fmt: str = "text"
    output: str | Path | None = None
    force: bool = False

    def __post_init__(self) -> None:
        """Refuse, before any work, a format the command does not render and a file option of the wrong kind."""
        from obsnl.report.sensors import FORMATS

        check_format(self.fmt, FORMATS)
        check_file_option(self.record, RECORD_OPTION)
        check_file_option(self.output, "output=")


@dataclass(frozen=True)
class SensorsResult:
    """What :func:`run_sensors` returns: the search, its rendering and the file it was written to (None: not written)."""

    search: SensorSearch
    rendering: str
    written: Path | None = None

    def to_dict(self) -> dict[str, Any]:
        """The search's document and the file written."""
        return {"search": self.search.to_dict(), "written": None if self.written is None else str(self.written)}


def run_sensors(request: SensorsRequest) -> SensorsResult:
    """Search the request's model's minimal sensor sets (ranked along the record when one is given), render the
    search and write it to ``request.output`` when one is named.

    Parameters
    ----------
    request : SensorsRequest

    Returns
    -------
    SensorsResult
    """
    from obsnl.design.sensors import rank_sufficient_sets, sensors
    from obsnl.model.bounds.budget import check_seconds, time_budget
    from obsnl.model.files import as_model
    from obsnl.observability.limits import check_file_limits
    from obsnl.report.sensors import render_sensors

    record, rank_size, noise = request.record, request.rank_size, request.noise
    if request.executor is not None:  # a Dask scheduler that does not answer is refused before any work
        request.executor.probe()
    check_rendering_target(request.output, force=request.force)
    check_seconds(request.max_seconds)  # of each analysis: refused before the search starts
    if record is None and (rank_size is not None or noise is not None):  # would be ignored: refused, not dropped
        raise OptionError(f"the rank size and the noise level rank the sensor sets along a record: add {RECORD_OPTION}")
    if noise is not None and not (isinstance(noise, (int, float)) and 0.0 < noise < 10.0):
        raise OptionError(f"noise {quote(noise, 30)} is not a relative level between 0 and 10 (0.01 is 1 %)")
    with time_budget(None):
        model = as_model(request.model, check=check_file_limits)
    rec = None
    if record is not None:  # read before the search: a bad record is refused before any work
        if rank_size is not None and not (isinstance(rank_size, int) and 1 <= rank_size <= len(model.output_names)):
            raise OptionError(
                f"the rank size is a number of sensors from 1 to {len(model.output_names)} (the "
                f"model's outputs), got {quote(rank_size, 30)}"
            )
        rec = one_input_record(model, record, option=RECORD_OPTION)
    search = sensors(
        model,
        target=request.target,
        max_size=request.max_size,
        seed=request.seed,
        max_seconds=request.max_seconds,
        executor=request.executor,
        progress=request.progress,
    )
    if rec is not None:
        search = rank_sufficient_sets(
            search,
            model,
            t=rec.t,
            inputs=rec.accel,
            size=rank_size,
            noise=0.01 if noise is None else noise,
        )
    text = render_sensors(search, request.fmt)
    return SensorsResult(search, text, write_rendering(text, request.output, force=request.force))


def sensors_printed(result: SensorsResult) -> Printed:
    """What ``obsnl sensors`` prints: the rendering (nothing when it went to a file), and the line that names the
    sets left undecided (:func:`obsnl.report.sensors.undecided_line`).

    Parameters
    ----------
    result : SensorsResult

    Returns
    -------
    Printed
    """
    from obsnl.report.sensors import undecided_line

    return Printed(result.rendering if result.written is None else None, undecided_line(result.search))
