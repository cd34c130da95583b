"""What the file commands (``analyze``, ``sensors``, ``design``) take: a file option of the right kind, and a record as
a model's one known input."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from obsnl.errors import OptionError, refuse_non_path

if TYPE_CHECKING:
    from obsnl.estimation.accelerogram import Record
    from obsnl.model.core import Model

__all__ = ["RECORD_OPTION", "check_file_option", "one_input_record"]

#: How the file commands name their record option in messages: as the Python keyword, which the command line prints
#: as its flag (``--record``).
RECORD_OPTION = "record="


def check_file_option(value: object, option: str, *, what: str = "file") -> None:
    """Refuse, when a request is made, a file option that is neither None, text nor a path (``record=5`` from Python
    reached ``open(5)``, which raised a TypeError or read a file descriptor).

    Parameters
    ----------
    value : object
        The option's value.
    option : str
        Its name in messages (``"record="``: the command line prints its flag).
    what : str
        What it names: ``"file"`` or ``"folder"``.

    Raises
    ------
    OptionError
        A value of another kind.

    Examples
    --------
    >>> check_file_option("rec.csv", "record=") is None
    True
    """
    if value is not None:
        refuse_non_path(value, f"{option} takes a {what} name")


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
