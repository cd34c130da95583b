"""Figures (matplotlib, Agg): the identification experiment after the seed paper's Figures 2 and 3,
and the observer bank's crack forces.

``figure2``: (a) the ground motion, (b) measured and estimated displacement (UKF and DUKF).
``figure3``: the estimated/true ratio of every parameter over time, one panel per filter.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np

from obsnl.errors import OutputError
from obsnl.report.files import check_target

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["figure2", "figure3", "plot_traces", "plot_bank_forces", "FIGURE_PREFIX", "agg_pyplot", "save_png"]

#: Bank figures are written as ``<FIGURE_PREFIX><scenario>.png``.
FIGURE_PREFIX = "forces_"

_LATEX = {
    "k_m": r"$k_m$",
    "c_dm": r"$c_{dm}$",
    "c_eta_p": r"$c'_\eta$",
    "w_h": r"$w_h$",
    "c_p": r"$c'$",
    "h_p": r"$h'$",
    "Delta1": r"$\Delta_1$",
    "Delta2": r"$\Delta_2$",
    "N": r"$N$",
}


def agg_pyplot() -> ModuleType:
    """``matplotlib.pyplot`` on the Agg backend (no display needed), imported on first use.

    Matplotlib is imported here, on the first call, not when a module is imported: an analysis that draws
    nothing does not load it.

    Returns
    -------
    types.ModuleType
        The module ``matplotlib.pyplot``, its backend set to Agg.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_png(plt: ModuleType, fig: Figure, path: str | Path, *, dpi: int = 130, tight: bool = True) -> Path:
    """Save ``fig`` as PNG at ``path``, then close it.

    The figure is written to a temporary file in the same folder and renamed onto ``path``: a symbolic link
    there is replaced by the file, never written through (the caller has decided, with
    :func:`obsnl.report.files.check_target`, that ``path`` may be replaced). What no caller may replace is
    refused before anything is created: a FIFO, a device or a socket, a name that names a folder (``x.png/``).
    The figure is closed whether or not it was written.

    Parameters
    ----------
    plt : types.ModuleType
        ``matplotlib.pyplot`` (from :func:`agg_pyplot`), which closes the figure.
    fig : matplotlib.figure.Figure
        The figure to write.
    path : str or Path
        The PNG file to write (its folder is made when missing).
    dpi : int
        Resolution in dots per inch.
    tight : bool
        Whether to call ``fig.tight_layout()`` before saving.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    OutputError
        ``path`` may not be written (see :func:`obsnl.report.files.check_target`), or writing it failed.
    """
    tmp = None
    try:
        out = check_target(path, force=True)
        if tight:
            fig.tight_layout()
        out.parent.mkdir(parents=True, exist_ok=True)
        tmp = out.parent / f".{out.name}.{os.getpid()}.tmp"  # a new file (O_EXCL), the user's umask applies
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o666)
        with os.fdopen(fd, "wb") as fh:
            fig.savefig(fh, dpi=dpi, format="png")
        os.replace(tmp, out)
        tmp = None
    except OutputError:
        raise
    except OSError as exc:
        raise OutputError(f"cannot write {path}: {exc.strerror or exc}") from None
    finally:
        plt.close(fig)
        if tmp is not None and os.path.exists(tmp):
            os.unlink(tmp)
    return out


def figure2(
    path: str | Path,
    *,
    t: np.ndarray,
    accel: np.ndarray,
    y_measured: np.ndarray,
    estimates: Mapping[str, np.ndarray],
    title: str = "",
) -> Path:
    """(a) record, (b) measured vs estimated displacement; ``estimates`` maps a label to ``y`` per sample.

    Parameters
    ----------
    path : str or Path
        The PNG file to write.
    t : numpy.ndarray
        Sample times (s).
    accel : numpy.ndarray
        Ground acceleration (m/s^2).
    y_measured : numpy.ndarray
        Measured displacement (m).
    estimates : mapping of str to numpy.ndarray
        Estimated displacement (m) per label.
    title : str
        Record name for panel (a).

    Returns
    -------
    Path
    """
    plt = agg_pyplot()
    fig, ax = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    ax[0].plot(t, accel, lw=0.7, color="k")
    ax[0].set_ylabel(r"$\ddot{x}_g$ (m/s$^2$)")
    ax[0].set_title("(a) ground acceleration" + (f": {title}" if title else ""), fontsize=10)
    ax[1].plot(t, 1e3 * np.ravel(y_measured), lw=1.6, color="0.75", label="measured")
    for (label, y), style in zip(estimates.items(), ("-", "--", ":")):
        ax[1].plot(t, 1e3 * np.ravel(y), style, lw=0.8, label=label)
    ax[1].set_ylabel(r"$x_1$ (mm)")
    ax[1].set_xlabel("t (s)")
    ax[1].set_title("(b) measured and estimated displacement", fontsize=10)
    ax[1].legend(fontsize=8, loc="upper right")
    return save_png(plt, fig, path)


