"""The figures an engineer reads after an identification: the fit over a long record, the residual analysis, the
model's frequency response against the measured one, and the hysteresis loop measured against the model.

One style for all of them (:func:`_style`): the measurement in grey, drawn first and thicker, the model in blue on
top, the residual in red, bounds and references dashed black; every panel names its quantity and its units where
the record gives them (seconds, hertz). A long record is readable: the overlay of the whole record comes with a
zoomed window around the largest residual (:func:`~obsnl.report.identification.validation.zoom_window`).

- ``fit.png`` (:func:`plot_fit_record`): per output, the whole record, the zoomed window and the residual.
- ``residuals.png`` (:func:`plot_residuals`): per output, the residual's autocorrelation with its bounds under
  whiteness, ``+-z/sqrt(N)``, and its cross-correlation with each input with the bounds ``+-z sqrt(P/N)``,
  ``P = sum_k r_e(k) r_u(k)`` (Ljung, "System Identification: Theory for the User", 1999, sec. 16.6), ``z`` the
  two-sided normal quantile of the adequacy level.
- ``frf.png`` (:func:`plot_frf`): per input and output, the model's frequency response
  ``H(f) = C (i 2 pi f I - A)^-1 B + D`` (the model linearised at rest) against the measured H1 estimate
  ``H1 = P_uy / P_uu`` (Welch's averaged cross- and auto-spectra, scipy.signal.csd and welch; Bendat and Piersol,
  "Random Data", 2010, sec. 9.1), and the coherence, which says where the estimate can be trusted.
- ``hysteresis.png`` (:func:`plot_hysteresis`): the restoring force against the displacement, measured against
  the model (a :class:`HysteresisLoop`, made by the caller, who knows the model; or a :class:`NoHysteresisLoop`,
  which says why there is none).
"""

from __future__ import annotations

import textwrap
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from obsnl.report.figures import agg_pyplot, save_png
from obsnl.report.identification.validation import longest_run, zoom_window

__all__ = [
    "HysteresisLoop",
    "NoHysteresisLoop",
    "plot_fit_record",
    "plot_residuals",
    "plot_frf",
    "plot_hysteresis",
    "model_frf",
    "h1_estimate",
    "correlation_bounds",
    "segment_length",
    "MEASURED",
    "MODEL",
    "RESIDUAL",
    "COHERENT",
    "SEGMENT",
]

#: The colours of the style: the measurement, the model, the residual.
MEASURED, MODEL, RESIDUAL = "0.6", "C0", "C3"
#: Samples per Welch segment at most (a long record averages more segments, a short one uses itself whole).
SEGMENT = 1024
#: The coherence below which the H1 estimate is drawn faint: there the input explains less than half of the output's
#: power at that frequency (noise, another input, or no excitation), and the estimate is not to be read.
COHERENT = 0.5


@contextmanager
def _style(plt: Any) -> Iterator[None]:
    """The figures' common look: small titles and labels, a light grid."""
    with plt.rc_context(
        {
            "axes.titlesize": 9,
            "axes.labelsize": 8,
            "xtick.labelsize": 7,
            "ytick.labelsize": 7,
            "legend.fontsize": 7,
            "axes.grid": True,
            "grid.alpha": 0.3,
            "lines.linewidth": 0.8,
        }
    ):
        yield


