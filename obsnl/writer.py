"""A small TOML writer for model files (no dependency): ``Model.to_dict()`` -> text that
:func:`obsnl.load_model` reads back to an equal model."""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping
from typing import Any

from .model import Model

__all__ = ["model_to_toml"]

_BARE = re.compile(r"^[A-Za-z0-9_-]+$")
_TABLES = ("outputs", "equations", "initial_condition_values", "definitions", "latex", "values")


def _key(k: str) -> str:
    return k if _BARE.match(k) else json.dumps(k)


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"cannot write the non-finite number {v!r}")
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)  # JSON string escapes are valid TOML basic strings
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def model_to_toml(model: Model, *, header: str = "") -> str:
    """The model as a TOML model file.

    Parameters
    ----------
    model
        Any model; its ``to_dict()`` keys are written, scalars and lists first, then tables.
    header
        Comment lines put at the top (each line gets a ``#``).

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="decay", states=["x"], parameters=["a"], equations={"x": "-a*x"}, outputs={"y": "x"})
    >>> print(model_to_toml(m))
    name = "decay"
    states = ["x"]
    parameters = ["a"]
    inputs = []
    unknown_inputs = []
    known_constants = []
    <BLANKLINE>
    [outputs]
    y = "x"
    <BLANKLINE>
    [equations]
    x = "-a*x"
    <BLANKLINE>
    """
    d = model.to_dict()
    lines = [f"# {line}".rstrip() for line in header.splitlines()]
    for k, v in d.items():
        if k not in _TABLES:
            lines.append(f"{_key(k)} = {_value(v)}")
    for k in _TABLES:
        if k in d and isinstance(d[k], Mapping):
            lines.append("")
            lines.append(f"[{k}]")
            lines.extend(f"{_key(str(a))} = {_value(b)}" for a, b in d[k].items())
    return "\n".join(lines) + "\n"
