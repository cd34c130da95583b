"""The record value: an evenly sampled acceleration history in m/s², the check of its time steps, and the
check of a record given to a filter as arrays; the checks the file readers (:mod:`obsnl.estimation.records`)
make of a record (its time and acceleration columns' units, its motion) and of absolute time; noise.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from decimal import Decimal
from fractions import Fraction
from typing import Any

import numpy as np

from obsnl._text import block, names, number, one_line, quote
from obsnl.errors import DataError

__all__ = [
    "Record",
    "check_times",
    "check_increasing",
    "check_inputs",
    "G",
    "ABSOLUTE_TIME",
    "time_since",
    "times_from_text",
    "check_seconds",
    "acceleration_unit",
    "check_motion",
    "rms",
    "add_noise",
]


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
            raise DataError(
                f"record {self.name!r}: NaN/inf at sample {bad[0]} ({bad.size} bad samples); clean the record first"
            )
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
            raise DataError(
                f"cannot keep the first {n} samples of {self.name!r}: a record needs at least 2 "
                f"(ask for 2 or more samples)"
            )
        return Record(self.name, self.accel[:n], self.dt, self.source, self.notes, self.channels)

    def resampled(self, dt: float) -> Record:
        """The record at interval ``dt`` (polyphase resampling with an anti-alias filter)."""
        if abs(dt - self.dt) <= _DT_RTOL * dt:
            return self
        from scipy.signal import resample_poly

        ratio = Fraction(self.dt / dt).limit_denominator(1000)
        if abs(float(ratio) - self.dt / dt) > 1e-9 * self.dt / dt:
            raise DataError(
                f"cannot resample from dt={float(self.dt)!r} to dt={float(dt)!r}: not a ratio of small integers"
            )
        a = resample_poly(self.accel, ratio.numerator, ratio.denominator, axis=0)
        return Record(
            self.name,
            a,
            dt,
            self.source,
            self.notes + (f"resampled from dt={self.dt:g} s to {dt:g} s (polyphase, x{ratio})",),
            self.channels,
        )

    def __repr__(self) -> str:
        ch = f"channels={names(self.channels, 4)!r}" if self.channels else ""
        return one_line(
            "Record",
            f"name={self.name!r}",
            f"samples={len(self)}",
            f"dt={number(self.dt)} s",
            f"peak={number(float(np.max(np.abs(self.accel))))}",
            ch,
        )

    def summary(self) -> str:
        """A few lines of plain text: length, step, peak, source, channels, what was done to it."""
        return block(
            f"record {self.name}: {len(self)} samples at dt = {number(self.dt)} s, peak |value| "
            f"{number(float(np.max(np.abs(self.accel))))}",
            f"source: {self.source}" if self.source else "",
            f"channels: {names(self.channels)}" if self.channels else "",
            *self.notes,
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "dt": self.dt,
            "samples": len(self),
            "source": self.source,
            "notes": list(self.notes),
            "pga_m_s2": float(np.max(np.abs(self.accel))),
            **({"channels": list(self.channels)} if self.channels else {}),
        }


def check_increasing(t: np.ndarray, where: str) -> float:
    """The rounding error of one time value of ``t``, after refusing fewer than 2 samples, a time that does not
    increase, and times so large (absolute time) that floating-point numbers cannot resolve the mean step (the
    checks :func:`check_times` makes before it judges the step; measured data judge it otherwise).

    Parameters
    ----------
    t : numpy.ndarray
        Sample times (s).
    where : str
        Name of the record, used in the messages.

    Returns
    -------
    float
        ``4 eps max|t|`` (s).

    Raises
    ------
    DataError
        Fewer than 2 samples, time not increasing, times too large to resolve the step.

    Examples
    --------
    >>> check_increasing(np.array([0.0, 0.1, 0.2]), "demo") < 1e-15
    True
    """
    if len(t) < 2:
        raise DataError(f"{where}: need at least 2 samples")
    d = np.diff(t)
    rounding = 4 * np.finfo(float).eps * float(max(abs(t[0]), abs(t[-1])))  # of one time value
    mean = float(t[-1] - t[0]) / (len(t) - 1)
    if mean > 0 and rounding > 1e-3 * mean:
        raise DataError(
            f"{where}: the time column starts at {float(t[0]):.10g} s, absolute (epoch) time by the look "
            f"of it, too large to resolve its step of {mean:.3g} s; subtract the first time from every "
            f"time (obsnl counts time from the first sample)"
        )
    if np.any(d <= 0):
        i = int(np.flatnonzero(d <= 0)[0])
        raise DataError(
            f"{where}: time does not increase at sample {i + 1} (t={float(t[i + 1])!r} after {float(t[i])!r})"
        )
    return float(rounding)


def check_times(t: np.ndarray, where: str) -> float:
    """The even step of the sample times ``t``; a :class:`~obsnl.errors.DataError` naming the sample where
    time does not increase or the step is irregular (``where`` names the record in the message).

    The times need not start at 0 (time is counted from the first sample); the tolerance on the step
    includes the rounding of the time values themselves, so that absolute (epoch) times near 1.7e9 s
    sampled at 100 Hz pass, and times too large to resolve the step are refused as such.

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
        Fewer than 2 samples, time not increasing, an irregular step, or times so large (absolute time)
        that floating-point numbers cannot resolve the step.

    Examples
    --------
    >>> check_times(np.array([0.0, 0.1, 0.2]), "demo")
    0.1
    """
    rounding = check_increasing(t, where)
    d = np.diff(t)
    dt = float(np.median(d))
    off = np.flatnonzero(np.abs(d - dt) > max(_DT_RTOL * dt, 1e-9 + 1e-6 * dt) + 2 * rounding)
    if off.size:
        i = int(off[0])
        raise DataError(
            f"{where}: irregular time step at sample {i + 1} (step {d[i]:.6g} s, expected {dt:.6g} s; "
            f"{off.size} irregular steps); resample the record to an even step first"
        )
    return float((t[-1] - t[0]) / (len(t) - 1))


def check_inputs(ys: Any, us: Any, *, ny: int, nu: int) -> tuple[np.ndarray, np.ndarray]:
    """Validate a record for a filter: shapes ``(T, ny)``, ``(T, nu)``, finite values.

    Parameters
    ----------
    ys, us : array_like
        Measured outputs and inputs, one row per sample (1-D allowed for one channel).
    ny, nu : int
        Numbers of outputs and inputs of the model.

    Returns
    -------
    tuple of numpy.ndarray
        ``(ys, us)`` as float arrays ``(T, ny)``, ``(T, nu)``.

    Raises
    ------
    DataError
        Wrong shapes, too short, or NaN/inf (naming the first bad sample).
    """
    ys = np.asarray(ys, float)
    us = np.asarray(us, float)
    ys = ys.reshape(-1, 1) if ys.ndim == 1 and ny == 1 else ys
    us = us.reshape(-1, 1) if us.ndim == 1 and nu == 1 else us
    if ys.ndim != 2 or ys.shape[1] != ny:
        raise DataError(f"outputs must have shape (T, {ny}), got {ys.shape}")
    if us.ndim != 2 or us.shape[1] != nu:
        raise DataError(f"inputs must have shape (T, {nu}), got {us.shape}")
    if len(ys) != len(us):
        raise DataError(f"outputs have {len(ys)} samples but inputs {len(us)}; give one of each per sample")
    if len(ys) < 2:
        raise DataError("a record needs at least 2 samples")
    for name, arr in (("outputs", ys), ("inputs", us)):
        bad = np.flatnonzero(~np.all(np.isfinite(arr), axis=1))
        if bad.size:
            raise DataError(
                f"{name} contain NaN/inf at sample {bad[0]} ({bad.size} bad samples); "
                f"clean or interpolate the record first"
            )
    return ys, us


#: Times from this size on (s) look absolute (Unix epoch time is 1.7e9 s): a file's are subtracted exactly.
ABSOLUTE_TIME = 1e4


def time_since(first: str) -> Callable[[str], float]:
    """A time cell minus the first time ``first``, exactly on the decimal text (:func:`times_from_text`)."""
    zero = Decimal(first)
    return lambda cell: float(Decimal(cell) - zero)


def times_from_text(cells: Iterable[str]) -> tuple[np.ndarray, float]:
    """The times of a file's time column, counted from the first, and the first time. From a first time
    of :data:`ABSOLUTE_TIME` on (absolute, epoch time) the subtraction is exact, on the decimal text: as floats
    near 1.7e9 the times carry rounding errors of 1e-7 s, enough to make an even 1 kHz step look irregular.

    Parameters
    ----------
    cells : iterable of str
        The time column's cells (each one a number).

    Returns
    -------
    tuple
        ``(times - first time, first time)``; an infinite time (``1e400``) stays infinite.

    Examples
    --------
    >>> t, start = times_from_text(["1700000000.001", "1700000000.002"])
    >>> t.tolist(), start
    ([0.0, 0.001], 1700000000.001)
    """
    cells = list(cells)
    t = np.array([float(c) for c in cells], float)
    if not len(t) or not np.isfinite(t[0]) or abs(t[0]) < ABSOLUTE_TIME:
        return t, 0.0
    since, out = time_since(cells[0]), []
    for c, v in zip(cells, t):
        try:
            out.append(since(c) if np.isfinite(v) else v)
        except ArithmeticError:  # a form float reads and Decimal does not: the float difference
            out.append(v - t[0])
    return np.array(out, float), float(t[0])


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
        raise DataError(
            f"{where}: the time column {quote(name)} is not in seconds; give the time in seconds as 'time_s'"
        )


#: A unit in the words of a column's name: g and its parts, gal, a length per second (squared: "cm s 2", "cms 2").
_UNIT = re.compile(
    r"\b(?:(?P<g>g|gs|mg|ug|µg|gal|gals|mgal)|(?P<l>m|cm|mm|um|µm|km|in|ft)"
    r"(?:(?: per)? (?:s|sec)(?P<two> 2| s| sec)?|p?s(?P<fused> 2)))\b"
)


def acceleration_unit(name: str) -> str | None:
    """The unit in an acceleration column's name, after its first word, when it is not m/s² (None: m/s², or
    no unit): ``g``, ``mg``, ``gal``, a length per second squared (``cm_s2``, ``[in/s^2]``, ``ft/s/s``,
    ``cms2``) or per second (a velocity).

    Examples
    --------
    >>> [acceleration_unit(n) for n in ("accel_m_s2", "accel", "acc_ns", "accel_g", "a [cm/s^2]", "vel_m_s")]
    [None, None, None, 'g', 'cm/s^2', 'm/s']
    """
    words = " ".join(re.findall(r"[a-zµ]+|\d+", name.lower().replace("²", "2").replace("⁻", ""))[1:])  # after
    found = [(m["g"] or f"{m['l']}/s" + ("^2" if m["two"] or m["fused"] else "")) for m in _UNIT.finditer(words)]
    return next((u for u in found if u != "m/s^2"), None)


def check_motion(rec: Record) -> Record:
    """Refuse a record without motion (every sample 0: no excitation, a zero noise level), with values
    beyond 1e100 in magnitude (the filters square them) or a step outside 1e-6..1 s (a ground motion is
    sampled at 1-1000 Hz and more; a step of 20 is a time column in milliseconds)."""
    if not np.any(rec.accel):
        raise DataError(f"record {rec.name!r}: every sample is 0 (no ground motion); give a record with excitation")
    peak = float(np.max(np.abs(rec.accel)))
    if peak > 1e100:
        raise DataError(f"record {rec.name!r} reaches {peak:.3g}; rescale it (the record is read in m/s^2)")
    if not 1e-6 <= rec.dt <= 1.0:
        raise DataError(
            f"record {rec.name!r} is sampled every {rec.dt:.3g} s; a ground motion is sampled every "
            f"1e-6 to 1 s: check that the time is in seconds"
        )
    return rec


def rms(x: Any) -> float:
    """Root mean square of ``x`` (all entries)."""
    x = np.asarray(x, float)
    return float(np.sqrt(np.mean(x**2)))


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
    scale = np.sqrt(np.mean(x**2, axis=0)) * ratio
    return x + scale * rng.standard_normal(x.shape)
