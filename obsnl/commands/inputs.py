"""A record as a model's one known input, as the file commands (``analyze``, ``sensors``, ``design``) take it."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from obsnl.errors import OptionError
from obsnl.model.core import Model

if TYPE_CHECKING:
    from obsnl.estimation.accelerogram import Record

__all__ = ["RECORD_OPTION", "one_input_record"]

#: How the file commands name their record option in messages: as the Python keyword, which the command line prints
#: as its flag (``--record``).
RECORD_OPTION = "record="


def one_input_record(model: Model, path: str | Path, *, option: str = "a record") -> Record:
    """The record at ``path`` as the one known input of ``model``.

    Parameters
    ----------
    model : Model
        A model with exactly one input.
    path : str or Path
        A record file (.csv or PEER .AT2).
    option : str
        How the caller names the record in messages (:data:`RECORD_OPTION`: ``--record`` on the command line).

    Returns
    -------
    Record
        The record read.

    Raises
    ------
    OptionError
        When the model has no input or more than one.
    """
    from obsnl.estimation.records import read_record

    if len(model.inputs) != 1:
        raise OptionError(
            f"{option} drives one input, model {model.name!r} has {len(model.inputs)}; give a model "
            "with one known input"
        )
    return read_record(path)
