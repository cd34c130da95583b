"""The one rule for names in a model: Python identifiers, in Unicode NFKC form, schema-compatible.

Python reads identifiers in NFKC form, so a fullwidth ``ｘ`` *is* ``x`` to the parser and ``ℓ`` is
``l``; comparing names raw would let two spellings of one symbol through (a wrong verdict) or fail
later with a NameError. Every declared name must therefore already be in NFKC form, and consist of
a letter or ``_`` followed by letters, digits and ``_`` (Unicode letters allowed, as in the branch-table
schema), must not be a Python keyword or start with ``__``, nor be one of the class names the expression
reader calls (:data:`~obsnl.model.reading.parse.PARSER_NAMES`: ``Integer``, ``Float``, ``Rational``, ``Symbol``,
``Function``). A symbol (a state, parameter, input or constant, not an output) must not be named like a function
of the expression language either (:data:`~obsnl.model.reading.parse.FUNCTION_NAMES`: ``exp``, ``sin``, ``Max``,
``Eq``, ...): it would shadow the function, and ``exp(x)`` would call the symbol.

Non-ASCII letters stay allowed (``μ``, ``Δ1``), but two names of one model that look alike are refused:
each name is reduced to a *skeleton* (compatibility decomposition, then the Cyrillic and Greek letters
that look like Latin ones mapped to them, :data:`LOOK_ALIKE`) and two declared names with one
skeleton (Latin ``a`` and Cyrillic ``а``, Latin ``o`` and Greek ``ο``) are refused: the reader would take
them as two symbols while every rendering shows one.

Text fields (name, description, source) carry no control characters: a line break in a model's name would
forge lines of the verdict, an escape sequence in its source would drive the terminal. The name has none at
all; description and source may hold line breaks and tabs (``\\n``, ``\\t``).
"""

from __future__ import annotations

import keyword
import re
import unicodedata
from collections.abc import Iterable, Mapping
from typing import Any

import sympy as sp

from obsnl.errors import ModelError
from obsnl.model.reading.parse import FUNCTION_NAMES, PARSER_NAMES, nfkc_problem, quote, shorten

__all__ = ["check_name", "check_text", "check_distinct", "skeleton", "name_list", "close_name", "LOOK_ALIKE"]

#: Cyrillic and Greek letters that look like a Latin letter, and that letter.
LOOK_ALIKE: dict[str, str] = dict(
    zip(
        "аеорсухіјѕԁһԛԝӏАВЕКМНОРСТХУІЈЅονϲϳΑΒΕΖΗΙΚΜΝΟΡΤΥΧ",
        "aeopcyxijsdhqwlABEKMHOPCTXYIJSovcjABEZHIKMNOPTYX",
    )
)

_NAME = re.compile(r"[^\W\d]\w*")

#: The keys that declare symbols of the expressions, each in words (an output's name is never a symbol).
_SYMBOL_ROLES: dict[str, str] = {
    "states": "state",
    "parameters": "parameter",
    "inputs": "input",
    "unknown_inputs": "unknown input",
    "known_constants": "known constant",
    "known_initial_conditions": "state",
}


def check_text(value: str, key: str, *, multiline: bool = False) -> None:
    """Refuse text that cannot be written back (lone surrogates from a JSON ``\\ud800`` escape) or that holds
    control characters (line breaks, escape sequences, bidirectional overrides, zero-width characters: they
    forge lines of a report, drive the terminal it is printed on, or hide a character).

    Parameters
    ----------
    value : str
        The text to check.
    key : str
        The model key it came from, named in the message.
    multiline : bool
        Free text (a description): line breaks ``\\n``, tabs and invisible format characters other than the
        bidirectional controls are accepted.

    Raises
    ------
    ModelError
        When ``value`` cannot be encoded as UTF-8 or holds a refused control character.

    Examples
    --------
    >>> check_text("\\ud800", "name")
    Traceback (most recent call last):
    ...
    obsnl.errors.ModelError: 'name' contains a lone surrogate ('\\ud800'); write it as valid Unicode text
    """
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise ModelError(
            f"'{key}' contains a lone surrogate ({shorten(ascii(value), 40)}); write it as valid Unicode text"
        ) from None
    bad = next((c for c in value if _control(c, multiline)), None)
    if bad is not None:
        kind = "a line break" if bad in "\n\r\x0b\x0c\x85\u2028\u2029" else "a control character"
        where = f"'{key}' contains {kind} ({ascii(bad)} at character {value.index(bad) + 1})"
        raise ModelError(f"{where}; remove it" + (" (line breaks '\\n' and tabs are allowed)" if multiline else ""))


#: Bidirectional controls: they reorder the characters shown after them (a forged verdict, "Trojan source").
_BIDI = frozenset("\u061c\u200e\u200f\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069")


