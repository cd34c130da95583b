"""Plain text shared by the one-line ``repr`` and the short ``summary()`` of every result value.

Echoed values cut (:func:`quote`, :func:`shorten`: the one place every error message shortens what the user
gave), the one line of an operating system's refusal (:func:`os_error_line`), name lists cut to a few,
numbers short, a probability bound that never rounds a near-certainty up to 1, the joint verdict in words, and
the one reading of a number a user typed (:func:`plain_float`).
Rank 0: it imports nothing of obsnl, so the result values of every room may use it; documents (Markdown,
LaTeX, JSON, figures) are rendered in :mod:`obsnl.report`.
"""

from __future__ import annotations

import errno
from collections.abc import Callable, Iterable, Sequence
from typing import TypeVar

__all__ = [
    "WIDTH",
    "LINES",
    "SHOWN",
    "shorten",
    "quote",
    "quoted",
    "names",
    "number",
    "numbers",
    "probability_text",
    "plain_float",
    "bound",
    "json_end",
    "one_line",
    "block",
    "verdict_words",
    "os_error_line",
]

#: Characters of a one-line ``repr`` at most.
WIDTH = 160
#: Lines of a ``summary()`` at most.
LINES = 12
#: Characters of a value a message echoes at most (a name, an expression, a path, an option's value).
SHOWN = 80


def shorten(text: str, limit: int = SHOWN) -> str:
    """``text`` cut to ``limit`` characters (with ``...``) for an error message: every message that echoes
    what the user gave (a name, an expression, a path, an option's value) cuts it here, never whole.

    Parameters
    ----------
    text : str
        The text to show.
    limit : int
        Largest length of the result.

    Returns
    -------
    str

    Examples
    --------
    >>> shorten("x + " * 30, 20)
    'x + x + x + x + x...'
    """
    text = text.strip()
    return text if len(text) <= limit else text[: limit - 3].rstrip() + "..."


def quote(value: object, limit: int = SHOWN) -> str:
    """``repr(value)`` cut to ``limit`` characters: how a message echoes what the user wrote.

    Parameters
    ----------
    value : object
        What the user wrote (a name, a value of a table).
    limit : int
        Largest length of the result.

    Returns
    -------
    str

    Examples
    --------
    >>> quote("z" * 100, 12)
    "'zzzzzzzz..."
    """
    if isinstance(value, str) and len(value) > limit:  # the same cut, without writing out a huge value first
        value = value[:limit]
    return shorten(repr(value), limit)


_Item = TypeVar("_Item")


def names(items: Iterable[_Item], most: int | None = None, *, name: Callable[[_Item], str] = str) -> str:
    """Names joined by commas, ``"none"`` for none, cut after ``most`` with the number left out.

    Parameters
    ----------
    items : iterable
        The names (or any values ``name`` writes).
    most : int or None
        Names shown at most (None: all).
    name : callable
        How one name is written (e.g. as LaTeX; default ``str``).

    Returns
    -------
    str

    Examples
    --------
    >>> names(["x", "v", "c"]), names([]), names("abcdefgh", 3)
    ('x, v, c', 'none', 'a, b, c, ... (+5 more)')
    """
    items = list(items)
    if not items:
        return "none"
    shown = items if most is None or len(items) <= most else items[:most]
    text = ", ".join(name(n) for n in shown)
    return text if len(shown) == len(items) else f"{text}, ... (+{len(items) - len(shown)} more)"


def quoted(items: Iterable[object], most: int = 8) -> str:
    """Values a message echoes, in brackets: each by :func:`quote`, cut after ``most`` (a list of names
    read from a file may hold any number of names of any length).

    Parameters
    ----------
    items : iterable
        The values (names read from a file, mostly).
    most : int
        Values shown at most.

    Returns
    -------
    str

    Examples
    --------
    >>> quoted(["x", "v"]), quoted(["z" * 100, "y", "w"], 2), quoted(n for n in "ab"), quoted(())
    ("['x', 'v']", "['zzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzz..., 'y', ... (+1 more)]", "['a', 'b']", '[]')
    """
    items = list(items)  # once: a generator is read a single time
    return f"[{names(items, most, name=quote)}]" if items else "[]"


