"""Records: ground-motion CSV and PEER AT2 readers with validation, resampling, measurement noise.

A :class:`~obsnl.estimation.accelerogram.Record` is an evenly sampled acceleration history in m/s²; the
readers here refuse NaN/inf, non-increasing or irregular time steps, truncated files and an acceleration
column named in other units (``accel_g``, ``a_cm_s2``) with a :class:`~obsnl.errors.DataError` that
names the line and the fix.

CSV files (records, and measured data in :mod:`obsnl.estimation.measured`) may start with a byte-order
mark and separate their columns by commas, semicolons or tabs (:func:`read_table`). Time is counted from
the first sample: absolute (epoch) time near 1.7e9 s is accepted, its first time subtracted exactly
(:func:`times_from_text`). A message quotes at most 80 characters of the user's text.

The files are untrusted, and read in bounded time and memory: only a regular file is opened (a FIFO or a
device is refused before, :func:`_open_text`), of at most :data:`MAX_FILE_BYTES`, line by line (lines of
at most :data:`MAX_LINE` characters), each number kept as 8 bytes of one array (at most
:data:`MAX_VALUES` of them). A number is plain decimal text, ASCII digits (``nan`` and ``inf`` are read,
then refused as such): Python's ``float`` also reads ``1_0`` as 10 and other digits than 0-9, refused here.
"""

from __future__ import annotations

import codecs
import os
import re
import stat
from array import array
from collections import Counter
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
from itertools import chain, repeat
from pathlib import Path
from typing import IO, NamedTuple, cast

import numpy as np

from obsnl._files import FILE_KINDS
from obsnl._text import os_error_line, shorten
from obsnl.errors import DataError, refuse_non_path
from obsnl.estimation.accelerogram import (
    ABSOLUTE_TIME,
    G,
    Record,
    acceleration_unit,
    add_noise,
    check_motion,
    check_seconds,
    check_times,
    rms,
    time_since,
    times_from_text,
)
from obsnl.model.bounds.textsize import quote

__all__ = [
    "check_seconds",
    "read_record",
    "read_csv",
    "read_at2",
    "add_noise",
    "rms",
    "Table",
    "MAX_FILE_BYTES",
    "MAX_LINE",
    "MAX_VALUES",
    "read_table",
    "times_from_text",
    "acceleration_unit",
]

#: Largest record or data file read (bytes): a long measured record of ten channels and a million
#: samples is about 150 MB as CSV.
MAX_FILE_BYTES = 1 << 30
#: Longest line (characters, its end included): a row of 10 000 channels fits.
MAX_LINE = 1 << 20
#: Most numbers kept from one file (8 bytes each: 400 MB): an hour at 1 kHz of time and ten channels is 40
#: million; a file is read row by row into one array, so memory stays within a few times the file's size.
MAX_VALUES = 50_000_000
#: Longest 4th line of an AT2 file (``NPTS=  1999, DT=   .0100 SEC``: under 100 characters).
_AT2_LINE = 1000


def read_csv(path: str | Path, *, column: str | int | None = None) -> Record:
    """Read a CSV with a header: a time column (``time*`` or ``t``) and an acceleration column.

    Parameters
    ----------
    path : str or Path
        The file; values in m/s², time in s; columns separated by commas, semicolons or tabs.
    column : str or int or None
        Name or index of the acceleration column (default: the one whose name starts with ``acc``, or
        the only column besides time; anything else is refused, never guessed). A name ending in another
        unit than m/s² (:func:`acceleration_unit`) is refused.
    """
    p = Path(path)

    def choose(header: list[str]) -> tuple[dict[str, int], tuple[str, ...]]:
        times = [i for i, h in enumerate(header) if h.lower().startswith("time") or h.lower() == "t"]
        if not times:
            raise DataError(f"{str(p)!r}: no time column in header {quote(header)} (name it 'time_s')")
        if len(times) > 1:
            raise DataError(
                f"{str(p)!r}: {len(times)} time columns {quote([header[i] for i in times])}; keep one, 'time_s'"
            )
        tcol = times[0]
        check_seconds(header[tcol], str(p))
        if column is None:  # by name: a column called acc..., else the only column besides time
            others = [i for i in range(len(header)) if i != tcol]
            named = [i for i in others if header[i].lower().startswith("acc")]
            pick = named if named else others
            if len(pick) != 1:
                raise DataError(
                    f"{str(p)!r}: cannot tell the acceleration column among "
                    f"{quote([header[i] for i in pick])}; name it 'accel_m_s2' (or keep only time "
                    f"and acceleration)"
                )
            acol: int | None = pick[0]
        else:
            acol = column if isinstance(column, int) else header.index(column) if column in header else None
        if acol is None or not 0 <= acol < len(header) or acol == tcol:
            raise DataError(f"{str(p)!r}: no acceleration column {quote(column)} in header {quote(header)}")
        unit = acceleration_unit(header[acol])
        if unit:  # read as m/s^2 it would be wrong by a factor (9.81 for g), silently
            raise DataError(
                f"{str(p)!r}: the acceleration column {quote(header[acol])} is in {unit}, not m/s^2; "
                f"convert it to m/s^2 and name it 'accel_m_s2'"
            )
        return {"t": tcol, "a": acol}, ("t",)

    table = read_table(p, "record", choose)
    if table.bad_rows:
        raise DataError(
            f"{str(p)!r} line {table.bad_line}: NaN/inf value ({table.bad_rows} bad rows); clean the record first"
        )
    dt = check_times(table.values["t"], str(p))
    start = table.starts["t"]
    notes = (
        (f"the time column starts at {start:.10g} s (absolute time?): counted from the first sample",) if start else ()
    )
    accel = np.ascontiguousarray(table.values["a"])  # not a view keeping the time column alive
    return check_motion(Record(p.stem, accel, dt, source=p.name, notes=notes))


