"""Rendering of the observer-bank study: a Markdown localisation table and force plots (PNG).

Presentation only: the numbers come from :func:`obsnl.bank.run_link_study` (or its
``to_dict()``, e.g. a stored ``bank.json``); nothing here computes a decision.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["bank_table_markdown", "plot_bank_forces", "FIGURE_PREFIX"]

#: Figures are written as ``<FIGURE_PREFIX><scenario>.png``.
FIGURE_PREFIX = "forces_"


def _num(x: Any, fmt: str = ".3f") -> str:
    return "–" if x is None else format(x, fmt)


def _counts(values: Sequence[Any], n: int) -> str:
    c = Counter("–" if v is None else str(v) for v in values)
    if len(c) == 1 and "–" in c:
        return "–"
    return ", ".join(f"{k} ({v}/{n})" for k, v in c.most_common())


def _span(values: Sequence[float | None], fmt: str = ".3f") -> str:
    v = [x for x in values if x is not None]
    if not v:
        return "–"
    lo, hi = min(v), max(v)
    return _num(lo, fmt) if format(lo, fmt) == format(hi, fmt) else f"{_num(lo, fmt)}–{_num(hi, fmt)}"


def bank_table_markdown(doc: Mapping[str, Any]) -> str:
    """The localisation table (one row per scenario, aggregated over seeds), thresholds and gates.

    Parameters
    ----------
    doc
        ``LinkStudy.to_dict()`` (the content of ``bank.json``).
    """
    st, thr = doc["settings"], doc["thresholds"]
    labels = list(thr["labels"])
    out = ["# Observer bank on the cantilever link", ""]
    out.append(
        f"Scenarios of observer_bank.md section 2.5 (source: {st['model']}). Sensors {st['sensors']}, "
        f"force channels {', '.join(st['channels'])} ({st['fictitious_model']} model, q_x = {st['q_x']:g}, "
        f"q_v = {st['q_v']:g}), crack severity {st['severity']:g}, noise {100 * st['noise']:g} % of the healthy "
        f"RMS, dt = {st['dt']:g} s, T = {st['duration']:g} s, crack onset at {st['onset']:g} s."
    )
    out.append("")
    out.append(
        f"Evaluation seeds {', '.join(map(str, st['evaluation_seeds']))}; thresholds from healthy runs with the "
        f"other seeds {', '.join(map(str, thr['seeds']))}: tau = {thr['factor']:g} × the largest "
        f"{thr['window']:g}-s sliding RMS. Location: RMS over the last {st['evaluation_window']:g} s; "
        f"'inconclusive' when the two largest forces are within a ratio of {st['ratio_band']:g} or the rules disagree."
    )
    out += ["", "| observer (element) | healthy floor [N·m] | tau [N·m] |", "|---|---|---|"]
    for lab in labels:
        out.append(f"| {lab} | {thr['floor'][lab]:.4f} | {thr['tau'][lab]:.4f} |")
    out += ["", "## Localisation (mean RMS force over seeds)", ""]
    head = ["scenario", "crack element", "truth RMS [N·m]"] + [f"RMS n̂ obs {lab} [N·m]" for lab in labels]
    head += ["detected", "time to detection [s]", "magnitude rule", "residual rule", "margin", "verdict"]
    out += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    by_scn: dict[str, list[Mapping[str, Any]]] = {}
    for r in doc["runs"]:
        by_scn.setdefault(r["scenario"], []).append(r)
    for name, rs in by_scn.items():
        n = len(rs)
        row = [name, _num(rs[0]["crack_element"], "d"), f"{rs[0]['truth_rms']:.3f}"]
        row += [f"{np.mean([r['rms_force'][lab] for r in rs]):.3f}" for lab in labels]
        row += [f"{sum(r['detected'] for r in rs)}/{n}", _span([r["time_to_detection"] for r in rs]),
                _counts([r["by_magnitude"] for r in rs], n), _counts([r["by_residual"] for r in rs], n),
                _span([r["margin"] for r in rs], ".2f"), _counts([r["verdict"] for r in rs], n)]
        out.append("| " + " | ".join(row) + " |")
    if doc.get("gates"):
        out += ["", "## Observability gate of the extended system (section 2.6.6)", "",
                "| sensors | channels | element | p | s | verdict | static-gain singular values | condition | reason |",
                "|---|---|---|---|---|---|---|---|---|"]
        for g in doc["gates"]:
            sv = ", ".join(f"{x:.2e}" for x in g["static_gain_singular_values"])
            out.append(f"| {g['sensors']} | {'+'.join(g['channels'])} | {g['element']} | {g['n_outputs']} | "
                       f"{g['n_channels']} | {g['verdict']} | {sv} | {_num(g['condition'], '.3g')} | "
                       f"{g['reason'] or '–'} |")
    return "\n".join(out) + "\n"


def plot_bank_forces(study: Any, out_dir: str | Path, *, every: int = 5) -> list[Path]:
    """One PNG per scenario: estimated crack forces (first seed) and their sliding RMS against tau.

    Parameters
    ----------
    study
        A :class:`obsnl.bank.LinkStudy` (its ``traces`` hold the time series).
    out_dir
        Folder for ``forces_<scenario>.png`` (created if needed; existing files are replaced,
        the caller decides whether that is allowed).
    every
        Plot every ``every``-th sample (the figures stay small).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .bank import sliding_rms

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
            line, = ax2.plot(t[sl], srms[sl, j], lw=1.0, label=f"obs {lab}")
            ax2.axhline(thr.tau[j], color=line.get_color(), ls="--", lw=0.8)
        for ax in (ax1, ax2):
            if name != "healthy":
                ax.axvline(st["onset"], color="k", lw=0.6, ls=":")
            ax.grid(alpha=0.3)
        ax1.set_ylabel("crack force [N·m]")
        ax1.set_title(f"{name}: estimated crack forces (seed {st['evaluation_seeds'][0]})", fontsize=10)
        ax1.legend(fontsize=7, ncol=4, loc="upper left")
        ax2.set_ylabel(f"{thr.window:g}-s RMS [N·m]")
        ax2.set_xlabel("time [s]")
        ax2.legend(fontsize=7, ncol=3, loc="upper left", title="dashed: tau", title_fontsize=7)
        path = out / f"{FIGURE_PREFIX}{name}.png"
        fig.savefig(path, dpi=80)
        plt.close(fig)
        paths.append(path)
    return paths
