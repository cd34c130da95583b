"""What every command of the command line shares: the one-line exit, option types, model loading,
writing output (never over a file without ``--force``), progress bars and the executor options."""

from __future__ import annotations

import argparse
import sys
from typing import Any


__all__ = ["write_output"]


class _Exit(Exception):
    def __init__(self, code: int, message: str = "") -> None:
        super().__init__(message)
        self.code = code
        self.message = message


def _at_least(low: int) -> Any:
    """An argparse type: a whole number ``>= low``, refused at parse time (before any work or bar starts)."""

    def parse(text: str) -> int:
        value = int(text) if text.strip().lstrip("-").isdigit() else None
        if value is None or value < low:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer >= {low}")
        return value

    parse.__name__ = f"integer >= {low}"
    return parse


#: ``--seed``: a non-negative integer (numpy's generators refuse negative seeds).
_seed = _at_least(0)


def _load(path: str):
    from obsnl.model.files import load_model

    return load_model(path)


def write_output(text: str, out: str | None, *, force: bool) -> None:
    """Print ``text`` or write it to ``out``; never overwrite an existing file without ``force``.

    The file goes through the one output writer (:func:`obsnl.report.files.safe_write`): created
    exclusively and moved onto ``out`` atomically, so with ``force`` a symlink or a hard-linked file
    there is replaced by a new file, never written through or truncated in place.

    Parameters
    ----------
    text : str
        The text (a final newline is added).
    out : str or None
        The file, or None / ``"-"`` for standard output.
    force : bool
        Overwrite an existing file.

    Raises
    ------
    OutputError
        When the file exists without ``force`` or cannot be written.
    """
    from obsnl.report.files import safe_write

    text = text if text.endswith("\n") else text + "\n"
    if out is None or out == "-":
        sys.stdout.write(text.encode("utf-8", "backslashreplace").decode("utf-8"))
        return
    safe_write(out, text, force=force)  # refuses symlinks, folders, a parent that is a file


def _progress(desc: str, total: int | None, unit: str) -> Any:
    """A progress bar on stderr (tqdm), or None when tqdm is missing."""
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover
        return None
    return tqdm(desc=desc, total=total, unit=unit, file=sys.stderr)


def _add_executor(p: argparse.ArgumentParser, workers: int | None = None) -> None:
    p.add_argument("--workers", type=_at_least(1), default=workers,
                   help=f"local processes (default: {workers or 'one per core'}; 1: none)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS", help="a Dask cluster instead (tcp://host:8786)")


def _executor(args: argparse.Namespace) -> Any:
    """The executor of ``--workers``/``--scheduler``; a scheduler nothing answers on is refused here, before any work."""
    from obsnl.executor import Executor

    return Executor(scheduler=args.scheduler, workers=args.workers).probe()