#: Separators of a CSV's columns.
SEPARATORS = (",", ";", "\t")


class Table(NamedTuple):
    """The columns read by :func:`read_table`."""

    #: The chosen columns' values by the names ``choose`` gave (a time column counted from its first time).
    values: dict[str, np.ndarray]
    #: The first time of each time column, 0 when it is not absolute (under 1e4 s).
    starts: dict[str, float]
    #: The first line with NaN or inf in a chosen column (0: none), and how many rows have one.
    bad_line: int
    bad_rows: int


#: What a table reader's ``choose(header)`` returns: the chosen columns and the time columns, with or without the
#: columns whose empty cells are missing samples.
Chosen = tuple[Mapping[str, int], Iterable[str]] | tuple[Mapping[str, int], Iterable[str], Iterable[str]]


def read_table(p: Path, what: str, choose: Callable[[list[str]], Chosen]) -> Table:
    """The numbers of some columns of a CSV file with a header line (shared by the record and data readers).

    The header is the first line that is not blank; its separator is the one of :data:`SEPARATORS` it uses
    most. Refused: a header of one column (every file has a time column and a channel) or with a name twice,
    a line with another number of cells, a number with a decimal comma (``0,01`` in a file separated by
    semicolons), a chosen cell that is not a plain decimal number or beyond the range of floats (``1e400``),
    more than :data:`MAX_VALUES` numbers. NaN and inf are read (counted in ``bad_rows``). An empty cell is refused,
    except in the columns ``choose`` names as a third value: there it is read as NaN (a missing sample, not counted).

    Parameters
    ----------
    p : Path
        The file (opened by :func:`_open_text`).
    what : str
        What it is, for the messages (``"record"``, ``"data"``).
    choose : callable
        ``choose(header)`` (the stripped names) returns ``({name: column index}, time column names)``, optionally
        with a third value, the names whose empty cells are missing samples, or refuses the header: the columns
        read into the :class:`Table` returned.
    """
    where = f"{what} {str(p)!r}"
    with _open_text(p, what) as f:
        lines = _lines(f, where)
        head = next((line for _, line in lines if line.strip()), "")
        if not head:
            raise DataError(f"{where} is empty; give a header line, then samples")
        counts = {c: head.count(c) for c in SEPARATORS}
        sep = max(counts, key=lambda c: counts[c])
        if not counts[sep]:
            raise DataError(
                f"{where}: the header {quote(head.strip())} has a single column; separate the "
                f"columns (time, then one per channel) with commas"
            )
        header = [h.strip() for h in head.split(sep)]
        twice, many = Counter(header).most_common(1)[0]
        if many > 1:  # it would be read from one of its columns, silently
            raise DataError(
                f"{where}: column {quote(twice)} appears {many} times in the header; rename or remove the copies"
            )
        chosen, times, *gaps = choose(header)  # gaps: the columns where an empty cell is a missing sample (NaN)
        rows = _Rows(
            where,
            sep,
            header,
            list(chosen.values()),
            [c in times for c in chosen],
            [c in (gaps[0] if gaps else ()) for c in chosen],
        )
        return rows.read(f, lines, list(chosen))


