"""Measured data: a table of the model's inputs and outputs against time, and their noise levels.

A measured record is a CSV with a header: a time column (``time_s`` or ``t``) and one column per model
input and per model output, named as in the model (extra columns are ignored; units are the
user's). :func:`read_measured` reads and validates it (the file conventions of
:mod:`obsnl.estimation.records`: a byte-order mark, commas, semicolons or tabs, absolute time counted
from the first sample); :func:`measured` does the same for columns the caller already holds (a mapping
of name to samples).

The time column is never ambiguous: two time columns are refused, and so is a model input or output
named ``t`` or ``time_s`` whose column would have to be the time column too (with a separate ``time_s``
column, a model input ``t`` is read as that input). Identification needs :data:`MIN_SAMPLES` samples
(checked when the data are used, :meth:`Measured.record` and :func:`estimate_noise`).

Noise levels not given are estimated from the data by :func:`estimate_noise`: the high-frequency
residual of each channel, from its finite differences (a white noise of std ``s`` has ``k``-th
differences of variance ``C(2k, k) s^2``; a signal sampled well above its band contributes almost
nothing to them). Assumption, stated in every result: the channel is oversampled (its content well
below the Nyquist frequency); for a broadband channel the estimate is an upper bound, and it is said so.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from math import comb
from pathlib import Path
from typing import Any

import numpy as np

from obsnl._text import block, names, number, one_line
from obsnl.errors import DataError
from obsnl.estimation.records import read_table
from obsnl.estimation.accelerogram import Record, check_seconds, check_times
from obsnl.model.bounds.textsize import quote

__all__ = [
    "Measured", "measured", "read_measured", "estimate_noise", "NOISE_FLOOR", "TIME_COLUMNS",
    "MIN_SAMPLES", "UPPER_BOUND",
]

#: Accepted names of the time column (seconds).
TIME_COLUMNS = ("time_s", "t")
#: Smallest noise-to-signal ratio a filter is given: one that trusts its model more than this is brittle.
NOISE_FLOOR = 1e-3
#: Fewest samples identified from: the noise levels come from differences of order up to 4, and a filter
#: needs many samples per unknown (3 samples ran to an "estimate" with numpy warnings).
MIN_SAMPLES = 20
#: How :func:`estimate_noise`'s note ends when the estimate is only an upper bound (the channel is not oversampled).
UPPER_BOUND = "this is an upper bound"
_TOO_SHORT = (f"identification needs at least {MIN_SAMPLES} samples (noise levels are estimated from 4th "
              f"differences, and a filter needs many samples per unknown); give a longer record")


@dataclass(frozen=True, eq=False)
class Measured:
    """Measured inputs ``u`` ``(T, nu)`` and outputs ``y`` ``(T, ny)`` at an even step ``dt``."""

    name: str
    dt: float
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    u: np.ndarray
    y: np.ndarray
    source: str = ""

    @property
    def t(self) -> np.ndarray:
        return np.arange(len(self.y)) * self.dt

    def record(self) -> Record:
        """The inputs as a :class:`~obsnl.estimation.accelerogram.Record` (one column per input); refused with fewer
        than :data:`MIN_SAMPLES` samples."""
        if len(self.y) < MIN_SAMPLES:
            raise DataError(f"data {self.source or self.name!r} have {len(self.y)} samples; {_TOO_SHORT}")
        return Record(self.name, self.u if self.u.shape[1] > 1 else self.u[:, 0], self.dt, self.source,
                      channels=self.inputs)

    def __repr__(self) -> str:
        return one_line("Measured", f"name={self.name!r}", f"samples={len(self.y)}", f"dt={number(self.dt)} s",
                        f"inputs={names(self.inputs, 4)!r}", f"outputs={names(self.outputs, 4)!r}")

    def summary(self) -> str:
        """A few lines of plain text: length, step, the channels and their RMS, where the data came from."""
        rms = [f"{c} {number(float(np.sqrt(np.mean(v ** 2))))}" for c, v in
               [*zip(self.inputs, self.u.T), *zip(self.outputs, self.y.T)]]
        return block(f"measured {self.name}: {len(self.y)} samples at dt = {number(self.dt)} s", f"source: {self.source}"
                     if self.source else "", f"inputs: {names(self.inputs, 8)}; outputs: {names(self.outputs, 8)}",
                     f"RMS: {names(rms, 10)}")

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "source": self.source, "dt": self.dt, "samples": len(self.y),
                "inputs": list(self.inputs), "outputs": list(self.outputs)}


def measured(columns: Mapping[str, Any], *, inputs: Sequence[str], outputs: Sequence[str], name: str = "data",
             source: str = "") -> Measured:
    """Measured data from columns (a time column and one per input and output).

    Parameters
    ----------
    columns : mapping of str to Any
        ``{name: samples}``; the time column is ``time_s`` or ``t``; extra columns are ignored.
    inputs, outputs : sequence of str
        The model's input and output names, in model order.
    name, source : str
        Labels of the record.

    Returns
    -------
    Measured

    Raises
    ------
    DataError
        No time column or two, a model channel that would be the time column, a missing column (named),
        NaN/inf (column and sample named), a time that does not increase or is irregular, fewer than 3
        samples.

    Examples
    --------
    >>> m = measured({"t": [0, 0.1, 0.2], "f": [0, 1, 0], "x": [0, 0.1, 0.3]}, inputs=["f"], outputs=["x"])
    >>> m.u.shape, m.y.shape, m.dt
    ((3, 1), (3, 1), 0.1)
    """
    where = f"data {source or name!r}"
    tname = _time_column(columns, inputs, outputs, where)
    arrays = {}
    for c in (tname, *inputs, *outputs):
        kind = {"c": "complex numbers", "M": "dates", "m": "time spans", "b": "booleans"}.get(np.asarray(columns[c]).dtype.kind)
        if kind or np.ma.is_masked(columns[c]):  # read as floats they would lose a part, or a mask, silently
            raise DataError(f"{where}: column {quote(c)} holds {kind or 'masked samples'}; give real numbers (time in "
                            f"seconds), every sample present")
        try:
            a = np.asarray(columns[c], float)
        except (TypeError, ValueError, OverflowError):
            raise DataError(f"{where}: column {quote(c)} is not numeric (or beyond the float range)") from None
        if a.ndim != 1:
            raise DataError(f"{where}: column {c!r} must be one series, got shape {a.shape}")
        bad = np.flatnonzero(~np.isfinite(a))
        if bad.size:
            raise DataError(f"{where}: column {c!r} has NaN/inf at sample {bad[0]} ({bad.size} bad samples); "
                            f"clean or interpolate the record first")
        if c != tname and a.size and np.max(np.abs(a)) > 1e100:  # squared by the noise levels and the filter
            raise DataError(f"{where}: column {c!r} reaches {float(np.max(np.abs(a))):.3g}; rescale it (check its units)")
        arrays[c] = a
    lengths = {len(a) for a in arrays.values()}
    if len(lengths) != 1:
        raise DataError(f"{where}: the columns have different lengths {sorted(lengths)}")
    if lengths.pop() < 3:
        raise DataError(f"{where}: need at least 3 samples")
    dt = check_times(arrays[tname], where)
    col = lambda names: np.column_stack([arrays[c] for c in names]) if names else np.zeros((len(arrays[tname]), 0))  # noqa: E731
    return Measured(name=name, dt=dt, inputs=tuple(inputs), outputs=tuple(outputs), u=col(inputs), y=col(outputs),
                    source=source)


def read_measured(path: str | Path, *, inputs: Sequence[str], outputs: Sequence[str]) -> Measured:
    """Read a measured record (CSV with header; see the module docstring).

    Parameters
    ----------
    path : str or Path
        The CSV file.
    inputs, outputs : sequence of str
        The model's input and output names: the columns read (others are ignored).

    Returns
    -------
    Measured

    Raises
    ------
    DataError
        A missing file or column, a non-numeric cell (line and column named), NaN, a bad time column.

    Examples
    --------
    >>> import tempfile, os
    >>> p = os.path.join(tempfile.mkdtemp(), "d.csv")
    >>> _ = open(p, "w").write("time_s,f,x,note\\n0,0,0,a\\n0.1,1,0.1,b\\n0.2,0,0.3,c\\n")
    >>> read_measured(p, inputs=["f"], outputs=["x"]).y.ravel().tolist()
    [0.0, 0.1, 0.3]
    """
    p = Path(path)
    channels, where = (*inputs, *outputs), f"data {str(p)!r}"

    def choose(header: list[str]) -> tuple[dict[str, int], list[str]]:
        for h in header:  # a time column in other units (time_ms) is not read as seconds
            if h.lower().startswith("time") and h not in TIME_COLUMNS and h not in channels:
                check_seconds(h, where)
        idx = {c: header.index(c) for c in (*TIME_COLUMNS, *channels) if c in header}
        _time_column(idx, inputs, outputs, f"data {p.name!r}")  # as measured() will, before the rows are read
        return idx, [c for c in TIME_COLUMNS if c in idx and c not in channels]  # absolute time: exact

    return measured(read_table(p, "data", choose).values, inputs=inputs, outputs=outputs, name=p.stem, source=p.name)


def _time_column(columns: Mapping[str, Any], inputs: Sequence[str], outputs: Sequence[str], where: str) -> str:
    """The name of the time column of ``columns``, refused when there is none, two, or only a model channel's,
    or when a model input or output has no column."""
    channels = (*inputs, *outputs)
    found = [c for c in TIME_COLUMNS if c in columns and c not in channels]
    if len(found) > 1:
        raise DataError(f"{where}: two time columns {found}; keep one, 'time_s'")
    taken = [c for c in TIME_COLUMNS if c in channels]
    if not found and taken and taken[0] in columns:
        raise DataError(f"{where}: the column {taken[0]!r} is a model input or output, so it cannot also be the "
                        f"time column; add the time in seconds as a column 'time_s'")
    if not found:
        raise DataError(f"{where}: no time column; name it 'time_s' (seconds) or 't'")
    missing = [c for c in channels if c not in columns]
    if missing:
        raise DataError(f"{where}: no column for {', '.join(repr(c) for c in missing)}; add one per model input "
                        f"and output, named as in the model ({', '.join(channels)})")
    return found[0]


def estimate_noise(x: Any, *, orders: Sequence[int] = (2, 3, 4)) -> tuple[float, str]:
    """Noise-to-signal RMS ratio of one channel, from its high-frequency residual.

    For each order ``k`` the noise std is estimated robustly from the ``k``-th differences,
    ``s_k = MAD(diff^k x) / 0.6745 / sqrt(C(2k, k))`` (exact for white Gaussian noise); the smallest
    ``s_k`` is taken (the signal's share of the differences falls with ``k`` for an oversampled
    channel). When the ``s_k`` disagree by more than 50 % the signal is not oversampled enough and the
    estimate is only an upper bound: the note says so.

    Parameters
    ----------
    x : Any
        The samples of one channel.
    orders : sequence of int
        Difference orders tried.

    Returns
    -------
    tuple
        ``(ratio, note)``: noise std over the RMS of ``x``, and how it was obtained.

    Raises
    ------
    DataError
        Fewer than :data:`MIN_SAMPLES` samples.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(4000) * 0.01
    >>> x = np.sin(2 * np.pi * 0.5 * t)
    >>> r, note = estimate_noise(x + 0.02 * np.sqrt(0.5) * rng.standard_normal(t.size))
    >>> round(r, 3)
    0.02
    """
    x = np.asarray(x, float)
    if x.size < MIN_SAMPLES:
        raise DataError(f"a channel of {x.size} samples: {_TOO_SHORT}")
    scale = float(np.sqrt(np.mean(x ** 2)))
    if scale == 0:
        return NOISE_FLOOR, "a zero channel: noise set to the floor"
    est = []
    for k in orders:
        d = np.diff(x, k)
        est.append(float(np.median(np.abs(d - np.median(d))) / 0.6745 / np.sqrt(comb(2 * k, k))))
    s = min(est)
    spread = max(est) / max(s, 1e-300)
    note = f"from the differences of orders {list(orders)} (noise std {s:.3g})"
    if spread > 1.5:
        note += f"; they disagree by a factor {spread:.2g}: the channel is not oversampled, {UPPER_BOUND}"
    return s / scale, note
