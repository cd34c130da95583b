"""Results as HTML for a notebook: what a result's ``_repr_html_`` shows (wired by the top level through
:mod:`obsnl._display`).

:func:`to_html` dispatches on the result's type name (the report room does not import the rooms whose values it
draws): an analysis (its verdicts and branch table), an identification (its estimates, intervals and flags, fit,
adequacy and modes), a validation (the figures per output), a modal summary, a sensor search and an experiment
design. Every table holds what the result's ``to_dict`` holds, rounded for reading; every text is escaped.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from html import escape
from typing import Any

__all__ = ["to_html", "RENDERED"]

#: The result types :func:`to_html` draws, by type name.
RENDERED = ("AnalysisResult", "Identification", "Validation", "Modal", "SensorSearch", "ExperimentDesign")

_STYLE = "border-collapse:collapse;font-size:0.9em"


def _num(x: Any, fmt: str = ".4g") -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "&ndash;" if x is None or math.isnan(x) else escape(str(x))
    return format(x, fmt) if isinstance(x, (int, float)) and not isinstance(x, bool) else escape(str(x))


def _table(head: Sequence[str], rows: Iterable[Sequence[str]]) -> str:
    """An HTML table; the cells are HTML already (escape text before)."""
    th = "".join(f"<th style='text-align:left;padding:2px 8px'>{escape(h)}</th>" for h in head)
    body = "".join("<tr>" + "".join(f"<td style='padding:2px 8px'>{c}</td>" for c in row) + "</tr>" for row in rows)
    return f"<table style='{_STYLE}'><thead><tr>{th}</tr></thead><tbody>{body}</tbody></table>"


def _head(title: str, *lines: str) -> str:
    return f"<h4>{escape(title)}</h4>" + "".join(f"<p style='margin:2px 0'>{escape(x)}</p>" for x in lines if x)


def _details(summary: str, items: Iterable[str]) -> str:
    li = "".join(f"<li>{escape(x)}</li>" for x in items)
    return f"<details><summary>{escape(summary)}</summary><ul>{li}</ul></details>" if li else ""


def _analysis(r: Any) -> str:
    from obsnl.report.groups import branch_groups
    from obsnl.report.sentences import opening_lines
    from obsnl.report.tables import ROWS, analysis_header, group_cell

    groups = branch_groups(r)
    rows = [
        [escape(ROWS[row])] + [escape(group_cell(g, row, latex=False, result=r)).replace("`", "") for g in groups]
        for row in ROWS
    ]
    return _head(f"Observability of {r.model}", analysis_header(r), *opening_lines(r, suffix=".")) + _table(
        ["Branches", *(g.heading for g in groups)], rows
    )


def _modes(m: Any) -> str:
    rows = [
        [
            str(i + 1),
            _num(f),
            _num(fs, ".2g"),
            _num(100 * z),
            _num(None if zs is None else 100 * zs, ".2g"),
            escape(", ".join(f"{o} {a:+.3g}" for o, a in sh.items())),
        ]
        for i, (f, fs, z, zs, sh) in enumerate(
            zip(m.frequency_hz, m.frequency_hz_std, m.damping_ratio, m.damping_ratio_std, m.shapes)
        )
    ]
    return _table(["mode", "frequency (Hz)", "std", "damping (%)", "std", "shape at the outputs"], rows)


def _modal(m: Any) -> str:
    at = ", ".join(f"{k}={v:.4g}" for k, v in m.state.items())
    real = ", ".join(f"{p:.4g}" for p in m.real_poles)
    return (
        _head(f"Modes of {m.model}", f"linearised at {at} (inputs 0)", f"real poles (1/s): {real}" if real else "")
        + _modes(m)
        + _details("assumed", m.assumptions)
    )


def _identification(r: Any) -> str:
    ad = r.adequacy
    state = "converged" if r.converged else "NOT converged"
    lines = [
        ad.headline() if ad is not None and not ad.passed else "",
        f"{r.mode} data, {r.method}, {r.passes_run} of {r.passes} passes, {state}"
        + (f" ({r.converged_reason})" if r.converged_reason else "")
        + f", {r.seconds:.3g} s",
        r.structural.note() if r.structural is not None else "",
    ]
    rows = []
    for p in r.parameters:
        lo, hi = p.interval if p.interval is not None else (None, None)
        value = (
            [f"held at {_num(p.guess)}", "", ""]
            if p.held
            else [_num(p.estimate), _num(p.std, ".2g"), f"[{_num(lo)}, {_num(hi)}]"]
        )
        truth = [_num(p.true), _num(p.error, ".3g")] if any(q.true is not None for q in r.parameters) else []
        rows.append(
            [
                escape(p.name),
                *value,
                *truth,
                "flagged: " + escape(p.reason or "") if p.flagged else escape(p.reason or ""),
            ]
        )
    head = (
        ["parameter", "estimate", "std", "95 % interval"]
        + (["true", "error"] if any(q.true is not None for q in r.parameters) else [])
        + ["flag"]
    )
    fit = ", ".join(f"{o} {_num(v, '.3g')} %" for o, v in r.fit.items())
    modal = getattr(r, "modal_at_rest", None)
    return (
        _head(f"Identification of {r.model}", *lines)
        + _table(head, rows)
        + f"<p style='margin:2px 0'>fit (NRMSE of the model at the estimate): {fit}</p>"
        + (f"<p style='margin:2px 0'>{escape(ad.headline())}</p>" if ad is not None and ad.passed else "")
        + (_modes(modal) if modal is not None else "")
        + _details("assumed", r.assumptions)
    )


def _validation(v: Any) -> str:
    rows = [
        [escape(o), _num(s.rmse), _num(s.nrmse), _num(s.fit_percent, ".2f"), _num(s.db, ".2f")]
        for o, s in v.outputs.items()
    ]
    rec = v.record
    return (
        _head(
            f"Validation of {v.model} on {rec.name!r}",
            f"{v.scored} samples scored at dt = {rec.dt} s, simulated {v._start_text()}",
        )
        + _table(["output", "RMSE", "NRMSE", "fit %", "dB"], rows)
        + _details("assumed", v.assumptions)
    )


def _sensors(s: Any) -> str:
    rows = [[str(len(x)), escape(", ".join(x))] for x in s.minimal_sets]
    lines = s.summary().splitlines()
    return _head(f"Sensors of {s.model}", *lines) + (_table(["size", "minimal set"], rows) if rows else "")


def _design(d: Any) -> str:
    rows = [
        [
            _num(v.scale),
            escape(", ".join(b.label or str(b.pattern) for b in v.branches)),
            {True: "yes", False: "no", None: "undecided"}[v.sufficient],
            escape(", ".join(v.missing)),
        ]
        for v in d.visits
        if not v.bisection
    ]
    return _head(f"Experiment design of {d.model}", *d.summary().splitlines()) + _table(
        ["scale", "branches visited", "sufficient", "not identifiable"], rows
    )


_BY_TYPE: Mapping[str, Callable[[Any], str]] = {
    "AnalysisResult": _analysis,
    "Identification": _identification,
    "Validation": _validation,
    "Modal": _modal,
    "SensorSearch": _sensors,
    "ExperimentDesign": _design,
}


def to_html(result: Any) -> str | None:
    """The HTML a notebook shows for ``result``, or None for a type not in :data:`RENDERED` (the plain repr then).

    Parameters
    ----------
    result : Any
        A result value.

    Returns
    -------
    str or None

    Examples
    --------
    >>> to_html(3) is None
    True
    """
    draw = _BY_TYPE.get(type(result).__name__)
    return None if draw is None else f"<div>{draw(result)}</div>"
