"""Records: ground-motion CSV and PEER AT2 readers with validation, resampling, measurement noise.

A :class:`Record` is an evenly sampled acceleration history in m/s². The readers refuse NaN/inf,
non-increasing or irregular time steps and truncated files with a :class:`~obsnl.errors.DataError`
that names the line and the fix.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from obsnl.errors import DataError

__all__ = ["Record", "check_times", "check_header", "check_seconds", "read_text", "read_record", "read_csv",
           "read_at2", "add_noise", "rms", "G", "MAX_FILE_BYTES"]

#: Standard gravity (m/s² per g), used to convert AT2 files.
G = 9.80665
_DT_RTOL = 1e-6


@dataclass(frozen=True, eq=False)
class Record:
    """An evenly sampled record.

    Attributes
    ----------
    name
        Short name (the file stem).
    accel
        Samples, shape ``(T,)`` (one input, a ground motion in m/s²) or ``(T, nu)`` (one column per input,
        named in ``channels``).
    dt
        Sampling interval (s).
    source
        Where it came from (file name, header line).
    """

    name: str
    accel: np.ndarray
    dt: float
    source: str = ""
    notes: tuple[str, ...] = field(default=())
    channels: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        a = np.asarray(self.accel, float)
        if a.ndim not in (1, 2) or len(a) < 2:
            raise DataError(f"record {self.name!r}: need a series of at least 2 samples, got shape {a.shape}")
        bad = np.flatnonzero(~np.all(np.isfinite(a.reshape(len(a), -1)), axis=1))
        if bad.size:
            raise DataError(f"record {self.name!r}: NaN/inf at sample {bad[0]} ({bad.size} bad samples); "
                            f"clean the record first")
        if not (np.isfinite(self.dt) and self.dt > 0):
            raise DataError(f"record {self.name!r}: the time step must be positive, got {self.dt!r}")
        a.setflags(write=False)
        object.__setattr__(self, "accel", a)

    @property
    def t(self) -> np.ndarray:
        return np.arange(len(self.accel)) * self.dt

    def __len__(self) -> int:
        return len(self.accel)

    def head(self, n: int) -> Record:
        """The first ``n`` samples."""
        if n < 2:
            raise DataError(f"cannot keep the first {n} samples of {self.name!r}: a record needs at least 2 "
                            f"(ask for 2 or more samples)")
        return Record(self.name, self.accel[:n], self.dt, self.source, self.notes, self.channels)

    def resampled(self, dt: float) -> Record:
        """The record at interval ``dt`` (polyphase resampling with an anti-alias filter)."""
        if abs(dt - self.dt) <= _DT_RTOL * dt:
            return self
        from scipy.signal import resample_poly

        ratio = Fraction(self.dt / dt).limit_denominator(1000)
        if abs(float(ratio) - self.dt / dt) > 1e-9 * self.dt / dt:
            raise DataError(f"cannot resample from dt={float(self.dt)!r} to dt={float(dt)!r}: not a ratio of small integers")
        a = resample_poly(self.accel, ratio.numerator, ratio.denominator, axis=0)
        return Record(self.name, a, dt, self.source,
                      self.notes + (f"resampled from dt={self.dt:g} s to {dt:g} s (polyphase, x{ratio})",), self.channels)

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "dt": self.dt, "samples": len(self), "source": self.source,
                "notes": list(self.notes), "pga_m_s2": float(np.max(np.abs(self.accel))),
                **({"channels": list(self.channels)} if self.channels else {})}


def check_times(t: np.ndarray, where: str) -> float:
    """The even step of the sample times ``t``; a :class:`~obsnl.errors.DataError` naming the sample where
    time does not increase or the step is irregular (``where`` names the record in the message).

    Parameters
    ----------
    t : numpy.ndarray
        Sample times (s).
    where : str
        Name of the record, used in the messages.

    Returns
    -------
    float
        The mean step (s).

    Raises
    ------
    DataError
        Fewer than 2 samples, time not increasing, or an irregular step.

    Examples
    --------
    >>> check_times(np.array([0.0, 0.1, 0.2]), "demo")
    0.1
    """
    if len(t) < 2:
        raise DataError(f"{where}: need at least 2 samples")
    d = np.diff(t)
    if np.any(d <= 0):
        i = int(np.flatnonzero(d <= 0)[0])
        raise DataError(f"{where}: time does not increase at sample {i + 1} (t={float(t[i + 1])!r} after {float(t[i])!r})")
    dt = float(np.median(d))
    off = np.flatnonzero(np.abs(d - dt) > max(_DT_RTOL * dt, 1e-9 + 1e-6 * dt))
    if off.size:
        i = int(off[0])
        raise DataError(f"{where}: irregular time step at sample {i + 1} (step {d[i]:.6g} s, expected {dt:.6g} s; "
                        f"{off.size} irregular steps); resample the record to an even step first")
    return float((t[-1] - t[0]) / (len(t) - 1))


def read_csv(path: str | Path, *, column: str | int | None = None) -> Record:
    """Read a CSV with a header: a time column (``time*`` or ``t``) and an acceleration column.

    Parameters
    ----------
    path
        The file; values in m/s², time in s.
    column
        Name or index of the acceleration column (default: the one whose name starts with ``acc``, or
        the only column besides time; anything else is refused, never guessed).
    """
    p = Path(path)
    lines = read_text(p, "record").splitlines()
    if not lines:
        raise DataError(f"{str(p)!r} is empty")
    header = check_header([h.strip() for h in lines[0].split(",")], str(p))
    times = [i for i, h in enumerate(header) if h.lower().startswith("time") or h.lower() == "t"]
    if not times:
        raise DataError(f"{str(p)!r}: no time column in header {header} (name it 'time_s')")
    if len(times) > 1:
        raise DataError(f"{str(p)!r}: {len(times)} time columns {[header[i] for i in times]}; keep one, 'time_s'")
    tcol = times[0]
    check_seconds(header[tcol], str(p))
    if column is None:  # by name: a column called acc..., else the only column besides time
        others = [i for i in range(len(header)) if i != tcol]
        named = [i for i in others if header[i].lower().startswith("acc")]
        pick = named if named else others
        if len(pick) != 1:
            raise DataError(f"{str(p)!r}: cannot tell the acceleration column among {[header[i] for i in pick]}; "
                            f"name it 'accel_m_s2' (or keep only time and acceleration)")
        acol: int | None = pick[0]
    elif isinstance(column, int):
        acol = column
    else:
        acol = header.index(column) if column in header else None
    if acol is None or not 0 <= acol < len(header):
        raise DataError(f"{str(p)!r}: no acceleration column {column!r} in header {header}")
    rows = []
    for n, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        cells = line.split(",")
        if len(cells) != len(header):
            raise DataError(f"{str(p)!r} line {n}: {len(cells)} fields, the header has {len(header)}")
        try:
            rows.append((float(cells[tcol]), float(cells[acol])))
        except ValueError:
            raise DataError(f"{str(p)!r} line {n}: not a number: {line.strip()!r}") from None
    arr = np.array(rows, float).reshape(-1, 2)
    bad = np.flatnonzero(~np.all(np.isfinite(arr), axis=1))
    if bad.size:
        raise DataError(f"{str(p)!r} line {bad[0] + 2}: NaN/inf value ({bad.size} bad rows); clean the record first")
    dt = check_times(arr[:, 0], str(p))
    return _moving(Record(p.stem, arr[:, 1], dt, source=p.name))


#: Largest record or data file read (bytes): a long measured record of ten channels and a million
#: samples is about 150 MB as CSV.
MAX_FILE_BYTES = 1 << 30


def read_text(p: Path, what: str) -> str:
    """The UTF-8 text of the file ``p``, refused with one line otherwise (shared by the record and data readers).

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
        return p.read_bytes().decode("utf-8")
    except UnicodeDecodeError as exc:
        raise DataError(f"{what} {str(p)!r} is not UTF-8 text (byte {exc.start}); save it as a UTF-8 CSV") from None
    except OSError as exc:
        raise DataError(f"cannot read {str(p)!r}: {exc.strerror or exc}") from None


