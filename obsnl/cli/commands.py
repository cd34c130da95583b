"""The one runner of every subcommand: its parsed options to its library job, the job's text printed.

Each command's job is imported plainly in :func:`job_of` (one ``case`` per command), so that a reader and every tool
can follow a command from the command line into the library; nothing is imported by a computed name."""

from __future__ import annotations

import sys
from argparse import Namespace
from collections.abc import Callable
from pathlib import Path
from typing import Any

from obsnl.errors import AnalysisError


def _regenerating(folder: Path) -> None:
    print(
        f"obsnl reproduce: regenerating the default folder {folder} (committed results); pass --out DIR or "
        "--quick to keep them",
        file=sys.stderr,
    )


def _opts(a: Namespace) -> dict[str, Any]:
    """The command's options as the library's keyword arguments (an option's ``dest`` is its keyword), the
    executor built from ``--workers``/``--scheduler`` (the job probes a scheduler before any work)."""
    opts = {k: v for k, v in vars(a).items() if k not in ("command", "workers", "scheduler")}
    if "workers" in vars(a):
        from obsnl.executor import Executor

        opts["executor"] = Executor(scheduler=a.scheduler, workers=a.workers)
    return opts | ({"regenerating": _regenerating} if a.command == "reproduce" else {})


def job_of(command: str) -> Callable[..., Any]:
    """The library job of ``command``: a function that takes the command's options as keywords and returns what the
    command prints (:class:`~obsnl.report.printed.Printed`). Imported here, on first use: ``obsnl --help`` loads no
    numeric library.

    Parameters
    ----------
    command : str
        The subcommand's name.

    Returns
    -------
    callable

    Raises
    ------
    KeyError
        For a command that has no job (a programming error: the parser knows every command).
    """
    job: Callable[..., Any]  # each command's job takes its own options
    match command:
        case "show":
            from obsnl.design.jobs import show_printed as job
        case "branches":
            from obsnl.design.jobs import branches_printed as job
        case "analyze":
            from obsnl.design.jobs import analyze_printed as job
        case "report":
            from obsnl.batch import report_printed as job
        case "symmetries":
            from obsnl.design.jobs import symmetries_printed as job
        case "reparametrize":
            from obsnl.studies.jobs import reparametrize_printed as job
        case "identify":
            from obsnl.studies.jobs import identify_printed as job
        case "reproduce":
            from obsnl.studies.jobs import reproduce_printed as job
        case "bank":
            from obsnl.studies.jobs import bank_printed as job
        case "sensors":
            from obsnl.design.jobs import sensors_printed as job
        case "design":
            from obsnl.design.jobs import design_printed as job
        case "validate":
            from obsnl.identification.validation.job import validate_printed as job
        case _:
            raise KeyError(f"no job for the command {command!r}")
    return job


def run(a: Namespace) -> None:
    """Run the command's library job (:func:`job_of`) and print the text of the
    :class:`~obsnl.report.printed.Printed` it returns (a character UTF-8 cannot encode, a lone surrogate, as
    its escape); its undecided line is then said as an error, never passed over."""
    text, stuck = job_of(a.command)(**_opts(a))
    if text is not None:
        sys.stdout.write(
            (text if text.endswith("\n") else text + "\n").encode("utf-8", "backslashreplace").decode("utf-8")
        )
    if stuck:
        raise AnalysisError(stuck)
