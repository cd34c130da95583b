"""What the commands share: the one-line exit, the bounded option types and actions, the one line of an
operating system's refusal, writing output."""

from __future__ import annotations

import argparse
import errno
import math
import re
import sys
from typing import Any

from obsnl._text import quote, shorten

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


def _real(low: float, high: float, what: str) -> Any:
    """An argparse type: a number strictly between ``low`` and ``high`` (so never NaN, and finite when ``high``
    is infinite), refused at parse time with the text shortened (argparse's own message echoes it whole)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not low < value < high:
            raise argparse.ArgumentTypeError(f"{quote(text, 40)} is not {what}")
        return value

    parse.__name__ = what
    return parse


_seconds = _real(0.0, math.inf, "a positive finite number of seconds")  # every command's --max-seconds
_noise = _real(0.0, 10.0, "a relative noise level above 0 and below 10 (0.01 is 1 %)")


def _given(parser: argparse.ArgumentParser, values: Any, option: str | None) -> Any:
    """``values``, or a usage error when Python 3.11's argparse turned ``--opt=--`` into ``[]`` (past the
    option's type and choices)."""
    if isinstance(values, list) and not values:
        parser.error(f"argument {option}: expected one value, got '--' (a value that starts with '-' is written "
                     f"{option}=VALUE)")
    return values


class _One(argparse.Action):
    """``store`` for a single-valued option, with the check of :func:`_given`."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any,
                 option_string: str | None = None) -> None:
        setattr(namespace, self.dest, _given(parser, values, option_string))


class _More(argparse.Action):
    """``append`` for a repeatable option, with the check of :func:`_given`."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any,
                 option_string: str | None = None) -> None:
        items = list(getattr(namespace, self.dest, None) or [])
        setattr(namespace, self.dest, [*items, _given(parser, values, option_string)])


class _Parser(argparse.ArgumentParser):
    """argparse's parser, whose usage errors never echo a value whole (an invalid choice, an argument it does
    not know): a message over 300 characters keeps its start and its end (where the choices are)."""

    def error(self, message: str) -> Any:  # argparse exits here (code 2)
        if len(message) > 300:
            message = f"{message[:200]} ... {message[-80:]}"
        super().error(message)


#: What to do about the system's refusals that a user can fix (else: check the path).
_OS_FIXES = {errno.ENAMETOOLONG: "use a file name of at most 255 bytes", errno.ENOSPC: "free some space or write "
             "elsewhere", errno.EROFS: "write to a writable file system", errno.EACCES: "choose a path you may use",
             errno.EPERM: "choose a path you may use", errno.EISDIR: "name a file, not a folder",
             errno.ENOTDIR: "a part of the path is a file, not a folder"}


def _os_error(exc: OSError) -> str:
    """The one line of the command line's error for a refusal of the operating system: the path (shortened),
    the system's reason and the fix."""
    where = f" {quote(str(exc.filename), 100)}" if exc.filename is not None else ""
    why = exc.strerror or shorten(str(exc) or type(exc).__name__, 200)
    return f"cannot use{where}: {why}; {_OS_FIXES.get(exc.errno or 0, 'check the path')}"


def _write(text: str, out: str | None = None, *, force: bool = False) -> None:
    """Print ``text`` (out None or ``-``) or write it to the file ``out`` through
    :func:`obsnl.report.files.safe_write`: never over a file without ``force``, never through a symlink."""
    text = text if text.endswith("\n") else text + "\n"
    if out is None or out == "-":
        sys.stdout.write(text.encode("utf-8", "backslashreplace").decode("utf-8"))
    else:
        from obsnl.report.files import safe_write

        safe_write(out, text, force=force)


#: A Python keyword as library messages write it: ``name=`` with an optional value (``True``, ``False``, a
#: quoted word or any other text that follows without a space).
_KEYWORD = re.compile(r"(?<![\w.'\"-])([a-z][a-z0-9_]*)=(?:(True|False)\b|'([^'\s]*)')?")


def _flags(parser: argparse.ArgumentParser) -> dict[str, tuple[str, bool]]:
    """Each option's ``dest`` to its long flag and whether it is a switch (``store_true``), read off the parser."""
    return {a.dest: (a.option_strings[-1], a.nargs == 0) for a in parser._actions
            if a.option_strings and a.option_strings[-1].startswith("--")}


def cli_terms(message: str, parser: argparse.ArgumentParser) -> str:
    """A library message in command-line terms: each Python keyword the parser has as an option becomes its flag.

    Parameters
    ----------
    message : str
        The message, naming options as Python keywords (``allow_unidentifiable=True``, ``max_seconds=``,
        ``s0=0.1``, ``method='dukf'``, ``refine=False``).
    parser : argparse.ArgumentParser
        The subcommand's parser: its actions map each ``dest`` to its flag, so no table can drift.

    Returns
    -------
    str
        ``name=True`` of a switch as its flag alone, ``name=False`` as the ``--no-`` switch or "without"
        the switch, ``name=VALUE`` as ``--flag VALUE``, ``name=`` as ``--flag``; other words unchanged.

    Examples
    --------
    >>> p = argparse.ArgumentParser()
    >>> _ = p.add_argument("--allow-unidentifiable", action="store_true")
    >>> _ = p.add_argument("--max-seconds", type=float)
    >>> cli_terms("pass allow_unidentifiable=True or raise max_seconds= (k=2 stays)", p)
    'pass --allow-unidentifiable or raise --max-seconds (k=2 stays)'
    """
    flags = _flags(parser)

    def flag(m: re.Match) -> str:
        name, switch, word = m.group(1), m.group(2), m.group(3)
        if switch == "False" and flags.get(f"no_{name}", ("", False))[1]:
            return flags[f"no_{name}"][0]
        if name not in flags:
            return m.group(0)
        option, is_switch = flags[name]
        if switch and is_switch:
            return option if switch == "True" else f"without {option}"
        value = word if word is not None else (switch or "")
        follows = message[m.end():m.end() + 1]
        if not value and follows and not follows.isspace() and follows not in ",;:.)]`":
            return f"{option} "  # name=3 -> --name 3
        return f"{option} {value}" if value else option

    return _KEYWORD.sub(flag, message)