def figure3(
    path: str | Path,
    *,
    t: np.ndarray,
    panels: Mapping[str, np.ndarray],
    truth: np.ndarray,
    parameters: Sequence[str],
    flagged: Sequence[str] = (),
    ylim: tuple[float, float] = (0.0, 4.0),
) -> Path:
    """Estimated/true ratio over time; ``panels`` maps a title to ``theta`` ``(T, np)``.

    Parameters flagged as practically unidentifiable are drawn dashed and marked in the legend.
    """
    plt = agg_pyplot()
    fig, axes = plt.subplots(len(panels), 1, figsize=(8, 3.2 * len(panels)), sharex=True, squeeze=False)
    cmap = plt.get_cmap("tab10")
    for ax, (title, theta) in zip(axes[:, 0], panels.items()):
        ratio = np.asarray(theta) / np.asarray(truth)
        for i, p in enumerate(parameters):
            name = _LATEX.get(p, p) + (" (poorly informed)" if p in flagged else "")
            ax.plot(t, ratio[:, i], "--" if p in flagged else "-", lw=1.0, color=cmap(i % 10), label=name)
        ax.axhline(1.0, color="k", lw=0.6)
        ax.set_ylim(*ylim)
        ax.set_ylabel("estimated / true")
        ax.set_title(title, fontsize=10)
        ax.legend(fontsize=7, ncol=5, loc="upper right")
    axes[-1, 0].set_xlabel("t (s)")
    return save_png(plt, fig, path)


# ---- identification of a structure (obsnl identify)
def table2_errors_figure(
    path: str | Path,
    *,
    parameters: Sequence[str],
    errors: Mapping[str, Sequence[float]],
    flagged: Mapping[str, Sequence[bool]],
    goal: float = 5.0,
) -> Path:
    """Table 2 as one figure: the worst-seed error in % of each parameter (groups) for each column (bars, log
    scale), a flagged estimate hatched, the 5 % goal as a line.

    Parameters
    ----------
    path : str or Path
        The PNG file.
    parameters : sequence of str
        The parameters' names (as the table prints them).
    errors, flagged : mapping of str to sequence
        Per column (a protocol and filter), the errors in % and whether each parameter is flagged.
    goal : float
        The goal's line, in %.

    Returns
    -------
    Path
    """
    plt = agg_pyplot()
    fig, ax = plt.subplots(figsize=(max(7.0, 1.1 * len(parameters) + 2), 4.2))
    width = 0.8 / max(len(errors), 1)
    x = np.arange(len(parameters))
    for i, (col, errs) in enumerate(errors.items()):
        e = np.maximum(np.asarray(errs, float), 1e-3)  # an exact estimate still shows as a stub
        bars = ax.bar(x + (i - (len(errors) - 1) / 2) * width, e, width, label=col)
        for b, f in zip(bars, flagged[col]):
            if f:
                b.set_hatch("///")
                b.set_alpha(0.55)
    ax.axhline(goal, color="k", lw=0.8, ls="--", label=f"{goal:g} % goal")
    ax.set_yscale("log")
    ax.set_xticks(x, list(parameters))
    ax.set_ylabel("worst error over the seeds (%)")
    ax.set_title("Table 2: errors per parameter and filter (hatched: flagged, not held to the goal)")
    ax.legend(fontsize=7, ncol=2)
    return save_png(plt, fig, path)


