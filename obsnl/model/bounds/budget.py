"""One time budget for a whole command: reading the model, factoring its switching functions, splitting it
into branches, simulating a record and analysing.

``obsnl analyze --max-seconds S`` opens :func:`time_budget` before the model file is read; the steps
that can take long call :func:`check_time` between units of bounded work (one expression, one
factorization, one sign pattern, a block of simulated samples), and the analysis gets what is left
(:func:`remaining`). Outside a budget nothing is checked. A step that runs past the budget ends in one
:class:`~obsnl.errors.AnalysisError` line naming what it was doing and the fix.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar

from obsnl._text import quote
from obsnl.errors import AnalysisError, OptionError

__all__ = ["time_budget", "check_seconds", "check_time", "remaining", "deadline", "past_deadline"]

# (deadline on time.perf_counter, the seconds given): the innermost budget in force
_BUDGET: ContextVar[tuple[float, float] | None] = ContextVar("obsnl_time_budget", default=None)


def check_seconds(seconds: float | None) -> float | None:
    """A time limit: None (no limit) or a positive finite number of seconds.

    Parameters
    ----------
    seconds : float or None
        The limit asked for.

    Returns
    -------
    float or None
        ``seconds``, checked.

    Raises
    ------
    OptionError
        Anything else (NaN, infinity, zero, a negative number, not a number).

    Examples
    --------
    >>> check_seconds(2.5), check_seconds(None)
    (2.5, None)
    """
    if seconds is not None and (
        isinstance(seconds, bool)
        or not isinstance(seconds, (int, float))
        or not (math.isfinite(seconds) and seconds > 0)
    ):
        raise OptionError(f"max_seconds= must be a positive finite number of seconds, got {quote(seconds, 30)}")
    return seconds


@contextmanager
def time_budget(seconds: float | None) -> Iterator[None]:
    """Run the body within ``seconds`` (None: no limit); an outer, earlier deadline stays in force.

    Parameters
    ----------
    seconds : float or None
        The time limit, counted from now.

    Raises
    ------
    OptionError
        ``seconds`` is not a positive finite number.

    Examples
    --------
    >>> with time_budget(60):
    ...     0 < remaining() <= 60
    True
    >>> remaining() is None
    True
    """
    if seconds is None:
        yield
        return
    check_seconds(seconds)
    end = time.perf_counter() + float(seconds)
    outer = _BUDGET.get()
    token = _BUDGET.set(outer if outer is not None and outer[0] <= end else (end, float(seconds)))
    try:
        yield
    finally:
        _BUDGET.reset(token)


def deadline() -> float | None:
    """The deadline in force (on :func:`time.perf_counter`), or None."""
    b = _BUDGET.get()
    return None if b is None else b[0]


def remaining() -> float | None:
    """Seconds left of the budget in force (at least 1 ms), or None without a budget."""
    b = _BUDGET.get()
    return None if b is None else max(b[0] - time.perf_counter(), 1e-3)


def past_deadline() -> bool:
    """True when a budget is in force and spent."""
    b = _BUDGET.get()
    return b is not None and time.perf_counter() > b[0]


def check_time(what: str, fix: str = "raise max_seconds=") -> None:
    """Refuse to go on when the budget in force is spent.

    Parameters
    ----------
    what : str
        What was being done, naming the user's expression or file (``"factoring the switching function
        'x**9 - v**9'"``).
    fix : str
        What the user can do.

    Raises
    ------
    AnalysisError
        ``"<what> ran past the time limit of S s (max_seconds=); <fix>"``.

    Examples
    --------
    >>> with time_budget(1e-9):
    ...     check_time("reading 'm.toml'", "raise max_seconds=")
    Traceback (most recent call last):
    ...
    obsnl.errors.AnalysisError: reading 'm.toml' ran past the time limit of 1e-09 s (max_seconds=); raise max_seconds=
    """
    b = _BUDGET.get()
    if b is not None and time.perf_counter() > b[0]:
        raise AnalysisError(f"{what} ran past the time limit of {b[1]:g} s (max_seconds=); {fix}")
