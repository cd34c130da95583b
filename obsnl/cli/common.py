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


def _at_least(low: int, at_most: int | None = None, why: str = "") -> Any:
    """An argparse type: a whole number ``>= low`` (and ``<= at_most`` when given, ``why`` saying why),
    refused at parse time (before any work or bar starts)."""

    def parse(text: str) -> int:
        digits = text.strip().lstrip("-")
        if at_most is not None and digits.isdigit() and not text.strip().startswith("-") and len(digits) > 20:
            value = at_most + 1  # not converted: Python refuses integers of over 4300 digits
        else:
            value = int(text) if digits.isdigit() and len(digits) < 4000 else None
        if value is None or value < low:
            raise argparse.ArgumentTypeError(f"{text[:30]!r} is not an integer >= {low}")
        if at_most is not None and value > at_most:
            raise argparse.ArgumentTypeError(f"{text.strip()[:30]} is more than {at_most}{': ' + why if why else ''}")
        return value

    parse.__name__ = f"integer >= {low}" if at_most is None else f"integer from {low} to {at_most}"
    return parse


#: Most Monte-Carlo replicates of ``identify`` and ``reproduce`` (100 000 000 ended in a MemoryError after 13 s).
MAX_REPLICATES = 10_000
#: Most passes over the record of ``identify`` and ``reproduce``.
MAX_PASSES = 100
#: ``--replicates``: 0 (off) to :data:`MAX_REPLICATES` (1 and 2 are refused by ``check_replicates``).
_replicates = _at_least(0, MAX_REPLICATES, "each replicate is one more filter run whose results are kept in memory; "
                                          "a few hundred give a Monte-Carlo interval")
#: ``--passes``: 1 to :data:`MAX_PASSES`.
_passes = _at_least(1, MAX_PASSES, "each pass is one more filter run over the whole record; the estimates settle "
                                   "within a few passes")

#: ``--seed``: a non-negative integer (numpy's generators refuse negative seeds).
_seed = _at_least(0)


def _load(path: str, check: Any = None):
    """The model file at ``path``; ``check`` sees the file's raw keys before any expression is parsed."""
    from obsnl.model.files import read_model

    return read_model(path, check=check)


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


def _one_input_record(model: Any, path: str) -> Any:
    """The record at ``path`` as the one known input of ``model`` (``--record`` of analyze, sensors and design)."""
    from obsnl.estimation.records import read_record

    if len(model.inputs) != 1:
        raise _Exit(2, f"--record drives one input, model {model.name!r} has {len(model.inputs)}; give a model with "
                    "one known input")
    return read_record(path)


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