def plot_traces(
    path: str | Path,
    *,
    traces: Sequence[Any],
    truth: Mapping[str, float] | None = None,
    held: Sequence[str] = (),
    flagged: Sequence[str] = (),
) -> Path:
    """Each parameter's estimate over the passes (one after the other) with its +-2 sigma band (log
    coordinates: ``theta exp(+-2 sigma)``); true value dotted where known; held parameters marked.

    Parameters
    ----------
    path : str or Path
        The PNG file to write.
    traces : sequence of Trajectory
        One per pass.
    truth : mapping of str to float or None
        True values where known.
    held, flagged : sequence of str
        Parameters held at their guess, and poorly informed ones.

    Returns
    -------
    Path
    """
    plt = agg_pyplot()
    params = traces[0].parameters
    nx = len(traces[0].states)
    dt = float(traces[0].t[1] - traces[0].t[0])
    theta = np.vstack([tr.theta for tr in traces])
    sd = np.sqrt(np.clip(np.vstack([np.diagonal(tr.P, axis1=1, axis2=2)[:, nx:] for tr in traces]), 0, None))
    t = np.arange(len(theta)) * dt
    cols = 2 if len(params) > 3 else 1
    rows = -(-len(params) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(8, 1.9 * rows + 0.6), sharex=True, squeeze=False)
    for i, p in enumerate(params):
        ax = axes[i // cols, i % cols]
        ax.plot(t, theta[:, i], lw=0.9, color="C0")
        if sd.shape[1] == len(params):
            ax.fill_between(
                t, theta[:, i] * np.exp(-2 * sd[:, i]), theta[:, i] * np.exp(2 * sd[:, i]), color="C0", alpha=0.2, lw=0
            )
        if truth and p in truth:
            ax.axhline(truth[p], color="k", lw=0.7, ls=":")
        for k in range(1, len(traces)):
            ax.axvline(k * len(traces[0].t) * dt, color="0.6", lw=0.5)
        tag = " (held at its guess)" if p in held else " (poorly informed)" if p in flagged else ""
        ax.set_title(_LATEX.get(p, p) + tag, fontsize=9)
    for j in range(len(params), rows * cols):
        axes[j // cols, j % cols].set_visible(False)
    for ax in axes[-1, :]:
        ax.set_xlabel("time over the passes (s)")
    return save_png(plt, fig, path)


# ---- observer bank
def plot_bank_forces(study: Any, out_dir: str | Path, *, every: int = 5) -> list[Path]:
    """One PNG per scenario: estimated crack forces (first seed) and their sliding RMS against tau.

    Parameters
    ----------
    study : Any
        A :class:`obsnl.studies.link_study.LinkStudy` (its ``traces`` hold the time series, its
        ``settings`` the onset and the seeds).
    out_dir : str or Path
        Folder for ``forces_<scenario>.png`` (created if needed; existing files are replaced,
        the caller decides whether that is allowed).
    every : int
        Plot every ``every``-th sample (the figures stay small).
    """
    plt = agg_pyplot()
    from obsnl.linear.bank import sliding_rms

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    thr, st = study.thresholds, study.settings
    paths = []
    for name, (t, nhat, n_true) in study.traces.items():
        nwin = int(round(thr.window / (t[1] - t[0])))
        srms = sliding_rms(nhat, nwin)
        fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7.5, 4.8), sharex=True, constrained_layout=True)
        sl = slice(None, None, max(1, int(every)))
        ax1.plot(t[sl], n_true[sl], color="0.6", lw=0.8, label="true (dipole projection)")
        for j, lab in enumerate(thr.labels):
            ax1.plot(t[sl], nhat[sl, j], lw=0.8, label=f"n̂ obs {lab}")
            (line,) = ax2.plot(t[sl], srms[sl, j], lw=1.0, label=f"obs {lab}")
            ax2.axhline(thr.tau[j], color=line.get_color(), ls="--", lw=0.8)
        for ax in (ax1, ax2):
            if name != "healthy":
                ax.axvline(st.onset, color="k", lw=0.6, ls=":")
            ax.grid(alpha=0.3)
        ax1.set_ylabel("crack force [N·m]")
        ax1.set_title(f"{name}: estimated crack forces (seed {st.evaluation_seeds[0]})", fontsize=10)
        ax1.legend(fontsize=7, ncol=4, loc="upper left")
        ax2.set_ylabel(f"{thr.window:g}-s RMS [N·m]")
        ax2.set_xlabel("time [s]")
        ax2.legend(fontsize=7, ncol=3, loc="upper left", title="dashed: tau", title_fontsize=7)
        paths.append(save_png(plt, fig, out / f"{FIGURE_PREFIX}{name}.png", dpi=80, tight=False))
    return paths


