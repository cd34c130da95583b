"""The one runner of every subcommand: its parsed options to its library job, the job's text printed."""

from __future__ import annotations

import sys
from argparse import Namespace
from importlib import import_module
from pathlib import Path
from typing import Any

from obsnl.errors import AnalysisError


def _regenerating(folder: Path) -> None:
    print(f"obsnl reproduce: regenerating the default folder {folder} (committed results); pass --out DIR or "
          "--quick to keep them", file=sys.stderr)


def _opts(a: Namespace) -> dict[str, Any]:
    """The command's options as the library's keyword arguments (an option's ``dest`` is its keyword), the
    executor built from ``--workers``/``--scheduler`` (the job probes a scheduler before any work)."""
    opts = {k: v for k, v in vars(a).items() if k not in ("command", "job", "workers", "scheduler")}
    if "workers" in vars(a):
        from obsnl.executor import Executor
        opts["executor"] = Executor(scheduler=a.scheduler, workers=a.workers)
    return opts | ({"regenerating": _regenerating} if a.command == "reproduce" else {})


def run(a: Namespace) -> None:
    """Run the command's library job (``a.job``, ``module:function``) and print the text of the
    :class:`~obsnl.report.printed.Printed` it returns (a character UTF-8 cannot encode, a lone surrogate, as
    its escape); its undecided line is then said as an error, never passed over."""
    module, name = a.job.split(":")
    text, stuck = getattr(import_module(module), name)(**_opts(a))
    if text is not None:
        sys.stdout.write((text if text.endswith("\n") else text + "\n").encode("utf-8", "backslashreplace")
                         .decode("utf-8"))
    if stuck:
        raise AnalysisError(stuck)
