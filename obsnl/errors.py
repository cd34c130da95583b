"""The obsnl error family.

Every error raised for bad user input is an :class:`ObsnlError`; each subclass also
derives from the matching built-in exception so that ``except ValueError`` keeps working.
Messages name the culprit and the fix, and an option by its Python keyword (``max_seconds=``,
``allow_unidentifiable=True``): :func:`in_terms` renames those for an interface with other names (the command
line's flags).
"""

from __future__ import annotations

import os
import re
import reprlib
from collections.abc import Mapping

__all__ = [
    "ObsnlError",
    "ModelError",
    "ParseError",
    "NotSupportedError",
    "AnalysisError",
    "DataError",
    "TableError",
    "EstimatorError",
    "CompileError",
    "OptionError",
    "OutputError",
    "ExecutorError",
    "in_terms",
    "refuse_non_path",
]


class ObsnlError(Exception):
    """Base class of every error obsnl raises on purpose (never raised itself: each error is one of the
    subclasses below, which also derive from the built-in they refine)."""


class ModelError(ObsnlError, ValueError):
    """The model is inconsistent: undeclared symbol, a name in two roles, a missing equation, ..."""


class ParseError(ModelError):
    """A model file or an expression could not be read (syntax, unsupported function, bad key)."""


class NotSupportedError(ObsnlError, NotImplementedError):
    """The request is well formed but outside what obsnl can do; the message says what instead."""


class AnalysisError(ObsnlError, ValueError):
    """An analysis cannot run on this model (no outputs, nothing to analyse, ...)."""


class DataError(ObsnlError, ValueError):
    """Measured data is unusable: NaN/inf, irregular time step, wrong shapes."""


class TableError(ObsnlError, ValueError):
    """A branch table (JSON) is corrupt, fails its schema, or does not match the model."""


class EstimatorError(ObsnlError, RuntimeError):
    """A filter cannot continue: a covariance stopped being positive definite, a NaN appeared."""


class CompileError(ObsnlError, RuntimeError):
    """Code could not be compiled to C and loaded: no C compiler, a compiler error or one that does not finish
    in time, a cache folder that cannot be written, a library that does not load. A run that did not ask for
    compilation goes on uncompiled. Not an :class:`EstimatorError`: a filter or simulation that fails is read as
    a point far from the data, a failed compilation never is."""


class OptionError(ObsnlError, ValueError):
    """An option or argument has a value obsnl does not accept (unknown format, replicates 2, ...)."""


class OutputError(ObsnlError, OSError):
    """Output cannot be written as asked: the file exists (pass ``--force``), a name is not a plain file
    name, a path would leave the folder the user named, a symlink would be followed."""


class ExecutorError(ObsnlError, RuntimeError):
    """Parallel work cannot finish: a worker process died (the message names its task), or a Dask cluster has no
    worker or its scheduler stopped answering within the deadline. The message says what to do instead."""


#: An option as messages name it: a Python keyword ``name=`` with an optional value (``True``, ``False``, a
#: quoted word or any other text that follows without a space).
_KEYWORD = re.compile(r"(?<![\w.'\"-])([a-z][a-z0-9_]*)=(?:(True|False)\b|'([^'\s]*)')?")


def in_terms(message: str, names: Mapping[str, tuple[str, bool | None]]) -> str:
    """``message`` with each option it names as a Python keyword renamed as another interface names it.

    Parameters
    ----------
    message : str
        A message, naming options as Python keywords (``allow_unidentifiable=True``, ``max_seconds=``,
        ``s0=0.1``, ``method='dukf'``, ``refine=False``).
    names : mapping of str to (str, bool or None)
        Each keyword's name in the interface (``--max-seconds``) and, for a switch (given without a value),
        the value it sets (``--no-refine`` sets ``refine`` to False); None for an option with a value.

    Returns
    -------
    str
        ``name=VALUE`` of a switch as its name when the switch sets VALUE, as the ``no_NAME`` switch that
        sets True, else as "without" the switch; ``name=VALUE`` of another option as ``NAME VALUE``,
        ``name=`` as ``NAME``; keywords not in ``names`` unchanged.

    Examples
    --------
    >>> in_terms("pass allow_unidentifiable=True, refine=False or raise max_seconds= (k=2 stays)",
    ...          {"allow_unidentifiable": ("--allow-unidentifiable", True), "refine": ("--no-refine", False),
    ...           "max_seconds": ("--max-seconds", None)})
    'pass --allow-unidentifiable, --no-refine or raise --max-seconds (k=2 stays)'
    """

    def rename(m: re.Match) -> str:
        name, switch, word = m.group(1), m.group(2), m.group(3)
        if switch == "False" and names.get(f"no_{name}", ("", None))[1] is True:
            return names[f"no_{name}"][0]
        if name not in names:
            return m.group(0)
        option, sets = names[name]
        if switch and sets is not None:
            return option if switch == str(sets) else f"without {option}"
        value = word if word is not None else (switch or "")
        follows = message[m.end() : m.end() + 1]
        if not value and follows and not follows.isspace() and follows not in ",;:.)]`":
            return f"{option} "  # name=3 -> --name 3
        return f"{option} {value}" if value else option

    return _KEYWORD.sub(rename, message)


def refuse_non_path(value: object, what: str) -> None:
    """Refuse a file argument that is neither text nor a path, in one line (``open(3)`` raises a TypeError, or reads
    file descriptor 3).

    Parameters
    ----------
    value : object
        The argument.
    what : str
        What takes it, for the message (``"read_record takes the path of a record file"``, ``"record= takes a file
        name"``); the message goes on with ``(text or a path), got KIND VALUE``.

    Raises
    ------
    OptionError
        ``value`` of another kind.

    Examples
    --------
    >>> refuse_non_path("r.csv", "read_record takes the path of a record file") is None
    True
    >>> refuse_non_path(3, "record= takes a file name")
    Traceback (most recent call last):
    ...
    obsnl.errors.OptionError: record= takes a file name (text or a path), got int 3
    """
    if not isinstance(value, (str, os.PathLike)):  # reprlib: a huge value is echoed cut (the ground floor's own)
        raise OptionError(f"{what} (text or a path), got {type(value).__name__} {reprlib.repr(value)}")
