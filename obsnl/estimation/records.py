"""Records: ground-motion CSV and PEER AT2 readers with validation, resampling, measurement noise.

A :class:`~obsnl.estimation.accelerogram.Record` is an evenly sampled acceleration history in m/s²; the
readers here refuse NaN/inf, non-increasing or irregular time steps and truncated files with a
:class:`~obsnl.errors.DataError` that names the line and the fix.

CSV files (records, and measured data in :mod:`obsnl.estimation.measured`) may start with a byte-order
mark and separate their columns by commas, semicolons or tabs (:func:`read_table`). Time is counted from
the first sample: absolute (epoch) time near 1.7e9 s is accepted, its first time subtracted exactly
(:func:`times_from_text`). A message quotes at most 80 characters of the user's text.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from decimal import Decimal, InvalidOperation
from pathlib import Path
from typing import Any

import numpy as np

from obsnl.errors import DataError
from obsnl.model.bounds.textsize import quote
from obsnl.estimation.accelerogram import G, Record, check_times

__all__ = [
    "check_seconds", "read_text", "read_record", "read_csv", "read_at2", "add_noise", "rms",
    "MAX_FILE_BYTES", "read_table", "times_from_text",
]


def read_csv(path: str | Path, *, column: str | int | None = None) -> Record:
    """Read a CSV with a header: a time column (``time*`` or ``t``) and an acceleration column.

    Parameters
    ----------
    path : str or Path
        The file; values in m/s², time in s; columns separated by commas, semicolons or tabs.
    column : str or int or None
        Name or index of the acceleration column (default: the one whose name starts with ``acc``, or
        the only column besides time; anything else is refused, never guessed).
    """
    p = Path(path)
    sep, header, body = read_table(p, "record")
    times = [i for i, h in enumerate(header) if h.lower().startswith("time") or h.lower() == "t"]
    if not times:
        raise DataError(f"{str(p)!r}: no time column in header {quote(header)} (name it 'time_s')")
    if len(times) > 1:
        raise DataError(f"{str(p)!r}: {len(times)} time columns {[header[i] for i in times]}; keep one, 'time_s'")
    tcol = times[0]
    check_seconds(header[tcol], str(p))
    if column is None:  # by name: a column called acc..., else the only column besides time
        others = [i for i in range(len(header)) if i != tcol]
        named = [i for i in others if header[i].lower().startswith("acc")]
        pick = named if named else others
        if len(pick) != 1:
            raise DataError(f"{str(p)!r}: cannot tell the acceleration column among "
                            f"{quote([header[i] for i in pick])}; name it 'accel_m_s2' (or keep only time and "
                            f"acceleration)")
        acol: int | None = pick[0]
    elif isinstance(column, int):
        acol = column
    else:
        acol = header.index(column) if column in header else None
    if acol is None or not 0 <= acol < len(header):
        raise DataError(f"{str(p)!r}: no acceleration column {quote(column)} in header {quote(header)}")
    tcells: list[str] = []
    accel: list[float] = []
    numbers: list[int] = []
    for n, cells in body:
        try:
            float(cells[tcol])
            accel.append(float(cells[acol]))
        except ValueError:
            raise DataError(f"{str(p)!r} line {n}: not a number: {quote(sep.join(cells).strip())}") from None
        tcells.append(cells[tcol])
        numbers.append(n)
    t, start = times_from_text(tcells)
    arr = np.column_stack([t, np.array(accel, float)]).reshape(-1, 2)
    bad = np.flatnonzero(~np.all(np.isfinite(arr), axis=1))
    if bad.size:
        raise DataError(f"{str(p)!r} line {numbers[bad[0]]}: NaN/inf value ({bad.size} bad rows); clean the record "
                        f"first")
    dt = check_times(arr[:, 0], str(p))
    notes = (f"the time column starts at {start:.10g} s (absolute time?): counted from the first sample",) \
        if abs(start) >= _ABSOLUTE else ()
    return _moving(Record(p.stem, arr[:, 1], dt, source=p.name, notes=notes))


#: Separators of a CSV's columns.
SEPARATORS = (",", ";", "\t")


def read_table(p: Path, what: str) -> tuple[str, list[str], Iterator[tuple[int, list[str]]]]:
    """The cells of a CSV file with a header line (shared by the record and data readers).

    The header is the first line that is not blank; its separator is the one of :data:`SEPARATORS` it uses
    most. Refused: a header of one column (every file has a time column and a channel), a line with
    another number of cells, and a number with a decimal comma (``0,01`` in a file separated by semicolons).

    Parameters
    ----------
    p : Path
        The file (read by :func:`read_text`).
    what : str
        What it is, for the messages (``"record"``, ``"data"``).

    Returns
    -------
    tuple
        ``(separator, column names, rows)``: the names stripped (refused when one repeats), the rows an
        iterator of ``(line number, cells)`` over the lines that are not blank, each checked as it comes.
    """
    lines = [(n, line) for n, line in enumerate(read_text(p, what).splitlines(), start=1) if line.strip()]
    where = f"{what} {str(p)!r}"
    if not lines:
        raise DataError(f"{where} is empty; give a header line, then samples")
    head = lines[0][1]
    counts = {c: head.count(c) for c in SEPARATORS}
    sep = max(counts, key=lambda c: counts[c])
    if not counts[sep]:
        raise DataError(f"{where}: the header {quote(head.strip())} has a single column; separate the columns "
                        f"(time, then one per channel) with commas")
    header = [h.strip() for h in head.split(sep)]
    twice = next((h for h in header if header.count(h) > 1), None)
    if twice is not None:  # it would be read from one of its columns, silently
        raise DataError(f"{where}: column {quote(twice)} appears {header.count(twice)} times in the header; rename "
                        f"or remove the copies")
    return sep, header, _cells(lines[1:], sep, len(header), where)


def _cells(lines: list[tuple[int, str]], sep: str, width: int, where: str) -> Iterator[tuple[int, list[str]]]:
    """The cells of each numbered line, checked (:func:`read_table`); a generator: a million rows are not held."""
    for n, line in lines:
        cells = line.split(sep)
        if len(cells) != width:
            raise DataError(f"{where} line {n}: {len(cells)} fields, the header has {width}")
        comma = next((c for c in cells if _DECIMAL_COMMA.fullmatch(c)), None) if sep != "," else None
        if comma is not None:
            raise DataError(f"{where} line {n}: {quote(comma.strip())} has a decimal comma; write numbers with a "
                            f"decimal point (0.01)")
        yield n, cells


_DECIMAL_COMMA = re.compile(r"\s*[-+]?\d*,\d+(?:[eE][-+]?\d+)?\s*")


#: Times from this size on (s) look absolute (Unix epoch time is 1.7e9 s): a file's are subtracted exactly.
_ABSOLUTE = 1e4


def times_from_text(cells: list[str]) -> tuple[np.ndarray, float]:
    """The times of a file's time column, counted from the first, and the first time. From a first time
    of :data:`_ABSOLUTE` on (absolute, epoch time) the subtraction is exact, on the decimal text: as floats
    near 1.7e9 the times carry rounding errors of 1e-7 s, enough to make an even 1 kHz step look irregular.

    Parameters
    ----------
    cells : list of str
        The time column's cells (each one a number).

    Returns
    -------
    tuple
        ``(times - first time, first time)``.

    Examples
    --------
    >>> t, start = times_from_text(["1700000000.001", "1700000000.002"])
    >>> t.tolist(), start
    ([0.0, 0.001], 1700000000.001)
    """
    t = np.array([float(c) for c in cells], float)
    if not len(t) or not np.isfinite(t[0]) or abs(t[0]) < _ABSOLUTE:
        return t, 0.0
    start = float(t[0])
    try:
        first = Decimal(cells[0].strip())
        return np.array([float(Decimal(c.strip()) - first) for c in cells], float), start
    except (InvalidOperation, ValueError):  # a form float reads and Decimal does not: float difference
        return t - t[0], start


#: Largest record or data file read (bytes): a long measured record of ten channels and a million
#: samples is about 150 MB as CSV.
MAX_FILE_BYTES = 1 << 30


def read_text(p: Path, what: str) -> str:
    """The UTF-8 text of the file ``p`` (without a byte-order mark), refused with one line otherwise (shared by
    the record and data readers).

    Parameters
    ----------
    p : Path
        The file.
    what : str
        What it is, for the messages (``"record"``, ``"data"``).

    Returns
    -------
    str

    Raises
    ------
    DataError
        A folder, a missing file, a file over :data:`MAX_FILE_BYTES`, not UTF-8, or unreadable.
    """
    if p.is_dir():
        raise DataError(f"{what} {str(p)!r} is a folder; give a file")
    if not p.is_file():
        raise DataError(f"{what} {str(p)!r} does not exist")
    try:
        size = p.stat().st_size
        if size > MAX_FILE_BYTES:
            raise DataError(f"{what} {str(p)!r} has {size / 2**20:.0f} MiB; obsnl reads at most "
                            f"{MAX_FILE_BYTES >> 20} MiB (cut the record, or decimate it)")
        return p.read_bytes().decode("utf-8").removeprefix("\ufeff")  # a byte-order mark (Excel writes one)
    except UnicodeDecodeError as exc:
        raise DataError(f"{what} {str(p)!r} is not UTF-8 text (byte {exc.start}); save it as a UTF-8 CSV") from None
    except OSError as exc:
        raise DataError(f"cannot read {str(p)!r}: {exc.strerror or exc}") from None


def check_seconds(name: str, where: str) -> None:
    """Refuse a time column whose name gives another unit than seconds (``time_ms``, ``t_min``, ...).

    Parameters
    ----------
    name : str
        The time column's name.
    where : str
        The file, for the message.

    Raises
    ------
    DataError
        A unit other than seconds after ``_``, ``[``, ``(`` or a space.

    Examples
    --------
    >>> check_seconds("time_s", "d.csv"), check_seconds("t", "d.csv")
    (None, None)
    >>> check_seconds("time_ms", "d.csv")
    Traceback (most recent call last):
    ...
    obsnl.errors.DataError: d.csv: the time column 'time_ms' is not in seconds; give the time in seconds as 'time_s'
    """
    unit = re.split(r"[_\[(\s]+", name.strip().lower().rstrip(")]"), maxsplit=1)[1:]
    if unit and unit[0] not in ("s", "sec", "secs", "second", "seconds"):
        raise DataError(f"{where}: the time column {quote(name)} is not in seconds; give the time in seconds as "
                        f"'time_s'")


def _moving(rec: Record) -> Record:
    """Refuse a record without motion (every sample 0: no excitation, a zero noise level), with values
    beyond 1e100 in magnitude (the filters square them) or a step outside 1e-6..1 s (a ground motion is
    sampled at 1-1000 Hz and more; a step of 20 is a time column in milliseconds)."""
    if not np.any(rec.accel):
        raise DataError(f"record {rec.name!r}: every sample is 0 (no ground motion); give a record with excitation")
    peak = float(np.max(np.abs(rec.accel)))
    if peak > 1e100:
        raise DataError(f"record {rec.name!r} reaches {peak:.3g}; rescale it (the record is read in m/s^2)")
    if not 1e-6 <= rec.dt <= 1.0:
        raise DataError(f"record {rec.name!r} is sampled every {rec.dt:.3g} s; a ground motion is sampled every "
                        f"1e-6 to 1 s: check that the time is in seconds")
    return rec


_AT2_HEAD = re.compile(r"NPTS\s*=\s*(\d+)\s*,?\s*DT\s*=\s*([0-9.eE+-]+)", re.IGNORECASE)


def read_at2(path: str | Path) -> Record:
    """Read a PEER NGA ``.AT2`` file (4 header lines, ``NPTS=..., DT=...``, values in g) into m/s²."""
    p = Path(path)
    lines = read_text(p, "record").splitlines()
    if len(lines) < 5:
        raise DataError(f"{str(p)!r}: too short for a PEER AT2 file (4 header lines, then values)")
    mt = _AT2_HEAD.search(lines[3])
    if not mt:
        raise DataError(f"{str(p)!r} line 4: expected 'NPTS= n, DT= dt', got {quote(lines[3].strip())}")
    try:
        npts, dt = int(mt.group(1)), float(mt.group(2))
    except ValueError:
        raise DataError(f"{str(p)!r} line 4: DT={mt.group(2)!r} is not a number") from None
    if not (np.isfinite(dt) and dt > 0):
        raise DataError(f"{str(p)!r} line 4: DT={mt.group(2)!r} must be a positive time step in seconds")
    if "UNITS OF G" not in lines[2].upper():
        raise DataError(f"{str(p)!r} line 3: expected acceleration in units of g, got {quote(lines[2].strip())}")
    values: list[float] = []
    for n, line in enumerate(lines[4:], start=5):
        for tok in line.split():
            try:
                values.append(float(tok))
            except ValueError:
                raise DataError(f"{str(p)!r} line {n}: not a number: {quote(tok)}") from None
    if len(values) < npts:
        raise DataError(f"{str(p)!r}: header says NPTS={npts} but the file holds {len(values)} values (truncated?)")
    row = max((len(line.split()) for line in lines[4:]), default=1)
    extra = values[npts:]
    if extra and not (len(extra) < row and not any(extra)):  # zeros filling the last row are padding
        raise DataError(f"{str(p)!r}: header says NPTS={npts} but the file holds {len(values)} values; correct NPTS "
                        f"(obsnl does not cut a record to its header's count)")
    a = np.array(values[:npts]) * G
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        raise DataError(f"{str(p)!r}: NaN/inf at sample {bad[0]}")
    return _moving(Record(p.stem, a, dt, source=f"{p.name}: {lines[1].strip()}"))


def read_record(path: str | Path) -> Record:
    """Read a record by extension: ``.AT2`` (PEER) or ``.csv``."""
    suffix = Path(path).suffix.lower()
    if suffix == ".at2":
        return read_at2(path)
    if suffix == ".csv":
        return read_csv(path)
    raise DataError(f"{quote(str(path))}: unknown record type {quote(suffix, 20)}; use a .csv (time_s,accel_m_s2) or "
                    f"a PEER .AT2")


def rms(x: Any) -> float:
    """Root mean square of ``x`` (all entries)."""
    x = np.asarray(x, float)
    return float(np.sqrt(np.mean(x ** 2)))


def add_noise(signal: Any, *, ratio: float, seed: int | np.random.Generator | None = None) -> np.ndarray:
    """``signal`` plus Gaussian white noise with RMS ``ratio * rms(signal)`` per column.

    Parameters
    ----------
    signal : array_like
        Samples along the first axis, one column per channel.
    ratio : float
        Noise-to-signal RMS ratio, non-negative.
    seed : int, numpy.random.Generator or None
        Seed or generator of the noise.

    Returns
    -------
    numpy.ndarray

    Raises
    ------
    DataError
        When ``ratio`` is negative or not finite.

    Examples
    --------
    >>> x = np.sin(np.linspace(0, 10, 1000))
    >>> noisy = add_noise(x, ratio=0.01, seed=0)
    >>> round(rms(noisy - x) / rms(x), 3)
    0.01
    """
    if not (np.isfinite(ratio) and ratio >= 0):
        raise DataError(f"noise ratio must be >= 0, got {ratio!r}")
    x = np.asarray(signal, float)
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    scale = np.sqrt(np.mean(x ** 2, axis=0)) * ratio
    return x + scale * rng.standard_normal(x.shape)
