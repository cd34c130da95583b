"""The observer-bank table (seed ``001_d0508a78c5399696.txt``; numbers from
:func:`obsnl.studies.link_study.run_link_study`), as Markdown."""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

__all__ = ["bank_table_markdown"]


def _bank_num(x: Any, fmt: str = ".3f") -> str:
    return "–" if x is None else format(x, fmt)


def _bank_counts(values: Sequence[Any], n: int) -> str:
    c = Counter("–" if v is None else str(v) for v in values)
    if len(c) == 1 and "–" in c:
        return "–"
    return ", ".join(f"{k} ({v}/{n})" for k, v in c.most_common())


def _bank_span(values: Sequence[float | None], fmt: str = ".3f") -> str:
    v = [x for x in values if x is not None]
    if not v:
        return "–"
    lo, hi = min(v), max(v)
    return _bank_num(lo, fmt) if format(lo, fmt) == format(hi, fmt) else f"{_bank_num(lo, fmt)}–{_bank_num(hi, fmt)}"


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
        row = [name, _bank_num(rs[0]["crack_element"], "d"), f"{rs[0]['truth_rms']:.3f}"]
        row += [f"{np.mean([r['rms_force'][lab] for r in rs]):.3f}" for lab in labels]
        row += [f"{sum(r['detected'] for r in rs)}/{n}", _bank_span([r["time_to_detection"] for r in rs]),
                _bank_counts([r["by_magnitude"] for r in rs], n), _bank_counts([r["by_residual"] for r in rs], n),
                _bank_span([r["margin"] for r in rs], ".2f"), _bank_counts([r["verdict"] for r in rs], n)]
        out.append("| " + " | ".join(row) + " |")
    if doc.get("gates"):
        out += ["", "## Observability gate of the extended system (section 2.6.6)", "",
                "| sensors | channels | element | p | s | verdict | static-gain singular values | condition | reason |",
                "|---|---|---|---|---|---|---|---|---|"]
        for g in doc["gates"]:
            sv = ", ".join(f"{x:.2e}" for x in g["static_gain_singular_values"])
            out.append(f"| {g['sensors']} | {'+'.join(g['channels'])} | {g['element']} | {g['n_outputs']} | "
                       f"{g['n_channels']} | {g['verdict']} | {sv} | {_bank_num(g['condition'], '.3g')} | "
                       f"{g['reason'] or '–'} |")
    return "\n".join(out) + "\n"
