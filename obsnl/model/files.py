"""Model files: read a TOML or JSON file into a :class:`~obsnl.model.core.Model`, write a model back as
TOML (no dependency; ``read_model(model_to_toml(m))`` gives an equal model), and find the models packaged
with obsnl (the repository's top-level ``models/`` folder, installed as ``share/obsnl/models``)."""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

from obsnl._files import read_document
from obsnl._text import quote
from obsnl.errors import OptionError, ParseError
from obsnl.model.bounds.textsize import MAX_DIGITS
from obsnl.model.core import Model

__all__ = [
    "read_model_file",
    "parse_text",
    "read_model",
    "as_model",
    "catalogue_path",
    "catalogue_folder",
    "model_to_toml",
    "PACKAGED",
]

#: Prefix of a packaged model's name where a file name is expected (``obsnl:bouc_wen``).
PACKAGED = "obsnl:"


def read_model_file(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Read a TOML or JSON model file into a plain dictionary (no validation yet).

    Raises
    ------
    ParseError
        The file is missing, has an unknown extension, or is not valid TOML/JSON.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    shown = quote(str(p), 100)  # a long path is cut, as the system's refusals cut it
    # a regular file of a bounded size only (missing, a folder, a FIFO, a device refused), in UTF-8
    text = read_document(p, where=f"model file {shown}", error=ParseError, fix="give a .toml or .json model file")
    if suffix not in (".toml", ".json"):
        raise ParseError(f"{shown}: unknown model file type {quote(suffix)}; use .toml or .json")
    text = text.removeprefix("\ufeff")  # a byte-order mark (Windows editors write one)
    data = parse_text(text, kind=suffix[1:], where=shown)
    if not isinstance(data, dict):
        raise ParseError(f"{shown}: the top level must be a table/object of model keys")
    return data


#: Deepest nesting of arrays/tables a model file may have (a model needs 3; the parsers recurse).
MAX_NESTING = 32


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in pairs:
        if k in out:
            raise ParseError(f"the key {k!r} appears twice in one object; keep one")
        out[k] = v
    return out


class _LongNumber(ParseError):
    """A number literal over :data:`~obsnl.model.bounds.textsize.MAX_DIGITS` digits (its message is final)."""


_DIGIT_RUN = re.compile(r"\d[\d_]*")


def _long_number(where: str, what: str) -> _LongNumber:
    return _LongNumber(
        f"a number with more than {MAX_DIGITS} digits in {where}: {what}; write it with an exponent "
        f"(e.g. 1.5e20) or scale the model (numbers in expressions have the same bound)"
    )


def _line_of(text: str, literal: str | None = None) -> str:
    """'line N' of ``literal`` in ``text``, or of the first run of more than MAX_DIGITS digits."""
    at = text.find(literal) if literal else -1
    if at < 0:
        at = next(
            (m.start() for m in _DIGIT_RUN.finditer(text) if sum(c.isdigit() for c in m.group()) > MAX_DIGITS), -1
        )
    return f"line {text.count(chr(10), 0, at) + 1}" if at >= 0 else "a number literal"


def _check_numbers(data: Any, where: str, path: str = "") -> None:
    """Refuse an integer over MAX_DIGITS digits anywhere in parsed data (TOML reads integers itself)."""
    if isinstance(data, int) and not isinstance(data, bool) and abs(data) >= 10**MAX_DIGITS:
        raise _long_number(where, path or "the top level")
    items = data.items() if isinstance(data, dict) else enumerate(data) if isinstance(data, list) else ()
    for k, v in items:
        _check_numbers(v, where, f"{path}.{k}" if path and isinstance(k, str) else f"{path}[{k}]" if path else str(k))


def parse_text(text: str, *, kind: str, where: str = "the file") -> Any:
    """Parse TOML or JSON text with the limits obsnl puts on files other people write.

    Refused: nesting deeper than :data:`MAX_NESTING` (checked on the text before the recursive parsers
    run), a key twice in one JSON object (JSON parsers silently keep the last), number literals over
    :data:`~obsnl.model.bounds.textsize.MAX_DIGITS` (100) digits, as in expressions, ``NaN``/``Infinity`` in JSON.

    Parameters
    ----------
    text : str
        The file's text.
    kind : str
        ``"toml"`` or ``"json"``.
    where : str
        How to name the file in messages.

    Raises
    ------
    ParseError
        One line naming the problem.

    Examples
    --------
    >>> parse_text('{"a": 1, "a": 2}', kind="json")
    Traceback (most recent call last):
    ...
    obsnl.errors.ParseError: the file is not valid JSON: the key 'a' appears twice in one object; keep one
    >>> parse_text("a = " + "9" * 200, kind="toml")
    Traceback (most recent call last):
    ...
    obsnl.errors.ParseError: a number with more than 100 digits in the file: a; write it with an exponent (e.g. 1.5e20) or scale the model (numbers in expressions have the same bound)
    """
    depth = deepest = 0
    for c in text:  # brackets inside strings count too: an over-estimate is harmless here
        if c in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif c in "]}":
            depth -= 1
    if deepest > MAX_NESTING:
        raise ParseError(f"{where} nests arrays/tables {deepest} deep (at most {MAX_NESTING}); a model file needs 3")

    def number(literal: str, read: Callable[[str], Any]) -> Any:
        if sum(c.isdigit() for c in literal.lower().partition("e")[0]) > MAX_DIGITS:
            raise _long_number(where, _line_of(text, literal))
        return read(literal)

    try:
        if kind == "toml":
            import tomllib

            try:
                data = tomllib.loads(text, parse_float=lambda s: number(s, float))
            except tomllib.TOMLDecodeError as exc:
                raise ParseError(f"{where} is not valid TOML: {exc}") from None
            _check_numbers(data, where)
            return data

        def constant(name: str) -> Any:
            raise ParseError(f"{name} is not a number obsnl accepts; write a finite number")

        try:
            return json.loads(
                text,
                object_pairs_hook=_unique_keys,
                parse_constant=constant,
                parse_int=lambda s: number(s, int),
                parse_float=lambda s: number(s, float),
            )
        except json.JSONDecodeError as exc:
            raise ParseError(f"{where} is not valid JSON: {exc}") from None
    except _LongNumber as exc:  # final as it is, raised as the plain ParseError
        raise ParseError(str(exc)) from None
    except ParseError as exc:
        if str(exc).startswith(where):
            raise
        raise ParseError(f"{where} is not valid {kind.upper()}: {exc}") from None
    except RecursionError:
        raise ParseError(f"{where} is nested too deeply") from None
    except ValueError as exc:
        if "integer string conversion" in str(exc):  # TOML's own int() of a literal over 4300 digits
            raise ParseError(str(_long_number(where, _line_of(text)))) from None
        raise ParseError(f"{where} is not valid {kind.upper()}: {exc}") from None


def _catalogue_places() -> Iterator[Path]:
    """Where the packaged models may be, in order: a source checkout's ``models/``, then the environment's data
    folders (looked up only when the checkout has none)."""
    root = Path(__file__).resolve().parents[2]
    project = root / "pyproject.toml"
    if project.is_file() and 'name = "obsnl"' in project.read_text(encoding="utf-8", errors="replace"):
        yield root / "models"  # a source checkout: the folder users open and copy
    import sys
    import sysconfig

    for base in (sysconfig.get_path("data"), sys.prefix, sysconfig.get_config_var("userbase") or ""):
        if base:
            yield Path(base) / "share" / "obsnl" / "models"


def catalogue_folder() -> Path:
    """The folder of the models packaged with obsnl: one copy, the repository's top-level ``models/``.

    In a source checkout (an editable install) that folder itself; after ``pip install .`` its copy in the
    environment's data folder (``share/obsnl/models``, mapped by ``tool.setuptools.data-files`` in
    ``pyproject.toml``).

    Returns
    -------
    Path

    Raises
    ------
    ParseError
        No catalogue folder is found (a broken installation: reinstall obsnl).

    Examples
    --------
    >>> (catalogue_folder() / "bouc_wen.toml").is_file()
    True
    """
    places = []
    for folder in _catalogue_places():
        if folder.is_dir() and any(folder.glob("*.toml")):
            return folder
        places.append(folder)
    raise ParseError(
        "the models packaged with obsnl are missing (looked in "
        + ", ".join(str(p) for p in places)
        + "); reinstall obsnl"
    )


def catalogue_path(name: str) -> Path:
    """The file of a model packaged with obsnl (``models/NAME.toml``, see :func:`catalogue_folder`).

    Parameters
    ----------
    name : str
        The model's file name without ``.toml`` (``damage_healing``, ``bouc_wen``, ...).

    Returns
    -------
    Path

    Raises
    ------
    ParseError
        No packaged model has that name (the message lists them).

    Examples
    --------
    >>> catalogue_path("coulomb_friction").name
    'coulomb_friction.toml'
    """
    folder = catalogue_folder()
    names = sorted(p.stem for p in folder.glob("*.toml"))
    if name not in names:
        raise ParseError(f"no packaged model {name!r}; choose one of {', '.join(names)}")
    return folder / f"{name}.toml"


def read_model(path: str | os.PathLike[str], check: Callable[[dict[str, Any]], None] | None = None) -> Model:
    """Read a model from a TOML or JSON file.

    The keys are those of ``shared/peer_cases/*.json``: ``name, description, source,
    states, parameters, inputs, outputs {name: expr}, equations {state: rhs}`` and the
    optional ``known_constants, known_initial_conditions, initial_condition_values,
    unknown_inputs``; obsnl adds the optional ``latex`` (symbol -> LaTeX), ``values``
    (nominal numbers), ``switching`` (order of switching functions), ``definitions``
    (new symbol -> expression in the symbols of another model) and ``bounds`` (declared signs and
    ranges of parameters and known constants, see :class:`~obsnl.model.core.Model`).

    Parameters
    ----------
    path : str or path-like
        A ``.toml`` or ``.json`` file, or ``obsnl:NAME`` for a model packaged with obsnl
        (:func:`catalogue_path`).
    check : callable or None
        Called with the file's raw keys before any expression is parsed (e.g. a size bound,
        :func:`obsnl.observability.limits.check_file_limits`).

    Returns
    -------
    Model

    Raises
    ------
    ParseError, ModelError
        With the file name and the offending key or expression.
    OptionError
        ``path`` is neither text nor a path (a number, a dict: a model in Python is built with
        :class:`~obsnl.model.core.Model`).

    Examples
    --------
    >>> import obsnl
    >>> obsnl.read_model("obsnl:coulomb_friction").states
    (x, v)
    """
    if not isinstance(path, (str, os.PathLike)):  # open() would raise a TypeError, or read a file descriptor
        raise OptionError(
            f"a model is an obsnl Model, the path of a .toml or .json model file or obsnl:NAME; got "
            f"{type(path).__name__} {quote(path, 40)}"
        )
    if isinstance(path, str) and path.startswith(PACKAGED):
        path = catalogue_path(path[len(PACKAGED) :])
    data = read_model_file(path)
    if check is not None:
        check(data)
    try:
        return Model.from_dict(data)
    except ParseError as exc:
        raise ParseError(f"{Path(path).name}: {exc}") from None


def as_model(model: Model | str | os.PathLike[str], check: Callable[[dict[str, Any]], None] | None = None) -> Model:
    """``model`` itself, or the model read from that file or ``obsnl:NAME`` (:func:`read_model`, ``check`` run on
    the file's contents first): what every function that takes "a model or its file" reads it with.

    Parameters
    ----------
    model : Model, str or Path
        A model, its file, or ``obsnl:NAME``.
    check : callable or None
        Run on the file's contents before they are parsed (a size limit); not run on a model.

    Returns
    -------
    Model

    Examples
    --------
    >>> m = as_model("obsnl:coulomb_friction")
    >>> as_model(m) is m
    True
    """
    return model if isinstance(model, Model) else read_model(model, check=check)


# ----------------------------------------------------------------------------- writing

_BARE = re.compile(r"^[A-Za-z0-9_-]+$")
_TABLES = (
    "outputs",
    "equations",
    "initial_condition_values",
    "definitions",
    "latex",
    "values",
    "guess",
    "intersample",
    "bounds",
)


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
    model : Model
        Any model; its ``to_dict()`` keys are written, scalars and lists first, then tables.
    header : str
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
