"""``obsnl validate``: a fitted model run on a test record, as one request.

:class:`ValidateRequest` holds the options, typed; :func:`run_validate` runs
:func:`obsnl.identification.validation.job.validate_job` (the output folder checked before any work, the model read
once, the fit simulated under the test record's input, the files written); :func:`validate_printed` is what the command
prints: the validation's text, then the files written.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from obsnl.commands.inputs import check_file_option
from obsnl.report.printed import Printed, written_line

if TYPE_CHECKING:
    from obsnl.identification.validation.merit import Validation
    from obsnl.model.core import Model

__all__ = ["ValidateRequest", "ValidateResult", "run_validate", "validate_printed"]


@dataclass(frozen=True, kw_only=True)
class ValidateRequest:
    """One validation of a fit on a test record.

    Parameters
    ----------
    model : Model, str or Path
        The model or its file.
    params : str or Path
        The fit's ``identify.json`` (or its folder).
    data : str or Path
        The test record (CSV), a column per model input and output.
    warmup : int
        Samples that estimate the initial state and are not scored (0: from rest).
    intersample : sequence of str, str or None
        ``NAME=KIND`` texts, or one ``KIND`` for every input (None or empty: as the fit took them).
    out : str or Path
        The folder of ``validate.json`` and the figures.
    force : bool
        Overwrite those files.
    """

    model: Model | str | Path
    params: str | Path
    data: str | Path
    out: str | Path
    warmup: int = 0
    intersample: Sequence[str] | str | None = None
    force: bool = False

    def __post_init__(self) -> None:
        """Refuse, before any work, a test record or a folder that is not a file name (``out=3`` reached
        ``open``)."""
        check_file_option(self.data, "data=")
        check_file_option(self.out, "out=", what="folder")


@dataclass(frozen=True)
class ValidateResult:
    """What :func:`run_validate` returns: the validation, the folder and the files written in it."""

    validation: Validation
    out: str | Path
    files: tuple[Path, ...]

    def to_dict(self) -> dict[str, Any]:
        """The validation's document and the files written."""
        return {"validation": self.validation.to_dict(), "files": [str(f) for f in self.files]}


def run_validate(request: ValidateRequest) -> ValidateResult:
    """Validate the request's fit on its test record and write the files.

    Parameters
    ----------
    request : ValidateRequest

    Returns
    -------
    ValidateResult
    """
    from obsnl.identification.validation.job import validate_job

    validation, files = validate_job(
        request.model,
        params=request.params,
        data=request.data,
        warmup=request.warmup,
        intersample=request.intersample,
        out=request.out,
        force=request.force,
    )
    return ValidateResult(validation, request.out, tuple(files))


def validate_printed(result: ValidateResult) -> Printed:
    """What ``obsnl validate`` prints: :func:`obsnl.report.identification.validation.validate_text`, then the
    files written.

    Parameters
    ----------
    result : ValidateResult

    Returns
    -------
    Printed
    """
    from obsnl.report.identification.validation import validate_text

    return Printed(validate_text(result.validation) + "\n" + written_line(list(result.files), result.out))
