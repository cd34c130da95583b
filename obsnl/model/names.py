"""The one rule for names in a model: Python identifiers, in Unicode NFKC form, schema-compatible.

Python reads identifiers in NFKC form, so a fullwidth ``ｘ`` *is* ``x`` to the parser and ``ℓ`` is
``l``; comparing names raw would let two spellings of one symbol through (a wrong verdict) or fail
later with a NameError. Every declared name must therefore already be in NFKC form, and consist of
a letter or ``_`` followed by letters, digits and ``_`` (Unicode letters allowed, as in the branch-table
schema), must not be a Python keyword or start with ``__``.
"""

from __future__ import annotations

import keyword
import re
from collections.abc import Iterable, Mapping
from typing import Any

import sympy as sp

from obsnl.errors import ModelError
from obsnl.model.parse import nfkc_problem, shorten

__all__ = ["check_name", "check_text", "name_list", "close_name"]

_NAME = re.compile(r"[^\W\d]\w*")


def check_text(value: str, key: str) -> None:
    """Refuse text that cannot be written back (lone surrogates from a JSON ``\\ud800`` escape).

    Parameters
    ----------
    value : str
        The text to check.
    key : str
        The model key it came from, named in the message.

    Raises
    ------
    ModelError
        When ``value`` cannot be encoded as UTF-8.

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
        raise ModelError(f"'{key}' contains a lone surrogate ({shorten(ascii(value), 40)}); "
                         f"write it as valid Unicode text") from None


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
        raise ModelError(f"'{key}': {name!r} is not a valid name (letters, digits and '_', not starting with a digit)")
    if keyword.iskeyword(name):
        raise ModelError(f"'{key}': {name!r} is a Python keyword; rename it (e.g. {name + '_'!r})")
    if name.startswith("__"):
        raise ModelError(f"'{key}': names starting with '__' are not allowed ({name!r})")


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
            raise ModelError(f"'{key}' must contain names (strings), got {item!r}")
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
