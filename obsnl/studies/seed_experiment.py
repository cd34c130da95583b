"""The seed paper's experiment: its model, its record, its set-up and its branch table.

The model is the packaged ``damage_healing_reparam.toml``, the record Northridge 1994 LOS270 (or another
record resampled to 100 Hz), the guesses those of the paper's Table 2 (:data:`SEED_GUESS`), and the branch
table the DUKF reads comes from obsnl's own analysis, checked against the paper's Table 1.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import TYPE_CHECKING

from obsnl.errors import OutputError
from obsnl.estimation.records import Record
from obsnl.identification.experiments import Setup, coordinates
from obsnl.model.files import catalogue_path

if TYPE_CHECKING:
    from obsnl.observability.contract.branch_table import BranchTable

__all__ = ["SEED_GUESS", "seed_model_path", "check_record_name", "seed_record", "seed_setup", "seed_branch_table"]

#: Initial guesses of Table 2 of the seed paper (000_d24855f97fc8bdd4.txt).
SEED_GUESS: Mapping[str, float] = {
    "k_m": 5e3,
    "c_dm": 50.0,
    "c_eta_p": 3e3,
    "c_p": 4.0,
    "h_p": 4e-3,
    "N": 3.0,
    "w_h": 0.3,
    "Delta1": 3e10,
    "Delta2": -6e9,
}


def seed_model_path() -> str:
    """The packaged ``damage_healing_reparam.toml`` (the model of the seed experiment)."""
    return str(catalogue_path("damage_healing_reparam"))


def check_record_name(name: str) -> str:
    """Refuse a record name that cannot be one folder below ``reports/identification``.

    Parameters
    ----------
    name : str
        The record's name (its file's stem).

    Returns
    -------
    str
        ``name``.

    Raises
    ------
    OutputError
        ``""``, ``"."``, ``".."``, or a name with a path separator or a NUL.

    Examples
    --------
    >>> check_record_name("northridge")
    'northridge'
    >>> check_record_name("..")
    Traceback (most recent call last):
    ...
    obsnl.errors.OutputError: the record's name '..' (its file name without the extension) cannot name a folder below reports/identification; rename the record file
    """
    if name in ("", ".", "..") or any(c and c in name for c in ("/", "\0", os.sep, os.altsep)):
        raise OutputError(
            f"the record's name {name!r} (its file name without the extension) cannot name a folder "
            f"below reports/identification; rename the record file"
        )
    return name


def seed_record(record: Record | None = None, samples: int | None = None) -> Record:
    """The record of the seed experiment: Northridge 1994 LOS270, or ``record`` resampled to 100 Hz and
    cut to its first 2000 samples; then its first ``samples``.

    Parameters
    ----------
    record : Record or None
        Another record (None: Northridge 1994 LOS270, as the seed paper).
    samples : int or None
        Keep only the first samples.

    Returns
    -------
    Record

    Raises
    ------
    DataError
        A step that cannot be resampled to 100 Hz, or fewer than 2 samples.
    OutputError
        A record whose name (its file's stem) is not a plain folder name: ``obsnl reproduce`` writes into
        ``reports/identification/<name>``, and a file named ``...csv`` (stem ``..``) led into ``reports/``.

    Examples
    --------
    >>> len(seed_record(samples=300)), seed_record().dt
    (300, 0.01)
    """
    from importlib import resources

    from obsnl.estimation.records import read_record

    if record is None:
        record = read_record(
            str(resources.files("obsnl").joinpath("studies/data/northridge1994_LOS270_ngawest2_accel.csv"))
        )
    else:
        check_record_name(record.name)
        record = record.resampled(0.01)
        record = record.head(min(len(record), 2000))
    return record if samples is None else record.head(samples)


def seed_setup(
    *, record: Record | None = None, samples: int | None = None, jit: bool = False, kind: str = "log"
) -> Setup:
    """The seed paper's experiment (on another record when given: resampled to 100 Hz, first 2000 samples).

    Parameters
    ----------
    record : Record or None
        Another record (None: Northridge 1994).
    samples : int or None
        Use only the first samples.
    jit : bool
        Compile the filter step.
    kind : str
        Filter coordinates (:func:`obsnl.identification.setup.coordinates`).

    Returns
    -------
    Setup
    """
    from obsnl.estimation.codegen import to_casadi
    from obsnl.model.files import read_model

    model = read_model(seed_model_path())
    record = seed_record(record, samples)
    num = to_casadi(model)
    truth = {p: float(model.values[p]) for p in num.parameters}
    return Setup(
        model=num,
        record=record,
        truth=truth,
        guess=dict(SEED_GUESS),
        jit=jit,
        coordinates=coordinates(num, kind, reference=SEED_GUESS),
    )


def seed_branch_table(*, seed: int = 0) -> tuple[BranchTable, str]:
    """The branch table of the seed model from obsnl's analysis, checked against the paper's Table 1."""
    from obsnl.model.files import read_model
    from obsnl.observability.analyze import analyze
    from obsnl.observability.contract.branch_table import BranchTable

    model = read_model(seed_model_path())
    table = BranchTable.from_result(analyze(model, seed=seed))
    paper = {1: {"Delta2"}, -1: {"Delta1", "w_h"}}  # Table 1: by the sign of (r - eta') x2
    agrees = all(set(b.unidentifiable_parameters) == paper[b.signs[0] * b.signs[1]] for b in table.branches)
    source = (
        f"obsnl analysis ({table.method}, seed {seed}); "
        f"{'agrees with' if agrees else 'DIFFERS from'} the seed paper's Table 1"
    )
    return table, source
