"""Measured data: a table of the model's inputs and outputs against time, and their noise levels.

A measured record is a CSV with a header: a time column (``time_s`` or ``t``) and one column per model
input and per model output, named as in the model (units are the user's). Columns the model does not use
are ignored and named in :attr:`Measured.ignored`. :func:`read_measured` reads and validates it (the file
conventions of :mod:`obsnl.estimation.records`: a byte-order mark, commas, semicolons or tabs, absolute time
counted from the first sample); :func:`measured` does the same for columns the caller already holds (a
mapping of name to samples).

Records as they come:

- The clock. Sample ``k`` is taken at ``k * dt`` after the first (``dt`` the mean step). A logger's clock
  jitters: a time column whose samples all lie within :data:`CLOCK_TOLERANCE` of the median step of ``k * dt``
  is read as regular, and the largest deviation is kept (:attr:`Measured.clock_deviation`, in steps) and
  reported. Beyond it the record is refused, naming the worst sample: resample it onto a regular clock first.
  (Within the tolerance the timing error of an input sample is at most ``1e-3 dt``: for a signal well below
  the Nyquist frequency, a relative error of its sample of order ``2 pi f dt * 1e-3``, far below any noise.)
- Gaps in the outputs. An output sampled more slowly than the inputs, or with gaps, has empty cells (a CSV)
  or NaN (Python): a missing sample. The filters update with the outputs present at each sample (none: the
  prediction is kept) and the likelihood gives a missing sample no weight; it counts in no sample count.
  The inputs drive the model and must be complete: a gap in an input is refused, naming the column and the
  sample.

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

import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from math import comb
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from obsnl._text import block, names, number, one_line, plain_float
from obsnl.errors import DataError, refuse_non_path
from obsnl.estimation.accelerogram import Record, check_increasing, check_seconds
from obsnl.estimation.records import read_table
from obsnl.model.bounds.textsize import quote

if TYPE_CHECKING:  # pandas loads when a DataFrame is given
    import pandas as pd

__all__ = [
    "Measured",
    "measured",
    "read_measured",
    "as_measured",
    "estimate_noise",
    "is_frame",
    "frame_columns",
    "NOISE_FLOOR",
    "TIME_COLUMNS",
    "MIN_SAMPLES",
    "UPPER_BOUND",
    "CLOCK_TOLERANCE",
]

#: Accepted names of the time column (seconds).
TIME_COLUMNS = ("time_s", "t")
#: Smallest noise-to-signal ratio a filter is given: one that trusts its model more than this is brittle.
NOISE_FLOOR = 1e-3
#: Fewest samples identified from: the noise levels come from differences of order up to 4, and a filter
#: needs many samples per unknown (3 samples ran to an "estimate" with numpy warnings).
MIN_SAMPLES = 20
#: The largest deviation of a sample time from ``k * dt``, as a fraction of the median step, that is read as a
#: regular clock (a logger's jitter); beyond it the record is refused (resample it onto a regular clock).
CLOCK_TOLERANCE = 1e-3
#: How :func:`estimate_noise`'s note ends when the estimate is only an upper bound (the channel is not oversampled).
UPPER_BOUND = "this is an upper bound"
_TOO_SHORT = (
    f"identification needs at least {MIN_SAMPLES} samples (noise levels are estimated from 4th "
    f"differences, and a filter needs many samples per unknown); give a longer record"
)


@dataclass(frozen=True, eq=False)
class Measured:
    """Measured inputs ``u`` ``(T, nu)`` and outputs ``y`` ``(T, ny)`` at an even step ``dt``.

    ``y`` is NaN at a missing output sample (:attr:`present`); ``u`` is complete. ``clock_deviation``: the
    largest deviation of a sample time from ``k * dt``, as a fraction of ``dt`` (at most
    :data:`CLOCK_TOLERANCE`); ``ignored``: the columns of the record that the model does not use.
    """

    name: str
    dt: float
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    u: np.ndarray
    y: np.ndarray
    source: str = ""
    clock_deviation: float = 0.0
    ignored: tuple[str, ...] = ()

    @property
    def t(self) -> np.ndarray:
        return np.arange(len(self.y)) * self.dt

    @property
    def present(self) -> np.ndarray:
        """``(T, ny)``: True where an output sample was measured, False at a gap."""
        return ~np.isnan(self.y)

    @property
    def missing(self) -> dict[str, int]:
        """The number of missing samples of each output (0 for a complete one)."""
        return {c: int(n) for c, n in zip(self.outputs, np.sum(~self.present, axis=0))}

    def record(self) -> Record:
        """The inputs as a :class:`~obsnl.estimation.accelerogram.Record` (one column per input); refused with fewer
        than :data:`MIN_SAMPLES` samples, or an output with fewer than that measured."""
        if len(self.y) < MIN_SAMPLES:
            raise DataError(f"data {self.source or self.name!r} have {len(self.y)} samples; {_TOO_SHORT}")
        for c, n in zip(self.outputs, np.sum(self.present, axis=0)):
            if n < MIN_SAMPLES:
                raise DataError(
                    f"output {c!r} of data {self.source or self.name!r} has {int(n)} samples measured "
                    f"(the others are gaps); {_TOO_SHORT}"
                )
        return Record(
            self.name, self.u if self.u.shape[1] != 1 else self.u[:, 0], self.dt, self.source, channels=self.inputs
        )

    def __repr__(self) -> str:
        return one_line(
            "Measured",
            f"name={self.name!r}",
            f"samples={len(self.y)}",
            f"dt={number(self.dt)} s",
            f"inputs={names(self.inputs, 4)!r}",
            f"outputs={names(self.outputs, 4)!r}",
        )

    def notes(self) -> tuple[str, ...]:
        """What reading the record took as given: the clock read as regular, the gaps of the outputs, the
        columns ignored (one sentence each; none for an exactly regular, complete record without other columns)."""
        return tuple(x for x in (self._clock_note() if self.clock_deviation > 1e-9 else "", *self._other_notes()) if x)

    def _clock_note(self) -> str:
        return (
            f"the time column is read as a regular clock of step {number(self.dt)} s: its samples lie within "
            f"{self.clock_deviation:.2g} of a step of k*dt (tolerance {CLOCK_TOLERANCE:g} of a step)"
        )

    def _other_notes(self) -> tuple[str, str]:
        gaps = [f"{c} {n} of {len(self.y)}" for c, n in self.missing.items() if n]
        return (
            f"output samples missing (skipped by the filter, no weight in the likelihood): {names(gaps, 8)}"
            if gaps
            else "",
            f"columns ignored (the model does not use them): {names(self.ignored, 8)}" if self.ignored else "",
        )

    def summary(self) -> str:
        """A few lines of plain text: length, step, the channels and their RMS (over the samples measured), the
        clock, the gaps and the columns ignored, where the data came from."""
        rms = [
            f"{c} {number(float(np.sqrt(np.nanmean(v**2))))}"
            for c, v in [*zip(self.inputs, self.u.T), *zip(self.outputs, self.y.T)]
        ]
        return block(
            f"measured {self.name}: {len(self.y)} samples at dt = {number(self.dt)} s",
            f"source: {self.source}" if self.source else "",
            f"inputs: {names(self.inputs, 8)}; outputs: {names(self.outputs, 8)}",
            f"RMS: {names(rms, 10)}",
            self._clock_note(),
            *self._other_notes(),
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "source": self.source,
            "dt": self.dt,
            "samples": len(self.y),
            "inputs": list(self.inputs),
            "outputs": list(self.outputs),
            "clock_deviation": self.clock_deviation,
            "clock_tolerance": CLOCK_TOLERANCE,
            "missing": self.missing,
            "ignored": list(self.ignored),
        }


def measured(
    columns: Mapping[str, Any] | pd.DataFrame,
    *,
    inputs: Sequence[str],
    outputs: Sequence[str],
    name: str = "data",
    source: str = "",
) -> Measured:
    """Measured data from columns (a time column and one per input and output).

    Parameters
    ----------
    columns : mapping of str to Any, or pandas.DataFrame
        ``{name: samples}``; the time column is ``time_s`` or ``t``; other columns are ignored (and named in
        :attr:`Measured.ignored`). NaN in an output column is a missing sample. A DataFrame is read by
        :func:`frame_columns` (its time a column, or its index).
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
        NaN in the time or an input column or inf anywhere (column and sample named), an output never
        measured, a time that does not increase or deviates from a regular clock by more than
        :data:`CLOCK_TOLERANCE` of a step, fewer than 3 samples.

    Examples
    --------
    >>> m = measured({"t": [0, 0.1, 0.2], "f": [0, 1, 0], "x": [0, 0.1, 0.3]}, inputs=["f"], outputs=["x"])
    >>> m.u.shape, m.y.shape, m.dt
    ((3, 1), (3, 1), 0.1)
    >>> m = measured({"t": [0, 0.1, 0.2], "f": [0, 1, 0], "x": [0, float("nan"), 0.3], "note": [1, 2, 3]},
    ...              inputs=["f"], outputs=["x"])
    >>> m.missing, m.ignored
    ({'x': 1}, ('note',))
    """
    where = f"data {source or name!r}"
    if is_frame(columns):
        columns = frame_columns(columns, where=where)
    tname = _time_column(columns, inputs, outputs, where)
    arrays = {}
    for c in (tname, *inputs, *outputs):
        kind = {"c": "complex numbers", "M": "dates", "m": "time spans", "b": "booleans"}.get(
            np.asarray(columns[c]).dtype.kind
        )
        if kind or np.ma.is_masked(columns[c]):  # read as floats they would lose a part, or a mask, silently
            raise DataError(
                f"{where}: column {quote(c)} holds {kind or 'masked samples'}; give real numbers (time in "
                f"seconds), every sample present (NaN marks a missing output sample)"
            )
        try:
            a = _cells(columns[c])
        except (TypeError, ValueError, OverflowError) as exc:
            said = f" ({exc})" if "'_'" in str(exc) else ""  # the CSV reader's rule: "1_0" is not 10
            raise DataError(
                f"{where}: column {quote(c)} is not numeric (or beyond the float range){said}; give plain numbers"
            ) from None
        if a.ndim != 1:
            raise DataError(f"{where}: column {c!r} must be one series, got shape {a.shape}")
        gap = c in outputs and c != tname  # an output may miss samples (NaN); time and inputs may not
        bad = np.flatnonzero(np.isinf(a) if gap else ~np.isfinite(a))
        if bad.size:
            fix = (
                "an input drives the model at every sample (only outputs may have gaps): fill the gap (interpolate "
                "the input) or cut the record there"
                if c in inputs and c != tname
                else "clean or interpolate the record first"
            )
            raise DataError(f"{where}: column {c!r} has NaN/inf at sample {bad[0]} ({bad.size} bad samples); {fix}")
        if gap and a.size and np.all(np.isnan(a)):
            raise DataError(
                f"{where}: output column {c!r} has no sample (every cell is empty or NaN); measure it, "
                f"or remove the output from the model"
            )
        if c != tname and a.size and np.nanmax(np.abs(a)) > 1e100:  # squared by the noise levels and the filter
            raise DataError(
                f"{where}: column {c!r} reaches {float(np.nanmax(np.abs(a))):.3g}; rescale it (check its units)"
            )
        arrays[c] = a
    lengths = {len(a) for a in arrays.values()}
    if len(lengths) != 1:
        raise DataError(f"{where}: the columns have different lengths {sorted(lengths)}")
    if lengths.pop() < 3:
        raise DataError(f"{where}: need at least 3 samples")
    dt, deviation = _clock(arrays[tname], where, tname)
    col = lambda names: np.column_stack([arrays[c] for c in names]) if names else np.zeros((len(arrays[tname]), 0))  # noqa: E731
    used = {tname, *inputs, *outputs}
    return Measured(
        name=name,
        dt=dt,
        inputs=tuple(inputs),
        outputs=tuple(outputs),
        u=col(inputs),
        y=col(outputs),
        source=source,
        clock_deviation=deviation,
        ignored=tuple(str(c) for c in columns if c not in used),
    )


def _cells(cells: Any) -> np.ndarray:
    """A column's samples as floats, a text cell read as a record cell is (:func:`obsnl._text.plain_float`:
    ``"1_0"`` is refused, where ``float`` reads it as 10)."""
    raw = np.asarray(cells)
    if raw.dtype.kind in "USO" and any(isinstance(v, (str, bytes)) for v in raw.ravel()):
        return np.array(
            [
                plain_float(v.decode() if isinstance(v, bytes) else str(v)) if isinstance(v, (str, bytes)) else float(v)
                for v in raw.ravel()
            ],
            float,
        ).reshape(raw.shape)
    return np.asarray(cells, float)


def is_frame(x: Any) -> bool:
    """Whether ``x`` is a pandas DataFrame (pandas is not imported for the question).

    Examples
    --------
    >>> is_frame({"t": [0, 1]})
    False
    """
    pd = sys.modules.get("pandas")
    return pd is not None and isinstance(x, pd.DataFrame)


def frame_columns(frame: Any, *, where: str = "data") -> dict[str, np.ndarray]:
    """The columns of a pandas DataFrame as :func:`measured` reads them, with its time in seconds.

    The time is a column ``time_s`` or ``t`` (seconds) when the frame has one; otherwise its index: a
    ``DatetimeIndex`` or a ``TimedeltaIndex`` (seconds from the first sample) or a float index (seconds), which
    becomes the column ``time_s``. A frame with neither (a default integer index: sample numbers, no clock) is
    refused.

    Parameters
    ----------
    frame : pandas.DataFrame
        One column per input and output, named as in the model.
    where : str
        How messages name the data.

    Returns
    -------
    dict of str to numpy.ndarray

    Raises
    ------
    DataError
        Column names that are not text or repeat, or no time (no time column, and an index that is not a time).

    Examples
    --------
    >>> import pandas as pd
    >>> f = pd.DataFrame({"F": [0.0, 1.0, 0.0], "x": [0.0, 0.1, 0.3]}, index=pd.Index([0.0, 0.1, 0.2], name="s"))
    >>> sorted(frame_columns(f)), frame_columns(f)["time_s"].tolist()
    (['F', 'time_s', 'x'], [0.0, 0.1, 0.2])
    >>> f = pd.DataFrame({"F": [0.0, 1.0]}, index=pd.date_range("2024-01-01", periods=2, freq="500ms"))
    >>> frame_columns(f)["time_s"].tolist()
    [0.0, 0.5]
    """
    import pandas as pd

    names = [c for c in frame.columns]
    if any(not isinstance(c, str) for c in names) or len(set(names)) < len(names):
        raise DataError(
            f"{where}: the DataFrame's columns must be distinct names (text), as in the model; got {quote(names)}"
        )
    columns = {c: frame[c].to_numpy() for c in names}
    if any(c in columns for c in TIME_COLUMNS):
        return columns
    index = frame.index
    if isinstance(index, (pd.DatetimeIndex, pd.TimedeltaIndex)):
        t = np.asarray((index - index[0]).total_seconds(), float)
    elif pd.api.types.is_float_dtype(index.dtype):
        t = index.to_numpy(float)
    else:
        raise DataError(
            f"{where}: the DataFrame has no time column and its index is not a time ({index.dtype}); "
            f"add a column 'time_s' (seconds), or index it by time (a DatetimeIndex, or seconds as "
            f"floats)"
        )
    return {"time_s": t, **columns}


def _clock(t: np.ndarray, where: str, tname: str) -> tuple[float, float]:
    """``(dt, deviation)``: the mean step of the sample times ``t`` and the largest deviation of a sample time from
    ``k * dt`` after the first, as a fraction of ``dt``; refused beyond :data:`CLOCK_TOLERANCE` of the median
    step (and a time that does not increase, or too large to resolve the step:
    :func:`~obsnl.estimation.accelerogram.check_increasing`). The rounding of the time values themselves is
    allowed on top of the tolerance."""
    rounding = check_increasing(t, where)
    dt = float(t[-1] - t[0]) / (len(t) - 1)
    off = np.abs((t - t[0]) - np.arange(len(t)) * dt)
    k = int(np.argmax(off))
    if off[k] > CLOCK_TOLERANCE * float(np.median(np.diff(t))) + 2 * rounding:
        raise DataError(
            f"{where}: irregular time step: sample {k} of {tname!r} (t = {float(t[k]):.10g} s) is "
            f"{off[k] / dt:.3g} of a step off k*dt (dt = {dt:.6g} s; up to {CLOCK_TOLERANCE:g} of a step "
            f"is read as regular); resample the record onto a regular clock first"
        )
    return dt, float(off[k] / dt)


def read_measured(path: str | Path, *, inputs: Sequence[str], outputs: Sequence[str]) -> Measured:
    """Read a measured record (CSV with header; see the module docstring).

    Parameters
    ----------
    path : str or Path
        The CSV file.
    inputs, outputs : sequence of str
        The model's input and output names: the columns read (others are ignored, and named in
        :attr:`Measured.ignored`). An empty cell (or NaN) in an output column is a missing sample.

    Returns
    -------
    Measured

    Raises
    ------
    DataError
        A missing file or column, a non-numeric cell or an empty one in the time or an input column (line and
        column named), NaN in an input, a bad time column (:func:`measured`).

    Examples
    --------
    >>> import tempfile, os
    >>> p = os.path.join(tempfile.mkdtemp(), "d.csv")
    >>> _ = open(p, "w").write("time_s,f,x,note\\n0,0,0,a\\n0.1,1,0.1,b\\n0.2,0,0.3,c\\n")
    >>> read_measured(p, inputs=["f"], outputs=["x"]).y.ravel().tolist()
    [0.0, 0.1, 0.3]
    >>> _ = open(p, "w").write("time_s,f,x,note\\n0,0,0,a\\n0.1,1,,b\\n0.2,0,0.3,c\\n")
    >>> m = read_measured(p, inputs=["f"], outputs=["x"])
    >>> m.y.ravel().tolist(), m.ignored
    ([0.0, nan, 0.3], ('note',))
    """
    refuse_non_path(path, "read_measured takes the path of a CSV file")
    p = Path(path)
    channels, where = (*inputs, *outputs), f"data {str(p)!r}"
    ignored: list[str] = []

    def choose(header: list[str]) -> tuple[dict[str, int], list[str], list[str]]:
        for h in header:  # a time column in other units (time_ms) is not read as seconds
            if h.lower().startswith("time") and h not in TIME_COLUMNS and h not in channels:
                check_seconds(h, where)
        idx = {c: header.index(c) for c in (*TIME_COLUMNS, *channels) if c in header}
        _time_column(idx, inputs, outputs, f"data {p.name!r}")  # as measured() will, before the rows are read
        ignored.extend(h for h in header if h not in idx)
        times = [c for c in TIME_COLUMNS if c in idx and c not in channels]  # absolute time: exact
        return idx, times, [c for c in outputs if c not in times]  # an empty output cell: a missing sample

    data = measured(read_table(p, "data", choose).values, inputs=inputs, outputs=outputs, name=p.stem, source=p.name)
    return replace(data, ignored=tuple(ignored))


def as_measured(
    data: Measured | Mapping[str, Any] | str | Path,
    *,
    inputs: Sequence[str],
    outputs: Sequence[str],
    option: str = "data=",
) -> Measured:
    """Measured data in any form obsnl takes them, for a model's inputs and outputs: a CSV file
    (:func:`read_measured`), columns or a pandas DataFrame (:func:`measured`), or a :class:`Measured` whose channels
    are the model's.

    Parameters
    ----------
    data : Measured, mapping of str to Any, pandas.DataFrame, str or Path
        The data.
    inputs, outputs : sequence of str
        The model's input and output names, in model order.
    option : str
        How the caller names the data in messages (``data=``, ``record=``).

    Returns
    -------
    Measured

    Raises
    ------
    DataError
        Data of another kind, a :class:`Measured` of other channels, or what the readers refuse.

    Examples
    --------
    >>> as_measured({"t": [0, 0.1, 0.2], "f": [0, 1, 0], "x": [0, 0.1, 0.3]}, inputs=["f"], outputs=["x"]).dt
    0.1
    >>> as_measured(None, inputs=["f"], outputs=["x"])
    Traceback (most recent call last):
    ...
    obsnl.errors.DataError: data= takes a CSV file, a mapping of columns {name: samples}, a pandas DataFrame or a Measured; got NoneType
    """
    if isinstance(data, (str, Path)):
        return read_measured(data, inputs=inputs, outputs=outputs)
    if isinstance(data, Mapping) or is_frame(data):
        return measured(data, inputs=inputs, outputs=outputs)
    if not isinstance(data, Measured):
        raise DataError(
            f"{option} takes a CSV file, a mapping of columns {{name: samples}}, a pandas DataFrame or a "
            f"Measured; got {type(data).__name__}"
        )
    if data.inputs != tuple(inputs) or data.outputs != tuple(outputs):
        raise DataError(
            f"{option} has inputs {list(data.inputs)} and outputs {list(data.outputs)}; the model has "
            f"{list(inputs)} and {list(outputs)}"
        )
    return data


def _time_column(columns: Mapping[str, Any], inputs: Sequence[str], outputs: Sequence[str], where: str) -> str:
    """The name of the time column of ``columns``, refused when there is none, two, or only a model channel's,
    or when a model input or output has no column."""
    channels = (*inputs, *outputs)
    found = [c for c in TIME_COLUMNS if c in columns and c not in channels]
    if len(found) > 1:
        raise DataError(f"{where}: two time columns {found}; keep one, 'time_s'")
    taken = [c for c in TIME_COLUMNS if c in channels]
    if not found and taken and taken[0] in columns:
        raise DataError(
            f"{where}: the column {taken[0]!r} is a model input or output, so it cannot also be the "
            f"time column; add the time in seconds as a column 'time_s'"
        )
    if not found:
        raise DataError(f"{where}: no time column; name it 'time_s' (seconds) or 't'")
    missing = [c for c in channels if c not in columns]
    if missing:
        raise DataError(
            f"{where}: no column for {', '.join(repr(c) for c in missing)}; add one per model input "
            f"and output, named as in the model ({', '.join(channels)})"
        )
    return found[0]


def estimate_noise(x: Any, *, orders: Sequence[int] = (2, 3, 4)) -> tuple[float, str]:
    """Noise-to-signal RMS ratio of one channel, from its high-frequency residual.

    For each order ``k`` the noise std is estimated robustly from the ``k``-th differences,
    ``s_k = MAD(diff^k x) / 0.6745 / sqrt(C(2k, k))`` (exact for white Gaussian noise); the smallest
    ``s_k`` is taken (the signal's share of the differences falls with ``k`` for an oversampled
    channel). When the ``s_k`` disagree by more than 50 % the signal is not oversampled enough and the
    estimate is only an upper bound: the note says so.

    A channel with gaps (NaN: missing samples) is judged on the samples measured: the ``k``-th differences of
    ``k + 1`` measured samples evenly spaced in time (every sample, every other one, every 10th of an output
    sampled 10 times more slowly than the inputs...: the white-noise factor ``C(2k, k)`` holds for any spacing),
    taken at the smallest spacing between measured samples that gives enough of them; the note says the spacing
    when it is not every sample. Its RMS is that of the samples measured.

    Parameters
    ----------
    x : Any
        The samples of one channel (NaN where one is missing).
    orders : sequence of int
        Difference orders tried.

    Returns
    -------
    tuple
        ``(ratio, note)``: noise std over the RMS of ``x``, and how it was obtained.

    Raises
    ------
    DataError
        Fewer than :data:`MIN_SAMPLES` samples measured, or too few evenly spaced ones among the gaps.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(4000) * 0.01
    >>> x = np.sin(2 * np.pi * 0.5 * t)
    >>> r, note = estimate_noise(x + 0.02 * np.sqrt(0.5) * rng.standard_normal(t.size))
    >>> round(r, 3)
    0.02
    >>> x[1::2] = np.nan   # every other sample missing: differences at twice the step
    >>> r, note = estimate_noise(x + 0.02 * np.sqrt(0.5) * rng.standard_normal(t.size))
    >>> round(r, 2), note.endswith("every 2nd sample")
    (0.02, True)
    """
    x = np.asarray(x, float)
    seen = np.flatnonzero(~np.isnan(x))
    if seen.size < MIN_SAMPLES:
        raise DataError(
            f"a channel of {seen.size} samples"
            + (f" measured (of {x.size})" if seen.size < x.size else "")
            + f": {_TOO_SHORT}"
        )
    scale = float(np.sqrt(np.mean(x[seen] ** 2)))
    if scale == 0:
        return NOISE_FLOOR, "a zero channel: noise set to the floor"
    est, spacing = [], 1
    for k in orders:
        d, spacing_k = _even_differences(x, seen, k)
        if d.size < MIN_SAMPLES:
            continue
        spacing = max(spacing, spacing_k)
        est.append(float(np.median(np.abs(d - np.median(d))) / 0.6745 / np.sqrt(comb(2 * k, k))))
    if not est:
        raise DataError(
            f"a channel with {x.size - seen.size} gaps among {x.size} samples has too few runs of evenly "
            f"spaced samples to estimate its noise from; give its noise level"
        )
    s = min(est)
    spread = max(est) / max(s, 1e-300)
    note = f"from the differences of orders {list(orders)} (noise std {s:.3g})"
    if spread > 1.5:
        note += f"; they disagree by a factor {spread:.2g}: the channel is not oversampled, {UPPER_BOUND}"
    if seen.size < x.size:
        note += f"; {x.size - seen.size} samples missing, differences of the measured ones, " + (
            "every sample" if spacing == 1 else f"every {_ordinal(spacing)} sample"
        )
    return s / scale, note


def _even_differences(x: np.ndarray, seen: np.ndarray, k: int) -> tuple[np.ndarray, int]:
    """The ``k``-th differences of ``x`` over windows of ``k + 1`` measured samples evenly spaced in time, at the
    smallest spacing that gives at least :data:`MIN_SAMPLES` of them (no gap: every sample), and that spacing."""
    if seen.size == x.size:
        return np.diff(x, k), 1
    for step in np.unique(np.diff(seen))[:16]:  # the spacings between measured samples, smallest first
        rows = np.arange(len(x) - k * step)
        idx = rows[:, None] + step * np.arange(k + 1)[None, :]
        ok = np.all(~np.isnan(x[idx]), axis=1)
        if np.count_nonzero(ok) >= MIN_SAMPLES:
            w = np.array([(-1) ** (k - j) * comb(k, j) for j in range(k + 1)], float)
            return x[idx[ok]] @ w, int(step)
    return np.zeros(0), 0


def _ordinal(n: int) -> str:
    return f"{n}{'nd' if n == 2 else 'rd' if n == 3 else 'th'}"
