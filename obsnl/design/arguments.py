"""The checks of the design functions' arguments at their public entry (:func:`obsnl.sensors`,
:func:`obsnl.design.experiment.design`): a value of the wrong type or out of bounds is refused with one
:class:`~obsnl.errors.OptionError` line naming the argument, before Python's own operations see it (a
``TypeError`` from iterating a number, an ``AttributeError`` from a string taken for a model).

The command line reads :data:`MAX_SCALES` while it parses its options.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from obsnl._text import quote
from obsnl.errors import OptionError
from obsnl.estimation.accelerogram import Record
from obsnl.estimation.measured import TIME_COLUMNS, frame_columns, is_frame
from obsnl.model.core import Model

__all__ = ["MAX_SCALES", "model_argument", "names_argument", "design_arguments", "record_run"]

#: Most scales of one design: each is one simulation per record (2000 scales on a gap spring ran 157 s).
MAX_SCALES = 64


def model_argument(model: Any, function: str, *, files: bool = False) -> None:
    """Refuse a ``model`` that is not an obsnl :class:`~obsnl.model.core.Model` (nor a path, when ``files``).

    Parameters
    ----------
    model : object
        The argument.
    function : str
        The function it was given to, for the message.
    files : bool
        Whether the function also reads a model file (a path or ``obsnl:NAME``).

    Raises
    ------
    OptionError
        One line naming the type given and what to pass.

    Examples
    --------
    >>> model_argument(5, "design")
    Traceback (most recent call last):
    ...
    obsnl.errors.OptionError: design takes an obsnl Model, got int; read a file with obsnl.read_model
    """
    if isinstance(model, Model) or (files and (isinstance(model, str) or hasattr(model, "__fspath__"))):
        return
    what = "an obsnl Model or a model file's path" if files else "an obsnl Model"
    raise OptionError(f"{function} takes {what}, got {type(model).__name__}; read a file with obsnl.read_model")


def names_argument(value: Any, what: str) -> str | list[str]:
    """``value`` as a comma-separated string or a list of names, refused when it is neither.

    Parameters
    ----------
    value : object
        A target or a sensor list, as given.
    what : str
        Its name, for the message.

    Returns
    -------
    str or list of str

    Raises
    ------
    OptionError
        A value that is not a string or a list, tuple or set of strings.

    Examples
    --------
    >>> names_argument(("x", "k"), "target"), names_argument("x, k", "target")
    (['x', 'k'], 'x, k')
    >>> names_argument([5], "target")
    Traceback (most recent call last):
    ...
    obsnl.errors.OptionError: target is a comma-separated string or a list of names, got [5]
    """
    if isinstance(value, str):
        return value
    if isinstance(value, (list, tuple, set, frozenset)) and all(isinstance(n, str) for n in value):
        return list(value)
    raise OptionError(f"{what} is a comma-separated string or a list of names, got {quote(value)}")


def design_arguments(model: Any, records: Any, *, scales: Any, tol: Any, sensors: Any) -> tuple[float, ...] | None:
    """Check the arguments of :func:`~obsnl.design.experiment.design` whose type Python would otherwise trip on.

    Parameters
    ----------
    model : Any
        As given to ``design`` (a Model, else refused).
    records : Any
        As given to ``design``, one Record put in a list (a record's contents are checked when converted).
    scales : Any
        As given to ``design``: None or a list of positive finite numbers.
    tol : Any
        As given to ``design``: a relative width from 1e-12 to below 1.
    sensors : Any
        As given to ``design``: None or a list of output names.

    Returns
    -------
    tuple of float or None
        The scales, sorted and without repeats (None: the default grid).

    Raises
    ------
    OptionError
        A model that is not a Model, records that are not a list, more than :data:`MAX_SCALES` scales or
        one that is not a positive finite number, a tolerance outside [1e-12, 1), sensors that are not names.

    Examples
    --------
    >>> m = Model(name="m", states=["x"], parameters=["a"], equations={"x": "-a*x"}, outputs={"y": "x"})
    >>> design_arguments(m, [], scales=[2, 1, 2], tol=1e-3, sensors=None)
    (1.0, 2.0)
    """
    model_argument(model, "design")
    if not isinstance(records, (list, tuple)):
        raise OptionError(f"records is a list of Record or (name, t, {{input: samples}}), got {quote(records)}")
    if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not 1e-12 <= tol < 1:
        raise OptionError(f"tol is a relative width from 1e-12 to below 1, got {quote(tol)}")
    if sensors is not None:
        names_argument(sensors, "sensors")
    if scales is None:
        return None
    values = (
        list(scales)
        if isinstance(scales, Sequence) and not isinstance(scales, str) or hasattr(scales, "__array__")
        else None
    )
    if values is not None and len(values) > MAX_SCALES:
        raise OptionError(
            f"{len(values)} scales: give at most {MAX_SCALES} (each is one simulation of every "
            f"record; a bisection refines the boundary between them)"
        )
    ok = values is not None and all(isinstance(s, numbers.Real) and not isinstance(s, bool) for s in values)
    grid = tuple(sorted({float(s) for s in values})) if ok and values else ()
    if not grid or not all(math.isfinite(s) and s > 0 for s in grid):
        raise OptionError(f"the scales are a list of positive finite numbers, got {quote(scales)}")
    return grid


def record_run(model: Model, rec: Any, *, name: str = "data") -> tuple[str, np.ndarray, dict[str, np.ndarray]]:
    """``(name, t, {input: samples})`` of a record (a one-column Record drives the model's one input).

    Parameters
    ----------
    model : Model
        The model the record drives.
    rec : Record, tuple or pandas.DataFrame
        A :class:`~obsnl.estimation.accelerogram.Record`, ``(name, t, {input: samples})`` or a DataFrame with a
        column per input of the model (its time a column or its index:
        :func:`~obsnl.estimation.measured.frame_columns`; other columns ignored).
    name : str
        The name of a DataFrame record without one in its ``attrs["name"]``.

    Returns
    -------
    tuple
        The name, the times and the samples of each input, as float arrays (their values are checked by the
        simulation, :meth:`obsnl.design.continuous.TrajectoryVisits.drive`).

    Raises
    ------
    OptionError
        Not a record, a one-column Record for a model of several inputs, or times or samples not numbers.
    """

    def known(name: Any, inputs: Any) -> None:  # a misspelt input would be ignored, the model's one reported missing
        other = [k for k in inputs if k not in {u.name for u in model.inputs}]
        if other:
            raise OptionError(
                f"record {quote(name)}: {quote(other[0])} is not an input of {quote(model.name)}; its "
                f"inputs are {', '.join(u.name for u in model.inputs) or 'none'}"
            )

    if isinstance(rec, Record):
        a = np.asarray(rec.accel, float)
        if a.ndim == 2:
            known(rec.name, rec.channels)
            return rec.name, rec.t, {c: a[:, j] for j, c in enumerate(rec.channels)}
        if len(model.inputs) != 1:
            raise OptionError(
                f"record {rec.name!r} drives one input, model {model.name!r} has {len(model.inputs)} "
                f"known inputs; give (name, t, {{input: samples}}) instead"
            )
        return rec.name, rec.t, {model.inputs[0].name: a}
    if is_frame(rec):
        label = str(rec.attrs.get("name", name))
        columns = frame_columns(rec, where=f"record {quote(label)}")
        tname = next(c for c in TIME_COLUMNS if c in columns)
        missing = [u.name for u in model.inputs if u.name not in columns]
        if missing:
            raise OptionError(
                f"record {quote(label)}: no column for the input {quote(missing[0])} of "
                f"{quote(model.name)}; name a column after each input"
            )
        rec = (label, columns[tname], {u.name: columns[u.name] for u in model.inputs})
    if isinstance(rec, tuple) and len(rec) == 3 and isinstance(rec[2], Mapping):
        name, t, inputs = rec
        known(name, inputs)
        if any(np.iscomplexobj(a) for a in (t, *inputs.values())):  # float() would drop the imaginary part
            raise OptionError(f"record {quote(name)}: its times and inputs must be real numbers, not complex")
        try:
            return str(name), np.asarray(t, float), {str(k): np.asarray(v, float) for k, v in inputs.items()}
        except (TypeError, ValueError):  # text, or nested lists of unequal lengths
            raise OptionError(f"record {quote(name)}: its times and inputs must be arrays of numbers") from None
    raise OptionError(
        f"a record is a Record, (name, t, {{input: samples}}) or a pandas DataFrame, got {type(rec).__name__}"
    )
