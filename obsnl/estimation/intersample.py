"""How an input behaves between its samples: zero-order hold, linear, or band-limited.

A continuous-time model driven by a sampled input needs the input between the samples, and that assumption is
part of the model (Pintelon and Schoukens [1]_, ch. 13). Three kinds, per input:

``zoh``
    Piecewise constant: the sample is held until the next one (a digital controller driving a DAC).
``linear``
    Piecewise linear between samples (obsnl's classic step; the default).
``bandlimited``
    No energy above the Nyquist frequency (a multisine synthesised in the frequency domain, or anything low-pass
    filtered before sampling). The values between samples are interpolated at :data:`POINTS` points per sample:
    by zero-padding the FFT when the record is periodic (exact for a periodic band-limited record; the Nyquist bin of
    an even length is split in two), else by a Kaiser-windowed sinc of :data:`HALF_WIDTH` samples on each side
    (``scipy.signal.resample_poly``), the ends extended by odd reflection about the end sample (value and slope
    continuous), so that the first and last :data:`HALF_WIDTH` samples' in-between values are approximate.

    A record is read as periodic when its end runs into its start like any stretch inside it: a linear predictor
    fitted to the record predicts across the wrap as well as inside (:func:`is_periodic`). An integer number of
    periods of a multisine is; so is a record that starts and ends at rest (an earthquake), for which the periodic
    extension is as smooth as any other.

:func:`drive` turns a record into what the compiled functions take: the classic model and the samples when every
input is linear, else a model driven by input blocks (:meth:`obsnl.estimation.numeric.NumericModel.driven`) and one
block per sample. :func:`between_samples` says how much the choice matters for a record: the relative RMS error that
the kind makes between samples if the input was in fact band-limited, from its Welch spectrum.

References
----------
.. [1] R. Pintelon and J. Schoukens, *System Identification: A Frequency Domain Approach*, 2nd ed., Wiley-IEEE
   Press, 2012, ch. 13 (the zero-order-hold and band-limited measurement set-ups). doi:10.1002/9781118287422
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from obsnl._text import quote, shorten
from obsnl.errors import DataError, OptionError
from obsnl.estimation.numeric import NumericModel
from obsnl.model.reading.fields import INTERSAMPLE_KINDS

__all__ = [
    "KINDS",
    "POINTS",
    "HALF_WIDTH",
    "MATTERS",
    "intersample_kinds",
    "is_periodic",
    "upsample",
    "blocks",
    "drive",
    "between_samples",
    "InputBetween",
]

#: The kinds of input between samples (the model file's ``[intersample]`` table takes the same).
KINDS = INTERSAMPLE_KINDS
#: Points per sample at which a band-limited input is interpolated (linear between them: at a frequency of a fifth
#: of the sampling rate the error of that last step is 3e-3 of the amplitude at most, about 1e-3 RMS).
POINTS = 8
#: Half-width of the windowed sinc (in samples) for a record that is not periodic.
HALF_WIDTH = 16
#: Kaiser window parameter of the sinc (about 80 dB stopband; flat to 1e-4 up to 0.4 of the sampling rate).
KAISER_BETA = 8.0
#: Relative RMS error between samples above which :func:`between_samples` says that the kind matters.
MATTERS = 0.01


def intersample_kinds(spec: Any, inputs: Sequence[str], *, table: Mapping[str, str] | None = None) -> dict[str, str]:
    """The kind of every input from a specification.

    Parameters
    ----------
    spec : None, str, mapping or sequence of str
        None: every input linear. ``"KIND"``: every input. ``"NAME=KIND"``, a sequence of such strings (a bare
        ``KIND`` among them applies to every input not named), or a mapping ``{NAME: KIND}``.
    inputs : sequence of str
        The model's inputs.
    table : mapping of str to str or None
        The model's ``[intersample]`` table: the kinds of the inputs that ``spec`` does not name (a bare kind in
        ``spec`` names them all).

    Returns
    -------
    dict
        ``{input: kind}`` for every input.

    Raises
    ------
    OptionError
        An unknown kind or input name, or a specification of another type.

    Examples
    --------
    >>> intersample_kinds(None, ["u", "v"])
    {'u': 'linear', 'v': 'linear'}
    >>> intersample_kinds(["zoh", "v=bandlimited"], ["u", "v"])
    {'u': 'zoh', 'v': 'bandlimited'}
    >>> intersample_kinds("v=linear", ["u", "v"], table={"u": "zoh", "v": "zoh"})
    {'u': 'zoh', 'v': 'linear'}
    >>> intersample_kinds({"u": "cubic"}, ["u"])
    Traceback (most recent call last):
    ...
    obsnl.errors.OptionError: intersample kind 'cubic' for u is unknown; use zoh, linear or bandlimited
    """
    names = list(inputs)
    base: list[tuple[str | None, Any]] = list((table or {}).items())
    if spec is None:
        items = base
    elif isinstance(spec, str):
        items = [_item(spec)]
    elif isinstance(spec, Mapping):
        items = [(k, v) for k, v in spec.items()]
    elif isinstance(spec, (list, tuple)):
        items = [_item(s) for s in spec]
    else:
        raise OptionError(
            f"intersample= takes a kind, 'NAME=KIND' strings or a mapping {{input: kind}}, not {type(spec).__name__}"
        )
    if spec is not None and all(name is not None for name, _ in items):
        items = base + items  # the table's kinds, then those given (which win)
    default, named = "linear", {}
    for name, kind in items:
        if not isinstance(kind, str) or kind not in KINDS:
            raise OptionError(
                f"intersample kind {quote(kind)}{'' if name is None else ' for ' + shorten(str(name))} is unknown; "
                f"use {', '.join(KINDS[:-1])} or {KINDS[-1]}"
            )
        if name is None:
            default = kind
        elif name not in names:
            raise OptionError(
                f"intersample names {quote(name)}, which is not an input of the model "
                f"({', '.join(names) or 'it has none'}); check the spelling"
            )
        else:
            named[name] = kind
    return {n: named.get(n, default) for n in names}


def _item(text: Any) -> tuple[str | None, Any]:
    if not isinstance(text, str):
        raise OptionError(f"intersample entries are 'NAME=KIND' or 'KIND' strings, not {quote(text)}")
    if "=" in text:
        name, kind = text.split("=", 1)
        return name.strip(), kind.strip()
    return None, text.strip()


def is_periodic(u: np.ndarray, *, order: int = 32) -> bool:
    """Whether a record's end runs into its start like any stretch inside it (module docstring).

    The judgement: a linear predictor of ``order`` past samples, fitted by least squares over the record, predicts
    the first samples of the record continued periodically (from its last samples) as well as it predicts inside:
    the largest error across the wrap is within 4 times the RMS error inside (plus rounding). A record holding an
    integer number of periods, or starting and ending at rest, passes; a sine cut mid-period does not.

    Parameters
    ----------
    u : numpy.ndarray
        One input's samples.
    order : int
        Past samples of the predictor (at most an eighth of the record).

    Returns
    -------
    bool

    Examples
    --------
    >>> t = np.arange(100)
    >>> bool(is_periodic(np.sin(2 * np.pi * 3 * t / 100))), bool(is_periodic(np.sin(2 * np.pi * 3.5 * t / 100)))
    (True, False)
    """
    x = np.asarray(u, float)
    T = len(x)
    p = max(1, min(int(order), T // 8))
    if T < 4 * p + 4:
        return False
    rows = np.lib.stride_tricks.sliding_window_view(x, p + 1)  # rows[k] = x[k .. k + p]
    A, b = rows[:, :p][:, ::-1], rows[:, p]  # predict x[k + p] from x[k + p - 1], ..., x[k]
    coef = np.linalg.lstsq(A, b, rcond=None)[0]
    inside = float(np.sqrt(np.mean((A @ coef - b) ** 2)))
    wrapped = np.concatenate([x[-p:], x[:p]])  # the end, then the start
    W = np.lib.stride_tricks.sliding_window_view(wrapped, p + 1)
    across = np.abs(W[:, :p][:, ::-1] @ coef - W[:, p])
    return bool(across.max() <= 4.0 * inside + 1e-12 * float(np.sqrt(np.mean(x**2))))


def upsample(u: np.ndarray, points: int, *, periodic: bool | None = None) -> np.ndarray:
    """A band-limited input at ``points`` points per sample: ``len(u) * points`` values at ``t_0 + j dt / points``
    (the samples themselves at every ``points``-th, kept exactly).

    Parameters
    ----------
    u : numpy.ndarray
        One input's samples.
    points : int
        Points per sample.
    periodic : bool or None
        The record is periodic (FFT), or not (windowed sinc); None: :func:`is_periodic` decides.

    Examples
    --------
    A periodic multisine below half the sampling rate is reproduced exactly between its samples:

    >>> t = np.arange(64)
    >>> x = lambda s: np.sin(2 * np.pi * 5 * s / 64) + 0.3 * np.cos(2 * np.pi * 20 * s / 64 + 1.0)
    >>> fine = upsample(x(t), 4)
    >>> bool(np.abs(fine - x(np.arange(256) / 4)).max() < 1e-12)
    True
    """
    x = np.asarray(u, float)
    T, m = len(x), int(points)
    if periodic is None:
        periodic = is_periodic(x)
    if periodic:
        X = np.fft.rfft(x)
        if T % 2 == 0:
            X[-1] /= 2.0  # the Nyquist bin, split between +fs/2 and -fs/2
        pad = np.zeros(T * m // 2 + 1, complex)
        pad[: len(X)] = X
        fine = np.fft.irfft(pad, n=T * m) * m
    else:
        from scipy import signal  # scipy.signal takes seconds to import: only where a sinc is needed

        h = signal.firwin(2 * m * HALF_WIDTH + 1, 1.0 / m, window=("kaiser", KAISER_BETA))
        fine = signal.resample_poly(x, m, 1, window=h, padtype="antireflect")[: T * m]
    fine[::m] = x
    return fine


def blocks(u: np.ndarray, kinds: Sequence[str], *, periodic: bool | None = None) -> tuple[np.ndarray, int]:
    """One input block per sample, and the points per sample ``m`` (0: every input linear, no blocks).

    Row ``k`` is ``[u(t_k), u(t_k + dt/m), ..., u(t_{k+1}^-)]``, each entry a vector over the inputs (the layout of
    :meth:`obsnl.estimation.numeric.NumericModel.driven`); the last row holds the last sample throughout.

    Parameters
    ----------
    u : numpy.ndarray
        The input samples, ``(T, nu)`` or ``(T,)``.
    kinds : sequence of str
        The kind of each input column.
    periodic : bool or None
        For band-limited inputs: the record is periodic (None: :func:`is_periodic` decides, per input).

    Returns
    -------
    tuple
        ``(blocks (T, nu * (m + 1)), m)``, or ``(u, 0)`` when every input is linear.

    Examples
    --------
    >>> B, m = blocks(np.array([[1.0], [3.0], [5.0]]), ["zoh"])
    >>> m, B.tolist()
    (1, [[1.0, 1.0], [3.0, 3.0], [5.0, 5.0]])
    """
    x = np.asarray(u, float)
    if x.ndim == 1:
        x = x[:, None]
    T, nu = x.shape
    if len(kinds) != nu:
        raise DataError(f"{len(kinds)} intersample kinds for {nu} input columns")
    if all(k == "linear" for k in kinds):
        return x, 0
    m = POINTS if "bandlimited" in kinds else 1
    fine = np.empty((T, m + 1, nu))
    for j, kind in enumerate(kinds):
        col = x[:, j]
        if kind == "zoh":
            fine[:, :, j] = col[:, None]
        elif kind == "linear":
            nxt = np.append(col[1:], col[-1])
            frac = np.arange(m + 1) / m
            fine[:, :, j] = col[:, None] * (1 - frac) + nxt[:, None] * frac
        else:
            up = upsample(col, m, periodic=periodic)
            fine[:, :m, j] = up.reshape(T, m)
            fine[:-1, m, j] = col[1:]
            fine[-1, :, j] = col[-1]
    return fine.reshape(T, (m + 1) * nu), m


def drive(
    num: NumericModel, u: np.ndarray, kinds: Mapping[str, str] | Sequence[str] | None, *, periodic: bool | None = None
) -> tuple[NumericModel, np.ndarray]:
    """The model to step and the input its compiled functions take, for a record with these kinds.

    Parameters
    ----------
    num : NumericModel
        The classic compiled model (:func:`obsnl.estimation.codegen.to_casadi`).
    u : numpy.ndarray
        The input samples, ``(T, nu)`` (or ``(T,)`` for one input).
    kinds : mapping, sequence or None
        The kind of each input (:func:`intersample_kinds`); None: linear.
    periodic : bool or None
        For band-limited inputs: the record is periodic (None: :func:`is_periodic` decides).

    Returns
    -------
    tuple
        ``(model, U)``: ``num`` and ``u`` themselves when every input is linear; else the model driven by blocks and
        one block per sample (``T`` rows of ``model.nu`` values; the first ``nu`` of a row are the sample).
    """
    if num.points:
        raise DataError(f"model {num.name!r} is already driven by input blocks; give the classic model")
    if kinds is None:
        kinds = ["linear"] * len(num.inputs)
    elif isinstance(kinds, Mapping):
        kinds = [kinds.get(n, "linear") for n in num.inputs]
    x = np.asarray(u, float)
    B, m = blocks(x.reshape(len(x), -1), list(kinds), periodic=periodic)
    if m == 0:
        return num, x
    return num.driven(m), B


@dataclass(frozen=True)
class InputBetween:
    """How one input is taken between samples, and how much that choice matters for this record.

    Attributes
    ----------
    input, kind
        The input and its kind.
    route
        How the in-between values are made: ``"held"``, ``"linear"``, ``"fft"`` (periodic band-limited) or
        ``"sinc"`` (windowed sinc, ends reflected).
    high_share
        The share of the input's power above a fifth of the sampling rate (Welch).
    discrepancy
        The relative RMS error between samples that linear interpolation (for ``linear``), holding (``zoh``) would
        make if the input was band-limited; for ``bandlimited``, the share of power above 0.45 of the sampling rate
        (where a band-limited reading is doubtful: aliasing).
    matters
        ``discrepancy`` above :data:`MATTERS`: the choice of kind changes the model's input noticeably.
    """

    input: str
    kind: str
    route: str
    high_share: float
    discrepancy: float
    matters: bool

    def to_dict(self) -> dict[str, Any]:
        return {
            "input": self.input,
            "kind": self.kind,
            "route": self.route,
            "high_share": self.high_share,
            "discrepancy": self.discrepancy,
            "matters": self.matters,
        }


def _error_gain(kind: str, f: np.ndarray) -> np.ndarray:
    """Mean squared error between samples, over the position in the interval, of holding or linearly interpolating
    a unit sinusoid of frequency ``f`` (cycles per sample)."""
    tau = (np.arange(64) + 0.5) / 64
    true = np.exp(2j * np.pi * np.outer(f, tau))
    if kind == "zoh":
        approx = np.ones_like(true)
    else:
        approx = (1 - tau)[None, :] + tau[None, :] * np.exp(2j * np.pi * f)[:, None]
    return np.mean(np.abs(true - approx) ** 2, axis=1)


def between_samples(
    u: np.ndarray, inputs: Sequence[str], kinds: Mapping[str, str], *, periodic: bool | None = None
) -> tuple[InputBetween, ...]:
    """How each input is taken between samples and how much the choice matters (:class:`InputBetween`).

    The judgement: with the input's Welch spectrum ``S(f)``, the relative RMS error between samples of a kind is
    ``sqrt(sum S(f) e(f) / sum S(f))``, ``e(f)`` the mean squared error of that kind on a unit sinusoid (0 for a
    band-limited one). Above :data:`MATTERS` (1 %) the input holds enough energy near the Nyquist frequency that the
    kind changes the fit, so the run says which kind it used and that the choice matters.

    Parameters
    ----------
    u : numpy.ndarray
        The input samples, ``(T, nu)`` or ``(T,)``.
    inputs : sequence of str
        The input names, in column order.
    kinds : mapping of str to str
        The kind of each input (linear where not named).
    periodic : bool or None
        Whether the record is periodic (None: :func:`is_periodic` decides).

    Returns
    -------
    tuple of InputBetween

    Examples
    --------
    A multisine up to a fifth of the sampling rate, taken linearly, is off by several per cent between samples:

    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(4096)
    >>> u = sum(np.sin(2 * np.pi * k * t / 4096 + rng.uniform(0, 6.3)) for k in range(20, 820, 8))
    >>> lin = between_samples(u, ["u"], {"u": "linear"})[0]
    >>> lin.matters, round(lin.discrepancy, 2)
    (True, 0.06)
    """
    from scipy import signal  # scipy.signal takes seconds to import: only when a record is judged

    x = np.asarray(u, float).reshape(len(u), -1)
    out = []
    for j, name in enumerate(inputs):
        col = x[:, j] - np.mean(x[:, j])
        kind = kinds.get(name, "linear")
        f, S = signal.welch(col, fs=1.0, nperseg=min(len(col), 1024))
        total = float(S.sum()) or 1.0
        high = float(S[f > 0.2].sum() / total)
        if kind == "bandlimited":
            per = is_periodic(x[:, j]) if periodic is None else periodic
            route, disc = ("fft" if per else "sinc"), float(S[f > 0.45].sum() / total)
        else:
            route = "held" if kind == "zoh" else "linear"
            disc = float(np.sqrt((S * _error_gain(kind, f)).sum() / total))
        out.append(InputBetween(name, kind, route, high, disc, disc > MATTERS))
    return tuple(out)