def plot_fit_record(
    path: str | Path,
    *,
    t: np.ndarray,
    measured: np.ndarray,
    simulated: np.ndarray,
    outputs: Sequence[str],
    fit: Mapping[str, float | None],
    units: Mapping[str, str] | None = None,
) -> Path:
    """Per output: the measured and simulated output over the whole record, a zoomed window around the largest
    residual, and the residual against time.

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
    fit : mapping of str to float or None
        NRMSE (%) per output, for the titles.
    units : mapping of str to str or None
        The unit of each output (a model file's ``units`` table), written on its axes where given.

    Returns
    -------
    Path
    """
    plt = agg_pyplot()
    ny = len(outputs)
    with _style(plt):
        fig, axes = plt.subplots(
            2 * ny, 2, figsize=(10, 4.6 * ny + 0.4), squeeze=False, gridspec_kw={"height_ratios": [1.4, 1.0] * ny}
        )
        for j, name in enumerate(outputs):
            y, s = measured[:, j], simulated[:, j]
            e = y - s
            label = f"{name} ({(units or {})[name]})" if (units or {}).get(name) else name
            win = zoom_window(e, 0)
            full, zoom = axes[2 * j, 0], axes[2 * j, 1]
            nrmse = fit.get(name)
            for ax in (full, zoom):
                sl = slice(None) if ax is full else win
                seen = ~np.isnan(y[sl])
                ax.plot(t[sl][seen], y[sl][seen], lw=1.4, color=MEASURED, label="measured")
                ax.plot(t[sl], s[sl], color=MODEL, label="model at the estimate")
                ax.set_ylabel(label)
            full.axvspan(t[win.start], t[win.stop - 1], color="C1", alpha=0.15, lw=0, label="zoomed window")
            full.set_title(
                f"{name}: NRMSE "
                + (f"{nrmse:.2f} %" if nrmse is not None and np.isfinite(nrmse) else "-")
                + " (whole record)"
            )
            full.legend(loc="upper right")
            zoom.set_title(f"zoom: {win.stop - win.start} samples around the largest residual")
            res = plt.subplot2grid((2 * ny, 2), (2 * j + 1, 0), colspan=2, fig=fig)
            axes[2 * j + 1, 0].remove()
            axes[2 * j + 1, 1].remove()
            res.plot(t, e, lw=0.6, color=RESIDUAL)
            res.axvspan(t[win.start], t[win.stop - 1], color="C1", alpha=0.15, lw=0)
            res.set_title(f"residual: measured - model (RMS {np.sqrt(np.nanmean(e**2)):.3g})")
            res.set_ylabel(f"residual of {label}")
            res.set_xlabel("t (s)")
            zoom.set_xlabel("t (s)")
        return save_png(plt, fig, path)


def correlation_bounds(n: int, level: float, p: float = 1.0) -> float:
    """The two-sided bound of an estimated correlation of ``n`` samples at ``level``: ``z sqrt(p / n)``.

    Parameters
    ----------
    n : int
        The samples.
    level : float
        The two-sided level (0.01: 99 % bounds).
    p : float
        The variance of ``sqrt(n)`` times the correlation under the null (1 for a white series).

    Returns
    -------
    float

    Examples
    --------
    >>> round(correlation_bounds(400, 0.05), 4)
    0.098
    """
    from scipy.stats import norm

    return float(norm.ppf(1 - level / 2) * np.sqrt(p / n))


def _correlation(a: np.ndarray, b: np.ndarray, lags: np.ndarray) -> np.ndarray:
    """The normalised correlation ``sum a(k + tau) b(k) / (n std_a std_b)`` at each lag (means removed)."""
    a, b = a - a.mean(), b - b.mean()
    n, scale = len(a), len(a) * a.std() * b.std()
    if scale == 0:
        return np.zeros(len(lags))
    return (
        np.array([np.dot(a[tau:], b[: n - tau]) if tau >= 0 else np.dot(a[: n + tau], b[-tau:]) for tau in lags])
        / scale
    )