def check_header(header: list[str], where: str) -> list[str]:
    """``header`` if no column name repeats (a repeated name would be read from one column, silently).

    Parameters
    ----------
    header : list of str
        The column names.
    where : str
        The file, for the message.

    Returns
    -------
    list of str

    Raises
    ------
    DataError
        A name that appears more than once.

    Examples
    --------
    >>> check_header(["time_s", "F", "F"], "d.csv")
    Traceback (most recent call last):
    ...
    obsnl.errors.DataError: d.csv: column 'F' appears 2 times in the header; rename or remove the copies
    """
    seen = {h: header.count(h) for h in header}
    twice = [h for h, n in seen.items() if n > 1]
    if twice:
        raise DataError(f"{where}: column {twice[0]!r} appears {seen[twice[0]]} times in the header; rename or "
                        f"remove the copies")
    return header


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
        raise DataError(f"{where}: the time column {name!r} is not in seconds; give the time in seconds as 'time_s'")


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
        raise DataError(f"{str(p)!r} line 4: expected 'NPTS= n, DT= dt', got {lines[3].strip()!r}")
    try:
        npts, dt = int(mt.group(1)), float(mt.group(2))
    except ValueError:
        raise DataError(f"{str(p)!r} line 4: DT={mt.group(2)!r} is not a number") from None
    if not (np.isfinite(dt) and dt > 0):
        raise DataError(f"{str(p)!r} line 4: DT={mt.group(2)!r} must be a positive time step in seconds")
    if "UNITS OF G" not in lines[2].upper():
        raise DataError(f"{str(p)!r} line 3: expected acceleration in units of g, got {lines[2].strip()!r}")
    values: list[float] = []
    for n, line in enumerate(lines[4:], start=5):
        for tok in line.split():
            try:
                values.append(float(tok))
            except ValueError:
                raise DataError(f"{str(p)!r} line {n}: not a number: {tok!r}") from None
    if len(values) < npts:
        raise DataError(f"{str(p)!r}: header says NPTS={npts} but the file holds {len(values)} values (truncated?)")
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
    raise DataError(f"{str(path)!r}: unknown record type {suffix!r}; use a .csv (time_s,accel_m_s2) or a PEER .AT2")


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