def plot_profiles(
    path: str | Path, *, profiles: Sequence[Any], threshold: float, truth: Mapping[str, float] | None = None
) -> Path:
    """The profile likelihood of each parameter, one panel each: ``Delta chi2`` against the parameter, the
    95 % threshold, the estimate and the interval (true value dotted where known).

    Parameters
    ----------
    path : str or Path
        The PNG file to write.
    profiles : sequence
        :class:`~obsnl.identification.profile.Profile` values (``name``, ``estimate``, ``interval``, ``shape``,
        ``points``).
    threshold : float
        The chi2 threshold of the 95 % interval (a profile's own ``threshold``, where it has one, wins: noise
        on the measured inputs raises it).
    truth : mapping of str to float or None
        True values (a simulation study).

    Returns
    -------
    Path
    """
    plt = agg_pyplot()
    n = max(len(profiles), 1)
    cols = min(n, 3)
    rows = -(-n // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.4 * cols, 2.6 * rows + 0.4), squeeze=False)
    for ax in axes.ravel()[len(profiles) :]:
        ax.axis("off")
    if not profiles:  # a run without the refinement (refine=False, or it could not run) has none: said, not blank
        axes[0, 0].text(
            0.5,
            0.5,
            "no profile likelihood in this run:\nthe maximum-likelihood refinement\ndid not run (see identify.json)",
            ha="center",
            va="center",
            fontsize=9,
            transform=axes[0, 0].transAxes,
        )
    for ax, pr in zip(axes.ravel(), profiles):
        pts = np.array(pr.points, float).reshape(-1, 2)
        if len(pts) < 2:  # a profile that was not computed or failed is said, not drawn as a dot
            why = "; ".join(s for s in pr.sides if s) or pr.shape
            import textwrap

            ax.text(
                0.5,
                0.5,
                textwrap.fill(f"no profile: {why}", 34),
                ha="center",
                va="center",
                fontsize=8,
                transform=ax.transAxes,
            )
            ax.set_title(f"{pr.name} ({pr.shape})", fontsize=9)
            ax.set_xticks([])
            ax.set_yticks([])
            continue
        # between computed points, sqrt(Delta) is interpolated linearly on each side of the estimate (exact for a
        # quadratic profile), so the drawn curve bends as a profile does instead of joining points by chords
        side = np.where(pts[:, 0] < pr.estimate, -1.0, 1.0)
        grid = np.linspace(pts[0, 0], pts[-1, 0], 200) if len(pts) > 1 else pts[:, 0]
        signed = np.interp(grid, pts[:, 0], side * np.sqrt(np.maximum(pts[:, 1], 0.0)))
        ax.plot(grid, signed**2, lw=1, color="C0")
        ax.plot(pts[:, 0], pts[:, 1], "o", ms=3, color="C0")
        ax.axhline(getattr(pr, "threshold", threshold), color="C3", lw=0.8, ls="--")
        ax.axvline(pr.estimate, color="0.3", lw=0.8)
        for end in pr.interval:
            if end is not None:
                ax.axvline(end, color="C3", lw=0.8)
        if truth and pr.name in truth:
            ax.axvline(truth[pr.name], color="k", lw=1, ls=":")
        ax.set_title(f"{pr.name} ({pr.shape})", fontsize=9)
        ax.set_ylabel(r"$\Delta\chi^2$", fontsize=8)
        ax.set_xlabel(pr.name, fontsize=8)
        ax.ticklabel_format(axis="x", useOffset=False)  # values as they are, not as an offset plus small numbers
        ax.tick_params(labelsize=7)
    fig.suptitle("profile likelihood; dashed: 95 % threshold", fontsize=9)
    return save_png(plt, fig, path)