def plot_residuals(
    path: str | Path,
    *,
    residuals: np.ndarray,
    inputs: np.ndarray | None,
    outputs: Sequence[str],
    input_names: Sequence[str] = (),
    lags: int = 25,
    level: float = 0.01,
) -> Path:
    """Per output: the residual's autocorrelation and its cross-correlation with each input, with their bounds.

    Parameters
    ----------
    path : str or Path
        The PNG file to write.
    residuals : numpy.ndarray
        ``(T, ny)``: measured minus the model's output (NaN at a gap: the longest stretch without one is used).
    inputs : numpy.ndarray or None
        ``(T, nu)``: the measured inputs (None or no column: no cross-correlation panel).
    outputs, input_names : sequence of str
        The names.
    lags : int
        The largest lag drawn (samples).
    level : float
        The two-sided level of the bounds (the adequacy tests' level).

    Returns
    -------
    Path
    """
    plt = agg_pyplot()
    e_all = np.asarray(residuals, float).reshape(len(residuals), -1)
    u_all = np.zeros((len(e_all), 0)) if inputs is None else np.asarray(inputs, float).reshape(len(e_all), -1)
    nu = u_all.shape[1]
    with _style(plt):
        fig, axes = plt.subplots(
            len(outputs), 1 + nu, figsize=(4.2 * (1 + nu), 2.8 * len(outputs) + 0.5), squeeze=False
        )
        for j, name in enumerate(outputs):
            run = longest_run(~np.isnan(e_all[:, j]))
            e = e_all[run, j]
            n = len(e)
            m = max(1, min(lags, n // 5))
            pos = np.arange(0, m + 1)
            r_e = _correlation(e, e, pos)
            ax = axes[j, 0]
            ax.vlines(pos[1:], 0, r_e[1:], color=RESIDUAL)
            ax.plot(pos[1:], r_e[1:], "o", ms=2.5, color=RESIDUAL)
            bound = correlation_bounds(n, level)
            for b in (bound, -bound):
                ax.axhline(b, color="k", ls="--", lw=0.7)
            ax.axhline(0, color="k", lw=0.5)
            ax.set_title(f"autocorrelation of the residual of {name}")
            ax.set_xlabel("lag (samples)")
            ax.set_ylabel("correlation")
            for i in range(nu):
                u = u_all[run, i]
                both = np.arange(-m, m + 1)
                r_eu = _correlation(e, u, both)
                r_u = _correlation(u, u, both)
                r_ee = _correlation(e, e, both)
                p = float(np.sum(r_ee * r_u))  # the variance of sqrt(n) r_eu under independence (Ljung 16.62)
                ax = axes[j, 1 + i]
                ax.vlines(both, 0, r_eu, color=RESIDUAL)
                ax.plot(both, r_eu, "o", ms=2.5, color=RESIDUAL)
                bu = correlation_bounds(n, level, max(p, 0.0))
                for b in (bu, -bu):
                    ax.axhline(b, color="k", ls="--", lw=0.7)
                ax.axhline(0, color="k", lw=0.5)
                label = input_names[i] if i < len(input_names) else f"input {i + 1}"
                ax.set_title(f"cross-correlation of the residual of {name} with {label}")
                ax.set_xlabel("lag (samples; positive: the input leads)")
        fig.suptitle(
            f"residual analysis; dashed: {100 * (1 - level):g} % bounds of a white residual independent of the input",
            fontsize=9,
        )
        return save_png(plt, fig, path)


def model_frf(A: Any, B: Any, C: Any, D: Any, f: Any) -> np.ndarray:
    """The frequency response ``C (i 2 pi f I - A)^-1 B + D`` of a linear model at the frequencies ``f`` (Hz).

    Parameters
    ----------
    A, B, C, D : array_like
        The state-space matrices.
    f : array_like
        The frequencies (Hz).

    Returns
    -------
    numpy.ndarray
        ``(len(f), ny, nu)``, complex.

    Examples
    --------
    >>> H = model_frf([[0.0, 1.0], [-4.0, -0.4]], [[0.0], [1.0]], [[1.0, 0.0]], [[0.0]], [0.0])
    >>> complex(H[0, 0, 0])   # the static gain 1/k
    (0.25+0j)
    """
    A, B, C, D = (np.atleast_2d(np.asarray(M, float)) for M in (A, B, C, D))
    eye = np.eye(A.shape[0])
    return np.array([C @ np.linalg.solve(2j * np.pi * fk * eye - A, B) + D for fk in np.asarray(f, float)])


def segment_length(n: int, most: int = SEGMENT) -> int:
    """Samples per Welch segment for a record of ``n``: ``most``, or a quarter of the record where that is shorter
    (7 half-overlapping segments: one segment alone gives a coherence of 1 at every frequency, which says nothing).

    Parameters
    ----------
    n : int
        The samples of the record.
    most : int
        The longest segment.

    Returns
    -------
    int

    Examples
    --------
    >>> segment_length(100_000), segment_length(750)
    (1024, 187)
    """
    return int(min(most, max(16, n // 4), n))


def h1_estimate(u: Any, y: Any, fs: float, *, segment: int = SEGMENT) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The H1 estimate of the response of ``y`` to ``u`` and their coherence, by Welch's averaged spectra.

    Parameters
    ----------
    u, y : array_like
        One input and one output, of the same length.
    fs : float
        The sampling frequency (Hz).
    segment : int
        Samples per segment at most (Hann windows, half overlap; :func:`segment_length`).

    Returns
    -------
    tuple of numpy.ndarray
        ``(f, H1, coherence)``.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(4096)
    >>> f, H, coh = h1_estimate(u, 2.0 * u, 100.0)
    >>> bool(np.allclose(H, 2.0)), bool(np.allclose(coh, 1.0))
    (True, True)
    """
    from scipy.signal import coherence, csd, welch

    u, y = np.asarray(u, float), np.asarray(y, float)
    seg = segment_length(len(u), segment)
    f, puy = csd(u, y, fs=fs, nperseg=seg)
    _, puu = welch(u, fs=fs, nperseg=seg)
    _, coh = coherence(u, y, fs=fs, nperseg=seg)
    with np.errstate(invalid="ignore", divide="ignore"):
        return f, puy / puu, coh


def plot_frf(
    path: str | Path,
    *,
    t: np.ndarray,
    inputs: np.ndarray,
    measured: np.ndarray,
    A: Any,
    B: Any,
    C: Any,
    D: Any,
    input_names: Sequence[str],
    outputs: Sequence[str],
    segment: int = SEGMENT,
) -> Path:
    """Per input and output: the model's frequency response against the measured H1 estimate (magnitude and phase),
    and the coherence.

    Parameters
    ----------
    path : str or Path
        The PNG file to write.
    t : numpy.ndarray
        Sample times (s).
    inputs, measured : numpy.ndarray
        The measured inputs ``(T, nu)`` and outputs ``(T, ny)`` (the longest stretch without an output gap is used).
    A, B, C, D : array_like
        The model linearised at rest.
    input_names, outputs : sequence of str
        The names.
    segment : int
        Samples per Welch segment at most.

    Returns
    -------
    Path
    """
    plt = agg_pyplot()
    u_all = np.asarray(inputs, float).reshape(len(t), -1)
    y_all = np.asarray(measured, float).reshape(len(t), -1)
    fs = 1.0 / float(t[1] - t[0])
    pairs = [(i, j) for i in range(u_all.shape[1]) for j in range(y_all.shape[1])]
    several = u_all.shape[1] > 1
    with _style(plt):
        fig, axes = plt.subplots(len(pairs), 3, figsize=(12, 2.8 * len(pairs) + 0.6), squeeze=False)
        for row, (i, j) in enumerate(pairs):
            run = longest_run(~np.isnan(y_all[:, j]))
            f, H1, coh = h1_estimate(u_all[run, i], y_all[run, j], fs, segment=segment)
            f, H1, coh = f[1:], H1[1:], coh[1:]  # the mean (0 Hz) is removed by the detrending
            fm = np.geomspace(f[0], f[-1], 600)  # the model on a fine grid: its peaks are not sampled away
            Hm = model_frf(A, B, C, D, fm)[:, j, i]
            mag, phase, co = axes[row]
            weak = coh < COHERENT
            for part, shade, label in (
                (~weak, MEASURED, "measured (H1)"),
                (weak, "0.88", f"measured, coherence below {COHERENT:g}"),
            ):
                shown = np.where(part, H1, np.nan)
                mag.loglog(f, np.abs(shown), lw=1.4, color=shade, label=label)
                phase.semilogx(f, np.degrees(np.angle(shown)), lw=1.4, color=shade)
            mag.loglog(fm, np.abs(Hm), color=MODEL, label="model linearised at rest")
            phase.semilogx(fm, np.degrees(np.angle(Hm)), color=MODEL)
            co.semilogx(f, coh, color=MEASURED, lw=1.0)
            co.axhline(COHERENT, color="k", ls="--", lw=0.7)
            co.set_ylim(0, 1.05)
            pair = f"{input_names[i]} to {outputs[j]}"
            mag.set_title(f"|H|, {pair}")
            mag.set_ylabel(f"|{outputs[j]} / {input_names[i]}|")
            phase.set_title(f"phase, {pair}")
            phase.set_ylabel("degrees")
            co.set_title(f"coherence, {pair}" + (" (the other inputs add to the noise)" if several else ""))
            mag.legend(loc="lower left")
            for ax in axes[row]:
                ax.set_xlabel("frequency (Hz)")
        seg = segment_length(len(t), segment)
        fig.suptitle(
            f"frequency response: the model against the measured H1 estimate (Welch, {seg}-sample Hann "
            f"segments, half overlap)",
            fontsize=9,
        )
        return save_png(plt, fig, path)


@dataclass(frozen=True, eq=False)
class HysteresisLoop:
    """A hysteresis loop to draw: the restoring force against the displacement, measured and the model's.

    Attributes
    ----------
    displacement_measured, force_measured
        The measured loop (samples of the record).
    displacement_model, force_model
        The model's loop at the estimate (its simulation).
    xlabel, ylabel
        The axes' labels (what the displacement is, in which units the force is).
    note
        How the loop was made (a line under the figure).
    """

    displacement_measured: np.ndarray
    force_measured: np.ndarray
    displacement_model: np.ndarray
    force_model: np.ndarray
    xlabel: str
    ylabel: str
    note: str


@dataclass(frozen=True)
class NoHysteresisLoop:
    """No hysteresis loop for a run, and why (``reason``, a sentence the figure shows in place of the loop).

    Examples
    --------
    >>> NoHysteresisLoop("the model does not linearise at rest").note
    'no loop drawn: the model does not linearise at rest'
    """

    reason: str

    @property
    def note(self) -> str:
        """What the figure says in place of the loop."""
        return f"no loop drawn: {self.reason}"


def plot_hysteresis(path: str | Path, loop: HysteresisLoop | NoHysteresisLoop) -> Path:
    """The hysteresis loop: the restoring force against the displacement, measured and the model's.

    Parameters
    ----------
    path : str or Path
        The PNG file to write.
    loop : HysteresisLoop or NoHysteresisLoop
        The loop, with its axes' labels and how it was made (a line under the title); or why there is none (said in
        the middle of an empty frame).

    Returns
    -------
    Path
    """
    plt = agg_pyplot()
    with _style(plt):
        fig, ax = plt.subplots(1, 1, figsize=(6.5, 5.5))
        note = loop.note
        if isinstance(loop, HysteresisLoop):
            ax.plot(loop.displacement_measured, loop.force_measured, lw=1.2, color=MEASURED, label="measured")
            ax.plot(loop.displacement_model, loop.force_model, color=MODEL, lw=0.7, label="model at the estimate")
            ax.set_xlabel(loop.xlabel)
            ax.set_ylabel(loop.ylabel)
            ax.legend(loc="upper left")
        else:  # said in the middle, not a blank frame
            ax.set_xlabel("displacement")
            ax.set_ylabel("restoring force")
            ax.text(0.5, 0.5, textwrap.fill(note, 60), ha="center", va="center", fontsize=8, transform=ax.transAxes)
        ax.set_title("hysteresis loop: restoring force against displacement")
        lines = textwrap.wrap(note, 100)
        fig.text(0.5, 0.01, "\n".join(lines), ha="center", va="bottom", fontsize=7)
        fig.tight_layout(rect=(0, 0.03 * len(lines), 1, 1))
        return save_png(plt, fig, path, tight=False)