def _control(c: str, multiline: bool) -> bool:
    """Whether ``c`` is refused in text (see :func:`check_text`)."""
    cat = unicodedata.category(c)
    if cat in ("Cc", "Zl", "Zp"):
        return not (multiline and c in "\n\t")
    return cat == "Cf" and (not multiline or c in _BIDI)


def check_name(name: str, key: str) -> None:
    """Refuse a name that breaks the rule of the module docstring; ``key`` says where it was declared.

    Parameters
    ----------
    name : str
        The name to check.
    key : str
        The model key it was declared under, named in the message.

    Raises
    ------
    ModelError
        Naming the problem and the spelling to use.

    Examples
    --------
    >>> check_name("\\u2113", "parameters")
    Traceback (most recent call last):
    ...
    obsnl.errors.ModelError: 'parameters': 'ℓ' is read as 'l' (Unicode NFKC); write 'l'; two spellings of one name are refused
    """
    check_text(name, key)
    problem = nfkc_problem(name)
    if problem:
        raise ModelError(f"'{key}': {problem}; two spellings of one name are refused")
    if not name.isidentifier() or not _NAME.fullmatch(name):
        raise ModelError(
            f"'{key}': {quote(name)} is not a valid name (letters, digits and '_', not starting with a digit)"
        )
    if keyword.iskeyword(name):
        raise ModelError(f"'{key}': {name!r} is a Python keyword; rename it (e.g. {name + '_'!r})")
    if name.startswith("__"):
        raise ModelError(f"'{key}': names starting with '__' are not allowed ({quote(name)})")
    if name in PARSER_NAMES:
        raise ModelError(
            f"'{key}': {name!r} is the name of a class the expression reader uses; rename it (e.g. {name + '_'!r})"
        )
    if name in FUNCTION_NAMES and key in _SYMBOL_ROLES:  # the symbol would shadow the function: exp(x) fails
        raise ModelError(
            f"name {name!r} is a function of the model language ({name}(...)); rename the "
            f"{_SYMBOL_ROLES[key]} (e.g. {name + '_'!r})"
        )


def skeleton(name: str) -> str:
    """What ``name`` looks like: compatibility-decomposed, look-alike Cyrillic and Greek letters made Latin.

    Examples
    --------
    >>> skeleton("\u0430") == skeleton("a"), skeleton("\u03bc") == skeleton("u")
    (True, False)
    """
    decomposed = unicodedata.normalize("NFKD", name)
    return "".join(LOOK_ALIKE.get(c, c) for c in decomposed)


def check_distinct(names: Iterable[str]) -> None:
    """Refuse two names that look alike (one :func:`skeleton`), such as Latin ``a`` and Cyrillic ``а``.

    Parameters
    ----------
    names : iterable of str
        Every name the model declares (symbols and outputs), each distinct.

    Raises
    ------
    ModelError
        Naming both spellings (with their code points) and the fix.

    Examples
    --------
    >>> check_distinct(["a", "b", "\u0430"])
    Traceback (most recent call last):
    ...
    obsnl.errors.ModelError: 'a' and '\u0430' (Cyrillic) look alike; rename one of them (two names that look alike are refused)
    """
    seen: dict[str, str] = {}
    for n in names:
        k = skeleton(n)
        if k in seen and seen[k] != n:
            other = seen[k]
            scripts = sorted({unicodedata.name(c, "?").split()[0].title() for c in n + other if ord(c) > 127})
            raise ModelError(
                f"{ascii(other)} and {ascii(n)} ({', '.join(scripts)}) look alike; rename one of them "
                f"(two names that look alike are refused)"
            )
        seen[k] = n


def name_list(value: Any, key: str) -> tuple[str, ...]:
    """A list of names from a model key (a name, a list of names or symbols), each checked by :func:`check_name`.

    Parameters
    ----------
    value : Any
        None, a name, a sympy Symbol, or an iterable of names or symbols.
    key : str
        The model key, named in the messages.

    Returns
    -------
    tuple of str
        The stripped names, in order (empty for None).

    Raises
    ------
    ModelError
        When ``value`` is not a list of names or a name breaks the rule.
    """
    if value is None:
        return ()
    if isinstance(value, (str, sp.Symbol)):
        value = [value]
    if isinstance(value, Mapping) or not isinstance(value, Iterable):
        raise ModelError(f"'{key}' must be a list of names, got {type(value).__name__}")
    names: list[str] = []
    for item in value:
        if isinstance(item, sp.Symbol):
            item = item.name
        if not isinstance(item, str):
            raise ModelError(f"'{key}' must contain names (strings), got {quote(item)}")
        name = item.strip()
        check_name(name, key)
        names.append(name)
    return tuple(names)


def close_name(name: str, candidates: Iterable[str]) -> str:
    """' (did you mean ...?)' for the closest candidate, or ''.

    Parameters
    ----------
    name : str
        The unknown name.
    candidates : iterable of str
        The names that exist.

    Returns
    -------
    str
    """
    import difflib

    close = difflib.get_close_matches(name, list(candidates), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""