#: A plain decimal number: ASCII digits, sign, point, exponent (or a spelling of NaN or inf, refused by the
#: readers as such), around it spaces; what numpy's reader takes, not ``1_0`` nor other digits than 0-9.
_NUMBER = re.compile(r"\s*[-+]?(?:(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?|(?ai:nan|inf|infinity))\s*")
_NON_FINITE = re.compile(r"\s*[-+]?(?ai:nan|inf|infinity)\s*")
_DECIMAL_COMMA = re.compile(r"\s*[-+]?\d*,\d+(?:[eE][-+]?\d+)?\s*")
#: Characters of the lines read at once (:meth:`_Rows.read`).
_CHUNK = 1 << 20


class _Rows:
    """The numbers of the chosen columns of a table's data lines (:func:`read_table`), into one array, row
    after row. The lines are read some thousand at once: a plain chunk (no decimal comma, as many cells in
    every line as in the header, numbers numpy reads: as :data:`_NUMBER`) is parsed by numpy; any other chunk
    line by line, cell by cell (:meth:`row`), which names the line and the column of a refusal."""

    def __init__(
        self, where: str, sep: str, header: list[str], idx: list[int], timed: list[bool], gaps: list[bool] | None = None
    ):
        self.where, self.sep, self.header, self.idx, self.timed = where, sep, header, idx, timed
        self.gaps = gaps or [False] * len(idx)
        self.conv: list[Callable[[str], float]] = [float] * len(idx)
        self.starts = [0.0] * len(idx)
        self.bad = [0, 0]  # first line with NaN/inf, rows with one

    def read(self, f: IO[str], lines: Iterator[tuple[int, str]], names: list[str]) -> Table:
        flat, n, first = array("d"), 0, None
        for n, line in lines:  # the first data row: does a time column start at an absolute time?
            if (first := self.row(n, line)) is not None:
                cells = line.split(self.sep)
                for j, i in enumerate(self.idx):
                    if self.timed[j] and np.isfinite(first[j]) and abs(first[j]) >= ABSOLUTE_TIME:
                        self.conv[j], self.starts[j], first[j] = time_since(cells[i]), first[j], 0.0
                flat.extend(first)
                break
        while chunk := f.readlines(_CHUNK):
            if max(map(len, chunk)) > MAX_LINE:
                n += 1 + [len(line) > MAX_LINE for line in chunk].index(True)
                raise DataError(
                    f"{self.where} line {n} is over {MAX_LINE:,} characters; a line of samples is "
                    f"short: give a CSV of one sample a line"
                )
            block = self.block(chunk, n)
            if block is None:
                flat.extend(v for k, line in enumerate(chunk, n + 1) if (row := self.row(k, line)) for v in row)
            else:
                flat.frombytes(block.tobytes())
            n += len(chunk)
            if len(flat) > MAX_VALUES:
                raise DataError(
                    f"{self.where} line {n}: over {MAX_VALUES:,} numbers to read; obsnl reads at most "
                    f"that many (cut the file, decimate it, or drop unused columns)"
                )
        a = np.frombuffer(flat, float).reshape(-1, len(self.idx)) if flat else np.zeros((0, len(self.idx)))
        return Table({c: a[:, j] for j, c in enumerate(names)}, dict(zip(names, self.starts)), *self.bad)

    def block(self, chunk: list[str], n: int) -> np.ndarray | None:
        """The numbers of a plain chunk of lines ``n + 1, ...`` (the class docstring), None for any other."""
        text, sep = "".join(chunk), self.sep
        if (sep != "," and "," in text) or set(map(str.count, chunk, repeat(sep))) != {len(self.header) - 1}:
            return None
        try:  # numpy reads a number as float does, 3 times faster, but refuses 1_0 and digits not 0-9
            block = np.loadtxt(chunk, delimiter=sep, comments=None, usecols=self.idx, ndmin=2, dtype=float)
            for j, i in enumerate(self.idx):
                if self.conv[j] is not float:  # absolute time: exactly, on the text
                    block[:, j] = [self.conv[j](line.split(sep, i + 1)[i].strip()) for line in chunk]
        except (ValueError, ArithmeticError):  # ArithmeticError: Decimal's Overflow (1e400)
            return None
        for k in np.flatnonzero(~np.isfinite(block).all(axis=1)):  # NaN, inf (counted) or 1e400 (refused)
            self.row(n + 1 + int(k), chunk[k])
        return block

    def row(self, n: int, line: str) -> list[float] | None:
        """The numbers of line ``n`` checked cell by cell (None for a blank line), or a one-line refusal."""
        if not line.strip():
            return None
        where, width = f"{self.where} line {n}", len(self.header)
        if line.count(self.sep) + 1 != width:
            raise DataError(f"{where}: {line.count(self.sep) + 1} fields, the header has {width}")
        cells = line.split(self.sep)
        comma = next((c for c in cells if _DECIMAL_COMMA.fullmatch(c)), None) if self.sep != "," else None
        if comma is not None:
            raise DataError(
                f"{where}: {quote(comma.strip())} has a decimal comma; write numbers with a decimal point (0.01)"
            )
        vals: list[float] = []
        for f, i, gap in zip(self.conv, self.idx, self.gaps):
            cell, name = cells[i], quote(self.header[i])
            if not cell.strip():
                if not gap:
                    raise DataError(
                        f"{where}: column {name} is empty; give a number in every cell of it"
                        + (" (only the outputs may have empty cells)" if any(self.gaps) else "")
                    )
                vals.append(float("nan"))  # a missing sample
                continue
            try:
                v = f(cell.strip()) if _NUMBER.fullmatch(cell) else None
            except ArithmeticError:  # the exact difference of an infinite time overflows
                v = float(cell.strip())
            except ValueError:
                v = None
            if v is None:
                raise DataError(
                    f"{where}: column {name} is not a number: {quote(cell.strip())} (write plain "
                    f"decimal numbers: digits 0-9, a sign, a point, an exponent)"
                )
            if not np.isfinite(v):
                if not _NON_FINITE.fullmatch(cell):
                    raise DataError(
                        f"{where}: column {name}: {quote(cell.strip())} is beyond the range of "
                        f"floating-point numbers (1.8e308); correct it, or rescale the column"
                    )
                self.bad = [self.bad[0] or n, self.bad[1] + bool(np.all(np.isfinite(vals)))]
            vals.append(v)
        return vals


