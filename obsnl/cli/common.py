"""What the commands share: the one-line exit, the bounded option types, writing output."""

from __future__ import annotations

import argparse
import sys
from typing import Any

__all__: list[str] = []


class _Exit(Exception):
    def __init__(self, code: int, message: str = "") -> None:
        super().__init__(message)
        self.code, self.message = code, message


def _at_least(low: int, at_most: int | None = None, why: str = "") -> Any:
    """An argparse type: a whole number ``>= low`` (and ``<= at_most``, ``why`` saying why), refused at parse time."""

    def parse(text: str) -> int:
        digits, negative = text.strip().lstrip("-"), text.strip().startswith("-")
        if at_most is not None and digits.isdigit() and not negative and len(digits) > 20:
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


MAX_REPLICATES, MAX_PASSES = 10_000, 100  # of identify and reproduce (1e8 replicates: a MemoryError after 13 s)
_replicates = _at_least(0, MAX_REPLICATES, "each replicate is one more filter run whose results are kept in memory; "
                                          "a few hundred give a Monte-Carlo interval")
_passes = _at_least(1, MAX_PASSES, "each pass is one more filter run over the whole record; the estimates settle "
                                   "within a few passes")
_seed = _at_least(0)  # numpy's generators refuse negative seeds


def _scales(text: str) -> list[float]:
    """An argparse type: comma-separated positive numbers."""
    try:
        values = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        values = []
    if not values or not all(0 < v < float("inf") for v in values):
        raise argparse.ArgumentTypeError(f"{text[:30]!r} is not a list of positive numbers such as 0.1,1,10")
    return values


def _write(text: str, out: str | None = None, *, force: bool = False) -> None:
    """Print ``text`` (out None or ``-``) or write it to the file ``out`` through
    :func:`obsnl.report.files.safe_write`: never over a file without ``force``, never through a symlink."""
    text = text if text.endswith("\n") else text + "\n"
    if out is None or out == "-":
        sys.stdout.write(text.encode("utf-8", "backslashreplace").decode("utf-8"))
    else:
        from obsnl.report.files import safe_write

        safe_write(out, text, force=force)
