"""What ``obsnl validate`` prints and draws: a fitted model's simulation on a new record against the measurement.

The text reads the validation's value (:class:`obsnl.identification.validation.merit.Validation`, through the
protocol :class:`ValidationRun`); the figures take arrays. ``validation.png`` holds, per output, the overlay of
measured and simulated over the whole record, a zoomed window around the largest error (a long record drawn
whole is a solid band), the error against time and the error's spectrum (Welch) beside the measured output's.
``loop.png`` draws a hysteretic state against the first output (the restoring-force loop).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from obsnl._text import number
from obsnl.report.figures import agg_pyplot, save_png

__all__ = [
    "ValidationRun",
    "validate_text",
    "plot_validation",
    "plot_loop",
    "zoom_window",
    "longest_run",
    "ZOOM_SAMPLES",
]

#: Samples of the zoomed window at least (a fortieth of the scored samples on a longer record).
ZOOM_SAMPLES = 200


class _Score(Protocol):
    @property
    def rmse(self) -> float: ...
    @property
    def nrmse(self) -> float | None: ...
    @property
    def fit_percent(self) -> float | None: ...
    @property
    def db(self) -> float | None: ...


class _Record(Protocol):
    @property
    def name(self) -> str: ...
    @property
    def samples(self) -> int: ...
    @property
    def dt(self) -> float: ...


class ValidationRun(Protocol):
    """What :func:`validate_text` reads of a validation (:class:`obsnl.identification.validation.merit.Validation`)."""

    @property
    def model(self) -> str: ...
    @property
    def record(self) -> _Record: ...
    @property
    def parameters_from(self) -> str: ...
    @property
    def start(self) -> str: ...
    @property
    def start_note(self) -> str: ...
    @property
    def warmup(self) -> int: ...
    @property
    def scored(self) -> int: ...
    @property
    def x0(self) -> Mapping[str, float]: ...
    @property
    def intersample(self) -> Mapping[str, str]: ...
    @property
    def outputs(self) -> Mapping[str, _Score]: ...
    @property
    def assumptions(self) -> Sequence[str]: ...


def _cell(x: float | None, digits: str = ".4g") -> str:
    return "n/a" if x is None or not math.isfinite(x) else format(x, digits)


def validate_text(v: ValidationRun) -> str:
    """The text ``obsnl validate`` prints: the run, the start, a table of the figures of merit, the assumptions.

    Parameters
    ----------
    v : ValidationRun
        The validation.

    Returns
    -------
    str

    Examples
    --------
    >>> from types import SimpleNamespace as V
    >>> s = V(rmse=0.01, nrmse=0.1, fit_percent=90.0, db=-20.0)
    >>> print(validate_text(V(model="m", record=V(name="test", samples=100, dt=0.01), parameters_from="given",
    ...       start="rest", start_note="", warmup=0, scored=100, x0={"x": 0.0}, intersample={"u": "linear"},
    ...       outputs={"y": s}, assumptions=["the parameters are fixed"])))
    validate m on 'test': 100 samples at dt = 0.01 s, parameters given
    simulated from rest (the model's initial states, else 0): x = 0; all 100 samples scored
    output  RMSE       NRMSE      fit %    dB
    y       0.01       0.1        90.00    -20.00
    inputs between samples: u linear
    assumed:
      - the parameters are fixed
    """
    rec = v.record
    x0 = ", ".join(f"{s} = {number(x)}" for s, x in v.x0.items())
    if v.start == "estimated":
        start = (
            f"simulated from the state estimated on the first {v.warmup} samples: {x0}; {v.scored} samples "
            f"scored after them\n  ({v.start_note})"
        )
    else:
        start = (
            "simulated from rest (the model's initial states, else 0)"
            if v.start == "rest"
            else "simulated from the initial state given"
        ) + f": {x0}; all {v.scored} samples scored"
    width = max(6, *(len(o) for o in v.outputs))
    rows = [f"{'output':<{width}}  {'RMSE':<10} {'NRMSE':<10} {'fit %':<8} dB"]
    rows += [
        f"{o:<{width}}  {_cell(s.rmse):<10} {_cell(s.nrmse):<10} {_cell(s.fit_percent, '.2f'):<8} {_cell(s.db, '.2f')}"
        for o, s in v.outputs.items()
    ]
    src = "given" if v.parameters_from == "given" else f"from {v.parameters_from}"
    return "\n".join(
        [
            f"validate {v.model} on {rec.name!r}: {rec.samples} samples at dt = {number(rec.dt)} s, parameters {src}",
            start,
            *rows,
            "inputs between samples: " + ", ".join(f"{u} {k}" for u, k in v.intersample.items()),
            "assumed:",
            *(f"  - {a}" for a in v.assumptions),
        ]
    )


def zoom_window(error: Any, first: int) -> slice:
    """The zoomed window: :data:`ZOOM_SAMPLES` samples (or a fortieth of the scored ones, if more) around the
    largest error from sample ``first`` on.

    Parameters
    ----------
    error : array_like
        The error of every sample (NaN at a gap).
    first : int
        The first sample scored (the warm-up is left out).

    Returns
    -------
    slice

    Examples
    --------
    >>> e = np.zeros(1000); e[700] = 1.0
    >>> zoom_window(e, 0)
    slice(600, 800, None)
    """
    e = np.abs(np.asarray(error, float))
    n = len(e) - first
    width = min(n, max(ZOOM_SAMPLES, n // 40))
    scored = np.nan_to_num(e[first:], nan=-1.0)
    centre = first + int(np.argmax(scored))
    lo = min(max(first, centre - width // 2), len(e) - width)
    return slice(lo, lo + width)


def longest_run(ok: np.ndarray) -> slice:
    """The longest stretch of ``True`` in ``ok`` (the first of the longest when several tie).

    Parameters
    ----------
    ok : numpy.ndarray
        A one-dimensional boolean array (e.g. where a signal is not NaN).

    Returns
    -------
    slice
        The indices of the stretch; ``slice(0, 0)`` when ``ok`` holds no ``True``.

    Examples
    --------
    >>> longest_run(np.array([True, False, True, True, True, False]))
    slice(2, 5, None)
    >>> longest_run(np.array([False, False]))
    slice(0, 0, None)
    """
    edges = np.flatnonzero(np.diff(np.concatenate([[0], ok.astype(int), [0]])))
    starts, ends = edges[::2], edges[1::2]
    k = int(np.argmax(ends - starts)) if len(starts) else 0
    return slice(int(starts[k]), int(ends[k])) if len(starts) else slice(0, 0)


def _title(name: str, score: _Score | None) -> str:
    """The head of an output's panels: its RMSE and fit % (``n/a`` for a figure undefined or an output not scored).

    Examples
    --------
    >>> from types import SimpleNamespace as V
    >>> _title("x", V(rmse=0.012345, nrmse=0.1, fit_percent=90.0, db=-20.0)), _title("x", None)
    ('x: RMSE 0.01235, fit 90.00 %', 'x: RMSE n/a, fit n/a %')
    """
    if score is None:
        return f"{name}: RMSE n/a, fit n/a %"
    return f"{name}: RMSE {number(score.rmse)}, fit {_cell(score.fit_percent, '.2f')} %"


def plot_validation(
    path: str | Path,
    *,
    t: np.ndarray,
    measured: np.ndarray,
    simulated: np.ndarray,
    outputs: Sequence[str],
    warmup: int,
    scores: Mapping[str, _Score],
) -> Path:
    """Per output: the overlay over the whole record, the zoomed window, the error and its spectrum.

    Parameters
    ----------
    path : str or Path
        The PNG file to write.
    t : numpy.ndarray
        Sample times (s).
    measured, simulated : numpy.ndarray
        Outputs ``(T, ny)``; a measured NaN is a gap.
    outputs : sequence of str
        Output names.
    warmup : int
        Samples at the start that are not scored (shaded).
    scores : mapping of str to OutputScore
        Each output's figures of merit (``Validation.outputs``: ``rmse``, ``fit_percent``), for the titles; an
        output without one is titled ``n/a``.

    Returns
    -------
    Path
    """
    from scipy.signal import welch

    plt = agg_pyplot()
    ny = len(outputs)
    fig, axes = plt.subplots(2 * ny, 2, figsize=(10, 5.2 * ny + 0.4), squeeze=False)
    fs = 1.0 / float(t[1] - t[0])
    for j, name in enumerate(outputs):
        y, s = measured[:, j], simulated[:, j]
        e = y - s
        win = zoom_window(e, warmup)
        full, zoom, err, psd = axes[2 * j, 0], axes[2 * j, 1], axes[2 * j + 1, 0], axes[2 * j + 1, 1]
        head = _title(name, scores.get(name))
        for ax in (full, zoom):
            sl = slice(None) if ax is full else win
            ax.plot(t[sl], y[sl], lw=1.4, color="0.65", label="measured")
            ax.plot(t[sl], s[sl], lw=0.8, color="C0", label="simulated")
            ax.set_ylabel(name)
        full.axvspan(t[win.start], t[win.stop - 1], color="C1", alpha=0.15, lw=0, label="zoomed window")
        if warmup:
            for ax in (full, err):
                ax.axvspan(t[0], t[warmup], color="0.85", lw=0, label="warm-up (not scored)")
        full.set_title(f"{head} (whole record)", fontsize=9)
        full.legend(fontsize=7, loc="upper right")
        zoom.set_title(f"zoom: {win.stop - win.start} samples around the largest error", fontsize=9)
        err.plot(t, e, lw=0.6, color="C3")
        err.set_title("error: measured - simulated", fontsize=9)
        err.set_ylabel(f"error of {name}")
        err.set_xlabel("t (s)")
        run = longest_run(~np.isnan(e[warmup:]))
        stretch = slice(warmup + run.start, warmup + run.stop)
        n = stretch.stop - stretch.start
        if n >= 8:
            seg = min(n, 1024)
            f, pe = welch(e[stretch], fs=fs, nperseg=seg)
            _, py = welch(y[stretch], fs=fs, nperseg=seg)
            psd.semilogy(f[1:], py[1:], lw=0.9, color="0.6", label="measured output")
            psd.semilogy(f[1:], pe[1:], lw=0.9, color="C3", label="error")
            psd.legend(fontsize=7, loc="upper right")
        gaps = " (longest stretch without gaps)" if n < len(e) - warmup else ""
        psd.set_title(f"spectrum (Welch, {min(n, 1024)}-sample segments){gaps}", fontsize=9)
        psd.set_xlabel("frequency (Hz)")
        psd.set_ylabel("power spectral density")
        zoom.set_xlabel("t (s)")
    return save_png(plt, fig, path)


def plot_loop(
    path: str | Path, *, displacement: np.ndarray, state: np.ndarray, output: str, name: str, warmup: int = 0
) -> Path:
    """The restoring-force loop: a hysteretic state against the displacement (a state or an output), both simulated,
    over the scored samples.

    Parameters
    ----------
    path : str or Path
        The PNG file to write.
    displacement : numpy.ndarray
        The displacement on the horizontal axis (simulated).
    state : numpy.ndarray
        The hysteretic state (simulated).
    output, name : str
        The names of the displacement and of the state.
    warmup : int
        Samples left out at the start.

    Returns
    -------
    Path
    """
    plt = agg_pyplot()
    fig, ax = plt.subplots(1, 1, figsize=(5.5, 4.5))
    ax.plot(displacement[warmup:], state[warmup:], lw=0.5, color="C0")
    ax.set_xlabel(f"{output} (simulated)")
    ax.set_ylabel(f"{name} (simulated)")
    ax.set_title(f"hysteretic state {name} against {output}: the restoring-force loop", fontsize=9)
    return save_png(plt, fig, path)
