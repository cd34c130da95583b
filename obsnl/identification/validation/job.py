"""``obsnl validate``: a fitted model run on a test record, its figures of merit printed and written to a folder.

:func:`validate_job` checks the output folder before any work, runs :func:`obsnl.simulate` and writes
:func:`write_validation`'s files; what the command prints is :func:`obsnl.commands.validate.validate_printed`.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

from obsnl.errors import DataError
from obsnl.identification.validation.merit import Validation
from obsnl.identification.validation.run import simulate
from obsnl.model.core import Model
from obsnl.model.files import as_model

__all__ = [
    "validate_job",
    "write_validation",
    "validation_files",
    "HYSTERETIC_STATE",
    "DISPLACEMENT_STATE",
    "VALIDATE_FILES",
]

#: What :func:`write_validation` writes, besides ``loop.png`` for a model with a hysteretic state.
VALIDATE_FILES = ("validate.json", "validation.png")
#: The name of a hysteretic state (Bouc-Wen's ``z``): its model gets the restoring-force loop, ``loop.png``.
HYSTERETIC_STATE = "z"
#: The state the loop is drawn against, where the model has it (else its first output).
DISPLACEMENT_STATE = "x"


def validation_files(states: Sequence[str]) -> tuple[str, ...]:
    """The files :func:`write_validation` writes for a model with these states.

    Examples
    --------
    >>> validation_files(["x", "v", "z"])
    ('validate.json', 'validation.png', 'loop.png')
    """
    return VALIDATE_FILES + (("loop.png",) if HYSTERETIC_STATE in states else ())


def write_validation(result: Validation, out: str | Path, *, force: bool = False) -> list[Path]:
    """Write ``validate.json`` (:meth:`Validation.to_dict`), ``validation.png`` and, for a model with a hysteretic
    state, ``loop.png`` into the folder ``out``, all of them or none.

    Parameters
    ----------
    result : Validation
        The validation.
    out : str or Path
        The folder.
    force : bool
        Replace existing files (a link is replaced, never followed).

    Returns
    -------
    list of Path

    Raises
    ------
    OutputError
        ``out`` is a file or a link, cannot be written, or one of the files exists and ``force`` is not set.
    DataError
        ``result`` carries no arrays (``t``, ``y_measured``, ``y_simulated``, ``x``) to draw.
    """
    from obsnl.report.files import OutputFolder
    from obsnl.report.identification.validation import plot_loop, plot_validation

    t, measured, simulated, x = result.t, result.y_measured, result.y_simulated, result.x
    if t is None or measured is None or simulated is None or x is None:
        raise DataError(
            "write_validation: the validation carries no arrays (t, y_measured, y_simulated, x) to draw; "
            "pass the one obsnl.simulate returned"
        )
    names = validation_files(result.states)
    outputs = tuple(result.outputs)
    with OutputFolder(out, names, force=force) as folder:
        folder.write_text("validate.json", json.dumps(result.to_dict(), indent=1, allow_nan=False) + "\n")
        plot_validation(
            folder.path("validation.png"),
            t=t,
            measured=measured,
            simulated=simulated,
            outputs=outputs,
            warmup=result.warmup,
            scores=result.outputs,
        )
        if "loop.png" in names:  # against the displacement state x where the model has one, else the first output
            across, values = (
                (DISPLACEMENT_STATE, x[:, result.states.index(DISPLACEMENT_STATE)])
                if DISPLACEMENT_STATE in result.states
                else (outputs[0], simulated[:, 0])
            )
            plot_loop(
                folder.path("loop.png"),
                displacement=values,
                state=x[:, result.states.index(HYSTERETIC_STATE)],
                output=across,
                name=HYSTERETIC_STATE,
                warmup=result.warmup,
            )
        return folder.commit()


def validate_job(
    model: Model | str | Path,
    *,
    params: str | Path,
    data: str | Path,
    warmup: int = 0,
    intersample: Sequence[str] | str | None = None,
    out: str | Path,
    force: bool = False,
) -> tuple[Validation, list[Path]]:
    """Validate a fit on a test record into a folder (checked before any work).

    Parameters
    ----------
    model : Model, str or Path
        The model or its file.
    params : str or Path
        The fit's ``identify.json`` (or its folder).
    data : str or Path
        The test record (CSV), a column per model input and output.
    warmup : int
        Samples that estimate the initial state and are not scored (0: from rest).
    intersample : sequence of str, str or None
        ``NAME=KIND`` texts, or one ``KIND`` for every input (None or empty: the default of
        :func:`obsnl.simulate`).
    out : str or Path
        The folder of ``validate.json`` and the figures.
    force : bool
        Overwrite those files.

    Returns
    -------
    (Validation, list of Path)
    """
    from obsnl.report.files import check_folder

    model = as_model(model)
    check_folder(out, validation_files([s.name for s in model.states]), force=force)
    result = simulate(model, params, data, warmup=warmup, intersample=intersample or None)
    return result, write_validation(result, out, force=force)