def number(x: float | complex | None) -> str:
    """A number in four significant digits (``"n/a"`` for None, NaN or infinity kept as text; a complex
    number with an imaginary part as ``a+bj``).

    Examples
    --------
    >>> number(0.30012), number(None), number(float("nan")), number(12345678.0), number(-1 + 2j), number(3 + 0j)
    ('0.3001', 'n/a', 'nan', '1.235e+07', '-1+2j', '3')
    """
    if x is None:
        return "n/a"
    imag = getattr(x, "imag", 0)  # a numpy number has one too
    if isinstance(x, complex) or imag:
        z = complex(x)
        return f"{z.real:.4g}{z.imag:+.4g}j" if z.imag else f"{z.real:.4g}"
    return f"{float(x):.4g}"


def plain_float(text: str) -> float:
    """``float(text)`` for a number typed in plain digits (an option, ``NAME=VALUE``).

    Python's ``float`` also reads digit separators, ``1_0`` as 10, where a record cell refuses them: refused here
    too, so one spelling reads alike everywhere.

    Raises
    ------
    ValueError
        Not a number, or one written with ``_``.

    Examples
    --------
    >>> plain_float(" 2.5e-3 "), plain_float("10")
    (0.0025, 10.0)
    >>> plain_float("1_0")
    Traceback (most recent call last):
    ...
    ValueError: '1_0' is written with '_'
    """
    if "_" in text:
        raise ValueError(f"{text!r} is written with '_'")
    return float(text)


def numbers(values: Iterable[float], most: int = 6) -> str:
    """Numbers in brackets, each by :func:`number`, cut after ``most``.

    Parameters
    ----------
    values : iterable of float
        The numbers.
    most : int
        Numbers shown at most.

    Returns
    -------
    str

    Examples
    --------
    >>> numbers([1.0, 2.5, 1 / 3]), numbers(range(10), 2)
    ('[1, 2.5, 0.3333]', '[0, 1, ... (+8 more)]')
    """
    return f"[{names([number(v) for v in values], most)}]".replace("[none]", "[]")


def probability_text(p: float | None) -> str:
    """A probability bound as text that does not round a near-certainty up to 1.

    Examples
    --------
    >>> probability_text(1.0), probability_text(1 - 3.7e-15), probability_text(0.95), probability_text(None)
    ('1 (certified)', '1 - 3.7e-15', '0.95', 'deterministic')
    """
    if p is None:
        return "deterministic"
    if p >= 1.0:
        return "1 (certified)"
    if p > 0.999:
        return f"1 - {1.0 - p:.1e}"
    return f"{p:.4g}"


def bound(p: float | None) -> str:
    """The bound of :func:`probability_text` in a ``repr``: no spaces, ``P>=`` in front.

    Examples
    --------
    >>> bound(1 - 3.7e-15), bound(1.0), bound(None)
    ('P>=1-3.7e-15', 'P=1', 'deterministic')
    """
    if p is None:
        return "deterministic"
    return "P=1" if p >= 1.0 else "P>=" + probability_text(p).replace(" ", "")


def json_end(x: float) -> float | str:
    """An end of a bound as a JSON document or a model file holds it: the number, or ``"inf"``/``"-inf"`` (JSON has
    no infinity).

    Examples
    --------
    >>> json_end(0.5), json_end(float("inf")), json_end(float("-inf"))
    (0.5, 'inf', '-inf')
    """
    return x if x == x and abs(x) != float("inf") else ("inf" if x > 0 else "-inf")


def one_line(kind: str, *parts: str, width: int = WIDTH) -> str:
    """``kind(part, part, ...)`` on one line of at most ``width`` characters (cut with ``...)``).

    Parameters
    ----------
    kind : str
        The class name.
    *parts : str
        The headline fields, written (empty ones are left out).
    width : int
        Characters at most.

    Returns
    -------
    str

    Examples
    --------
    >>> one_line("Fit", "converged", "", "chi2=1.5")
    'Fit(converged, chi2=1.5)'
    >>> len(one_line("Fit", "x" * 500))
    160
    """
    text = " ".join(f"{kind}({', '.join(p for p in parts if p)})".split())
    return text if len(text) <= width else text[: width - 4] + "...)"


