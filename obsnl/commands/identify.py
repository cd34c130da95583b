"""``obsnl identify``: identification from measured data or a simulation study, as one request.

:class:`IdentifyRequest` takes the options as the command line gives them (the guesses and noise levels as
``NAME=VALUE`` texts, the meaning of ``--noise``: one ``RATIO`` for every channel, ``NAME=RATIO`` for one; a
tuning given in part, :data:`TUNING_DEFAULTS` for the rest), checks them and resolves them once, before any
work: an option that would be ignored, an executor nothing would use, a scheduler that does not answer and an
output folder that cannot take the files are refused before the model is read; the model is read once. Then the
library checks and resolves the rest once (:func:`obsnl.identification.identify.check_identify` for measured data,
:func:`~obsnl.identification.identify.check_study` for a simulation study: the data or the record read, the table
read, the guesses): the request holds the :class:`~obsnl.identification.identify.CheckedIdentification`.
:func:`run_identify` runs it (:func:`~obsnl.identification.identify.run_identification`, which checks nothing again)
and writes the files; :func:`identify_printed` is what the command prints.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, overload

from obsnl.commands.inputs import check_file_option
from obsnl.errors import OptionError
from obsnl.report.printed import Printed, written_line

if TYPE_CHECKING:
    from obsnl.executor import Executor
    from obsnl.identification.experiments import Tuning
    from obsnl.identification.identify import CheckedIdentification
    from obsnl.identification.results import Identification
    from obsnl.model.core import Model
    from obsnl.observability.contract.branch_table import BranchTable

__all__ = [
    "IdentifyRequest",
    "IdentifyResult",
    "run_identify",
    "identify_printed",
    "tuning_from",
    "noise_ratios",
    "TUNING_DEFAULTS",
    "STUDY_NOISE",
]

#: The tuning of a parameter not given when the others are: prior std of log-parameters, their random
#: walk, the factor on the state noise, the innovation gate (off).
TUNING_DEFAULTS: tuple[float, float, float, float] = (0.2, 0.0, 1.0, float("inf"))
#: A noise level of a simulation study when none is given (noise-to-signal RMS ratio).
STUDY_NOISE = 1e-3


def tuning_from(
    s0: float | None = None, q_theta: float | None = None, q_x: float | None = None, gate: float | None = None
) -> Tuning | None:
    """A filter tuning from the values given, :data:`TUNING_DEFAULTS` for the others; None when none is given.

    Parameters
    ----------
    s0, q_theta, q_x, gate : float or None
        Prior std of the log-parameters, their random walk, the factor on the state noise, the
        innovation gate.

    Returns
    -------
    Tuning or None
        None: the identification tunes the filter by the output misfit.

    Examples
    --------
    >>> tuning_from() is None
    True
    >>> tuning_from(s0=0.5).s0
    0.5
    """
    from obsnl.identification.experiments import Tuning

    given = (s0, q_theta, q_x, gate)
    if given == (None,) * 4:
        return None
    return Tuning(*(d if v is None else v for v, d in zip(given, TUNING_DEFAULTS)))


@overload
def noise_ratios(
    items: Sequence[str], channels: Sequence[str], *, study: Literal[True], option: str = "noise="
) -> float: ...
@overload
def noise_ratios(
    items: Sequence[str], channels: Sequence[str], *, study: Literal[False], option: str = "noise="
) -> dict[str, float]: ...
@overload
def noise_ratios(
    items: Sequence[str], channels: Sequence[str], *, study: bool, option: str = "noise="
) -> dict[str, float] | float: ...


def noise_ratios(
    items: Sequence[str], channels: Sequence[str], *, study: bool, option: str = "noise="
) -> dict[str, float] | float:
    """Noise-to-signal RMS ratios from texts: ``RATIO`` for every channel (at most once), ``NAME=RATIO`` (over it).

    Parameters
    ----------
    items : sequence of str
        The texts.
    channels : sequence of str
        The model's inputs and outputs.
    study : bool
        A simulation study: one ratio for every channel (:data:`STUDY_NOISE` when none is given).
    option : str
        How the caller names the texts in messages.

    Returns
    -------
    dict of str to float, or float
        The ratio of each channel named (measured data: the others are estimated from their
        high-frequency residual), or the study's one ratio.

    Raises
    ------
    OptionError
        A ratio that is not a number, an unknown channel, a channel or the plain ratio given twice, or a named
        channel in a study.

    Examples
    --------
    >>> noise_ratios(["0.01", "y=0.02"], ["u", "y"], study=False)
    {'u': 0.01, 'y': 0.02}
    >>> noise_ratios([], ["u", "y"], study=True)
    0.001
    """
    from obsnl._text import plain_float
    from obsnl.identification.structural import parse_assignments

    plain = [v for v in items if "=" not in v]
    named = [v for v in items if "=" in v]
    if len(plain) > 1:  # two levels for every channel: neither silently wins
        raise OptionError(
            f"{option} gives one RATIO for every channel twice ({', '.join(map(repr, plain))}); give it once"
        )
    try:
        every = plain_float(plain[0]) if plain else None
    except ValueError:
        raise OptionError(
            f"{option} {plain[0]!r} is not a number: give NAME=RATIO or one RATIO for every channel"
        ) from None
    ratios = {c: every for c in channels} if every is not None else {}
    ratios.update(parse_assignments(named, channels, option=option, what="model input or output"))
    if study:
        if named:
            raise OptionError(f"a simulation study takes one {option} RATIO for every channel")
        return STUDY_NOISE if every is None else every
    return ratios


def _flat(guess: Sequence[str | Sequence[str]]) -> tuple[str, ...]:
    """``--guess`` takes several P=V at once and may be repeated: a list of lists from the command line."""
    return tuple(g for item in guess for g in ([item] if isinstance(item, str) else item))


@dataclass(frozen=True, kw_only=True)
class IdentifyRequest:
    """One identification, checked and resolved when it is made (messages name the options as Python keywords,
    ``guess=``; the command line prints its flags for them).

    Parameters
    ----------
    model : Model, str or Path
        The model or its file (read once, after every check of the options).
    data, record : str or Path or None
        Exactly one: a measured CSV, or a record driving a simulation study of the model's ``[values]``.
    guess : sequence of str (or of sequences of str)
        ``NAME=VALUE`` guesses of parameters (over the model's ``[guess]``).
    noise : sequence of str
        Noise ratios as :func:`noise_ratios` reads them.
    method : {"ukf", "dukf"}
        The filter (the DUKF needs ``table``).
    table : BranchTable, str, Path or None
        The model's branch table.
    passes, replicates, seed : int
        Passes over the record, Monte-Carlo replicates (0: none), the seed.
    allow_unidentifiable, hold, refine : bool
        Run despite the structural verdict; hold poorly informed parameters at their guess; refine by maximum
        likelihood.
    tuning : Tuning or None
        A fixed tuning, or None to tune by the output misfit.
    s0, q_theta, q_x, gate : float or None
        A tuning given in part instead (:func:`tuning_from`: :data:`TUNING_DEFAULTS` for the others).
    samples : int or None
        Use only the first samples of the study's record.
    jit : bool or None
        Compile the filter and the likelihood fit to C (None: where a C compiler is found).
    intersample : str, mapping, sequence of str or None
        How measured inputs run between samples (None or empty: not given).
    objective : {"output", "prediction"}
        What the likelihood fit on measured data minimises.
    executor : Executor or None
        Where the profile likelihoods and the replicates run; one that names its workers or a scheduler is
        refused when nothing runs in parallel; its scheduler is probed when the request is made.
    progress : bool, callable or None
        A progress bar.
    out : str, Path or None
        A folder for the result's files (checked when the request is made).
    force : bool
        Overwrite those files.

    Raises
    ------
    OptionError
        An option that would be ignored or contradicts another, a bad guess or noise level, a scheduler that
        does not answer.
    OutputError
        An output folder that cannot take the files.
    """

    model: Model | str | Path
    data: str | Path | None = None
    record: str | Path | None = None
    guess: Sequence[str | Sequence[str]] = ()
    noise: Sequence[str] = ()
    method: str = "ukf"
    table: BranchTable | str | Path | None = None
    passes: int = 3
    replicates: int = 0
    seed: int = 0
    allow_unidentifiable: bool = False
    hold: bool = False
    refine: bool = True
    tuning: Tuning | None = None
    s0: float | None = None
    q_theta: float | None = None
    q_x: float | None = None
    gate: float | None = None
    samples: int | None = None
    jit: bool | None = None
    intersample: str | Mapping[str, str] | Sequence[str] | None = None
    objective: str = "output"
    executor: Executor | None = None
    progress: bool | Callable[[], Any] | None = True
    out: str | Path | None = None
    force: bool = False
    #: The identification checked and resolved (the model and the data or record read, the guesses and the noise
    #: levels parsed, the tuning made): what :func:`run_identify` runs.
    checked: CheckedIdentification = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        from obsnl.identification.identify import IDENTIFY_FILES, check_identify, check_study
        from obsnl.identification.structural import parse_assignments
        from obsnl.model.files import as_model

        data, intersample = self.data, self.intersample or None  # the command line's empty list: not given
        check_file_option(self.record, "record=")
        check_file_option(self.out, "out=", what="folder")
        if self.samples is not None and data:  # an option that would be ignored is refused, not dropped silently
            raise OptionError("samples= applies to a record= study; cut the data file instead")
        if intersample is not None and not data:
            raise OptionError(
                "intersample= applies to measured data= (a record= study simulates its input linearly "
                "between samples); drop it or identify from data="
            )
        if self.objective != "output" and not data:
            raise OptionError(
                "objective= applies to measured data= (a record= study's outputs carry measurement noise only, "
                "which the output error fits); drop it or identify from data="
            )
        ex = self.executor
        if (
            ex is not None
            and (ex.workers is not None or ex.scheduler is not None)
            and not (self.replicates or self.refine)
        ):
            raise OptionError(
                "workers= or scheduler= applies to the profile likelihoods and the Monte-Carlo replicates: "
                "drop refine=False or add replicates=N (nothing else of identify runs in parallel)"
            )
        if ex is not None:
            ex.probe()
        if self.tuning is not None and (self.s0, self.q_theta, self.q_x, self.gate) != (None,) * 4:
            raise OptionError("give tuning= or its parts (s0=, q_theta=, q_x=, gate=), not both")
        tuning = self.tuning if self.tuning is not None else tuning_from(self.s0, self.q_theta, self.q_x, self.gate)
        if self.out is not None:  # refused before any work: an output folder that cannot take the files (or empty)
            from obsnl.identification.engineering import FIGURES
            from obsnl.report.files import check_folder

            check_folder(self.out, IDENTIFY_FILES + FIGURES, force=self.force)  # every file a run may write
        model = as_model(self.model)  # a Model, or read from its file (anything else refused in one line)
        guesses = parse_assignments(
            list(_flat(self.guess)), [s.name for s in model.parameters], option="guess=", what="parameter"
        )
        channels = [s.name for s in model.inputs] + list(model.outputs)
        source = data if data else self.record
        if source is None:
            raise OptionError("give data= (a measured CSV) or record= (a record driving a simulation study)")
        common: dict[str, Any] = {  # what a measured identification and a simulation study take alike
            "guess": guesses,
            "method": self.method,
            "table": self.table,
            "passes": self.passes,
            "replicates": self.replicates,
            "seed": self.seed,
            "tuning": tuning,
            "allow_unidentifiable": self.allow_unidentifiable,
            "jit": self.jit,
            "hold": self.hold,
            "progress": self.progress,
            "executor": ex,
            "refine": self.refine,
        }
        if data:  # measured data: a level per channel named, the others estimated
            checked = check_identify(
                model,
                data,
                noise=noise_ratios(list(self.noise), channels, study=False, option="noise="),
                intersample=intersample,
                objective=self.objective,
                **common,
            )
        else:  # a simulation study: one level for every channel
            noise = noise_ratios(list(self.noise), channels, study=True, option="noise=")
            checked = check_study(model, source, noise=noise, samples=self.samples, **common)
        object.__setattr__(self, "checked", checked)


@dataclass(frozen=True)
class IdentifyResult:
    """What :func:`run_identify` returns: the identification and the files written (none without ``out``)."""

    identification: Identification
    files: tuple[Path, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """The identification's document and the files written."""
        return {"identification": self.identification.to_dict(), "files": [str(f) for f in self.files]}


def run_identify(request: IdentifyRequest) -> IdentifyResult:
    """Identify the request's model from its measured data or, as a simulation study, under its record.

    Parameters
    ----------
    request : IdentifyRequest
        The checked and resolved options.

    Returns
    -------
    IdentifyResult
        The identification and the files written in ``request.out``.
    """
    from obsnl.identification.identify import run_identification, write_identification

    res = run_identification(request.checked)
    files = write_identification(res, request.out, force=request.force) if request.out else []
    return IdentifyResult(res, tuple(files))


def identify_printed(result: IdentifyResult) -> Printed:
    """What ``obsnl identify`` prints: :func:`obsnl.report.identification.identify_text` of the run, then a line
    naming the files written.

    Parameters
    ----------
    result : IdentifyResult

    Returns
    -------
    Printed
    """
    from obsnl.report.identification import identify_text

    files = list(result.files)
    return Printed(identify_text(result.identification) + (f"\n{written_line(files)}" if files else ""))
