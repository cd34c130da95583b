"""Type aliases shared by the result values: what a JSON document or a model file can hold.

A field whose value is truly free (a user's notes in a model file, what an older table carried) is typed with
these recursive aliases rather than ``Any``: a reader then knows it gets plain data, never an object. A module
that names one in a field imports it at run time (not under ``TYPE_CHECKING``), so that
``typing.get_type_hints`` resolves the alias's inner names there (tests/test_typed_fields.py reads them).
"""

from __future__ import annotations

import datetime
from typing import TypeAlias

__all__ = ["FileValue", "JSONValue"]

#: A value of a JSON document (``json.loads``): a number, text, a boolean, null, a list or an object of them.
JSONValue: TypeAlias = str | int | float | bool | None | list["JSONValue"] | dict[str, "JSONValue"]

#: A value of a model file, TOML or JSON (``tomllib.loads``, ``json.loads``): a JSON value, or TOML's dates and
#: times (a ``datetime.datetime`` is a ``datetime.date``).
FileValue: TypeAlias = (
    str | int | float | bool | None | datetime.date | datetime.time | list["FileValue"] | dict[str, "FileValue"]
)
