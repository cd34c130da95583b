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

from obsnl.errors import ModelError
from obsnl.model.parse import nfkc_problem, shorten

__all__ = ["check_name", "check_text"]

_NAME = re.compile(r"[^\W\d]\w*")


def check_text(value: str, key: str) -> None:
    """Refuse text that cannot be written back (lone surrogates from a JSON ``\\ud800`` escape).

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