@contextmanager
def _open_text(p: Path, what: str) -> Iterator[IO[str]]:
    """A context manager: the file ``p`` opened as UTF-8 text (without a byte-order mark; any line ending),
    shared by the record and data readers (``what``, ``"record"`` or ``"data"``, names it in the messages).

    Refused with one line (:class:`~obsnl.errors.DataError`): a missing file, a folder, a FIFO or a device
    (only a regular file is opened: a FIFO would block the open, a device never end), a file over
    :data:`MAX_FILE_BYTES`, unreadable, or text that is not UTF-8 (its first byte named, where it is read).
    """
    where = f"{what} {str(p)!r}"
    try:
        st, fd = os.stat(p), None
        if stat.S_ISREG(st.st_mode):  # opened without waiting (a FIFO put in its place), then checked again
            fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
            st = os.fstat(fd)
        if not (stat.S_ISREG(st.st_mode) and st.st_size <= MAX_FILE_BYTES) and fd is not None:
            os.close(fd)
            fd = None
    except FileNotFoundError:
        raise DataError(f"{where} does not exist") from None
    except (OSError, ValueError) as exc:  # a name too long, no permission; ValueError: a NUL in the name
        raise DataError(os_error_line(exc) if isinstance(exc, OSError) else f"{where}: {exc}") from None
    if stat.S_ISDIR(st.st_mode):
        raise DataError(f"{where} is a folder; give a file")
    if not stat.S_ISREG(st.st_mode):
        kind = next((name for test, name in FILE_KINDS if test(st.st_mode)), "special file")
        raise DataError(f"{where} is a {kind}, not a regular file: give a file")
    if fd is None:
        raise DataError(
            f"{where} has {st.st_size / 2**20:.0f} MiB; obsnl reads at most {MAX_FILE_BYTES >> 20} "
            f"MiB (cut the record, or decimate it)"
        )
    with open(fd, encoding="utf-8-sig", newline=None) as f:
        try:
            yield f
        except UnicodeDecodeError:
            raw = cast(IO[bytes], f.buffer)  # a file opened as text reads through a BufferedReader, which seeks
            raise DataError(f"{where} is not UTF-8 text (byte {_not_utf8(raw)}); save it as UTF-8") from None


def _lines(f: IO[str], where: str) -> Iterator[tuple[int, str]]:
    """The numbered lines of the text file ``f``, refused with one line when one is over :data:`MAX_LINE`
    characters."""
    n = 0
    while line := f.readline(MAX_LINE + 1):
        n += 1
        if len(line) > MAX_LINE:
            raise DataError(
                f"{where} line {n} is over {MAX_LINE:,} characters; a line of samples is short: give "
                f"a CSV of one sample a line"
            )
        yield n, line


