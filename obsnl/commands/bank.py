"""``obsnl bank``: the observer-bank benchmark on the cantilever link into a folder, as one request.

:class:`BankRequest` reads the link model and checks its ``[bank]`` table and the output folder when it is
made; :func:`run_bank` runs :func:`obsnl.studies.link_study.run_link_study` and writes the report (all files or none);
:func:`bank_printed` is what the command prints.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from obsnl.commands.inputs import check_file_option
from obsnl.report.printed import Printed

if TYPE_CHECKING:
    from obsnl.studies.link_model import LinkSpec

__all__ = ["BankRequest", "BankResult", "run_bank", "bank_printed"]


@dataclass(frozen=True, kw_only=True)
class BankRequest:
    """One observer-bank benchmark, checked when it is made.

    Parameters
    ----------
    out : str or Path
        The output folder.
    model : str, Path or None
        The link model file (default: the packaged cantilever link).
    seeds : int
        Noise seeds per scenario (thresholds use as many other seeds).
    force : bool
        Overwrite existing files.

    Raises
    ------
    ModelError, OptionError
        A bad link model or ``[bank]`` table.
    OutputError
        A folder that cannot take the files.
    """

    out: str | Path
    model: str | Path | None = None
    seeds: int = 3
    force: bool = False
    #: The link model read and checked: what :func:`run_bank` uses.
    spec: LinkSpec = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        from obsnl.report.bank import check_bank_output
        from obsnl.studies.link_model import read_link_spec
        from obsnl.studies.link_study import check_bank_settings

        check_file_option(self.out, "out=", what="folder")
        check_file_option(self.model, "model=")
        spec = read_link_spec(self.model)  # the model file and its [bank] table are checked before any work
        scenarios = ["healthy"] + [f"crack{c}" for c in check_bank_settings(spec).crack_elements]
        check_bank_output(self.out, scenarios, force=self.force)
        object.__setattr__(self, "spec", spec)


@dataclass(frozen=True)
class BankResult:
    """What :func:`run_bank` returns: the files written (``bank.md``, ``bank.json``, then the force plots)."""

    files: tuple[Path, ...]

    def to_dict(self) -> dict[str, Any]:
        """The files, as text."""
        return {"files": [str(f) for f in self.files]}


def run_bank(request: BankRequest) -> BankResult:
    """Run the benchmark and write its report into ``request.out``.

    Parameters
    ----------
    request : BankRequest

    Returns
    -------
    BankResult
    """
    from obsnl.report.bank import write_bank_report
    from obsnl.studies.link_study import run_link_study

    study = run_link_study(seeds=request.seeds, spec=request.spec)
    return BankResult(tuple(write_bank_report(study, request.out, force=request.force)))


def bank_printed(result: BankResult) -> Printed:
    """What ``obsnl bank`` prints: :func:`obsnl.report.bank.bank_written_line` of the files.

    Parameters
    ----------
    result : BankResult

    Returns
    -------
    Printed
    """
    from obsnl.report.bank import bank_written_line

    return Printed(bank_written_line(list(result.files)))