def block(*lines: str, most: int = LINES, width: int = WIDTH) -> str:
    """Lines of plain text (empty ones left out), at most ``most`` of them and ``width`` characters each.

    Parameters
    ----------
    *lines : str
        The lines, the answer first.
    most : int
        Lines at most; beyond, the last line says how many were left out.
    width : int
        Characters of a line at most (cut with ``...``).

    Returns
    -------
    str
        The lines, ending with a newline.

    Examples
    --------
    >>> print(block("m: observable", "", "2 branches"), end="")
    m: observable
    2 branches
    >>> block(*"abcde", most=3).splitlines()
    ['a', 'b', '... (+3 more lines)']
    """
    kept = [" ".join(line.split()) for line in lines if line]
    if len(kept) > most:
        kept = kept[: most - 1] + [f"... (+{len(kept) - most + 1} more lines)"]
    return "".join((k if len(k) <= width else k[: width - 3] + "...") + "\n" for k in kept)


def verdict_words(
    observable: Sequence[str],
    unobservable: Sequence[str],
    undecided: Sequence[str],
    *,
    most: int | None = None,
    name: Callable[[str], str] = str,
) -> str:
    """The joint verdict in words, the answer a user needs first.

    Parameters
    ----------
    observable, unobservable, undecided : sequence of str
        Jointly identifiable (observable) states and parameters, those that are not, those not decided.
    most : int or None
        Names shown per list at most (None: all).
    name : callable
        How one name is written (e.g. as LaTeX).

    Returns
    -------
    str
        ``"jointly identifiable: all"`` when nothing is unidentifiable or undecided, else
        ``"jointly identifiable: ...; not identifiable: ...; undecided: ..."`` (empty lists left out).

    Examples
    --------
    >>> verdict_words(["x", "k"], [], [])
    'jointly identifiable: all'
    >>> verdict_words(["x", "v", "c"], ["beta"], ["w"])
    'jointly identifiable: x, v, c; not identifiable: beta; undecided: w'
    """
    if not unobservable and not undecided:
        return "jointly identifiable: all"
    parts = [f"jointly identifiable: {names(observable, most, name=name)}"]
    if unobservable:
        parts.append(f"not identifiable: {names(unobservable, most, name=name)}")
    if undecided:
        parts.append(f"undecided: {names(undecided, most, name=name)}")
    return "; ".join(parts)


#: What to do about the system's refusals that a user can fix (else: check the path).
_OS_FIXES = {
    errno.ENAMETOOLONG: "use a file name of at most 255 bytes",
    errno.ENOSPC: "free some space or write elsewhere",
    errno.EROFS: "write to a writable file system",
    errno.EACCES: "choose a path you may use",
    errno.EPERM: "choose a path you may use",
    errno.EISDIR: "name a file, not a folder",
    errno.ENOTDIR: "a part of the path is a file, not a folder",
}


def os_error_line(exc: OSError) -> str:
    """One line for a refusal of the operating system: the path (shortened), the system's reason and the fix.

    Parameters
    ----------
    exc : OSError
        A name too long, a missing folder, no permission, a full disk.

    Returns
    -------
    str
        ``"cannot use 'PATH': REASON; FIX"``.

    Examples
    --------
    >>> os_error_line(OSError(errno.ENOSPC, "No space left on device", "out.md"))
    "cannot use 'out.md': No space left on device; free some space or write elsewhere"
    """
    where = f" {quote(str(exc.filename), 100)}" if exc.filename is not None else ""
    why = exc.strerror or shorten(str(exc) or type(exc).__name__, 200)
    return f"cannot use{where}: {why}; {_OS_FIXES.get(exc.errno or 0, 'check the path')}"