def _not_utf8(raw: IO[bytes]) -> int:
    """The offset of the first byte of ``raw`` (read again from the start) that is not UTF-8."""
    raw.seek(0)
    decoder, offset = codecs.getincrementaldecoder("utf-8")(), 0
    while True:
        chunk, pending = raw.read(1 << 20), len(decoder.getstate()[0])
        try:
            decoder.decode(chunk, final=not chunk)
        except UnicodeDecodeError as exc:
            return offset - pending + exc.start
        if not chunk:
            return offset
        offset += len(chunk)


#: The 4th line of an AT2 file; no two adjacent quantifiers can share characters (linear time on any line).
_AT2_HEAD = re.compile(r"NPTS\s*=\s*(\d{1,12})\s*(?:,\s*)?DT\s*=\s*([0-9.eE+-]+)", re.IGNORECASE)


def read_at2(path: str | Path) -> Record:
    """Read a PEER NGA ``.AT2`` file (4 header lines, ``NPTS=..., DT=...``, values in g) into m/s²."""
    p = Path(path)
    where = repr(str(p))
    with _open_text(p, "record") as f:
        lines = _lines(f, f"record {where}")
        head, values, total, padding, row = [next(lines, (0, ""))[1] for _ in range(5)], array("d"), 0, True, 1
        if not head[4]:
            raise DataError(f"{where}: too short for a PEER AT2 file (4 header lines, then values)")
        if len(head[3]) > _AT2_LINE:
            raise DataError(
                f"{where} line 4 has {len(head[3]):,} characters; a PEER AT2 file's is "
                f"'NPTS= n, DT= dt' (is this an AT2 file?)"
            )
        mt = _AT2_HEAD.search(head[3])
        if not mt:
            raise DataError(f"{where} line 4: expected 'NPTS= n, DT= dt', got {quote(head[3].strip())}")
        try:
            npts, dt = int(mt.group(1)), float(mt.group(2))
        except ValueError:
            raise DataError(f"{where} line 4: DT={quote(mt.group(2))} is not a number") from None
        if not (np.isfinite(dt) and dt > 0):
            raise DataError(f"{where} line 4: DT={quote(mt.group(2))} must be a positive time step in seconds")
        if npts > MAX_VALUES:
            raise DataError(
                f"{where} line 4: NPTS={npts} is over the {MAX_VALUES:,} samples obsnl reads; cut the "
                f"record, or decimate it"
            )
        if "UNITS OF G" not in head[2].upper():
            raise DataError(f"{where} line 3: expected acceleration in units of g, got {quote(head[2].strip())}")
        for n, line in chain([(5, head[4])], lines):
            tokens = line.split()
            try:
                vals = [float(tok) for tok in tokens]
                if "_" in line or not line.isascii():
                    raise ValueError
            except ValueError:
                tok = next((tok for tok in tokens if not _NUMBER.fullmatch(tok)), None)
                if tok is not None:
                    raise DataError(f"{where} line {n}: not a number: {quote(tok)}") from None
                vals = [float(tok) for tok in tokens]
            values.extend(vals[: max(npts - total, 0)])
            padding = padding and not any(vals[max(npts - total, 0) :])
            total, row = total + len(vals), max(row, len(vals))
    if total < npts:
        raise DataError(f"{where}: header says NPTS={npts} but the file holds {total} values (truncated?)")
    if total > npts and not (total - npts < row and padding):  # zeros filling the last row are padding
        raise DataError(
            f"{where}: header says NPTS={npts} but the file holds {total} values; correct NPTS "
            f"(obsnl does not cut a record to its header's count)"
        )
    a = np.frombuffer(values, float) * G
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        raise DataError(f"{where}: NaN/inf at sample {bad[0]}")
    return check_motion(Record(p.stem, a, dt, source=f"{p.name}: {shorten(head[1], 200)}"))


def read_record(path: str | Path) -> Record:
    """Read a record by extension: ``.AT2`` (PEER) or ``.csv``."""
    refuse_non_path(path, "read_record takes the path of a record file")
    suffix = Path(path).suffix.lower()
    if suffix == ".at2":
        return read_at2(path)
    if suffix == ".csv":
        return read_csv(path)
    kind = "a folder, not a record file" if Path(path).is_dir() else f"unknown record type {quote(suffix, 20)}"
    raise DataError(f"{quote(str(path))}: {kind}; use a .csv (time_s,accel_m_s2) or a PEER .AT2")
