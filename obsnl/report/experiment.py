"""Renderings of an experiment design (:func:`obsnl.design.experiment.design`): text, Markdown, LaTeX,
JSON and the figure of the visited branches against the scale.

The design room ranks above this one, so nothing here imports it: every function reads the result by its
attributes (``visits``, ``min_scale``, ``bracket``, ``status``, ``sufficient_records`` ...) and its
``to_dict``. A table row is one simulated scale (grid scales, and bisection points marked ``*``), or a scale whose
simulation blew up (no verdict). Targets that no scale makes identifiable (``structural``) come first in the
summary, then ``min_scale``, then the blow-ups and the grid scales not tried above them (``blowups``, ``skipped``).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from obsnl.errors import OptionError
from obsnl.report.figures import agg_pyplot, save_png
from obsnl.report.tex import tex_escape

__all__ = [
    "design_text",
    "design_markdown",
    "design_latex",
    "render_design",
    "plot_visits",
    "undecided_line",
    "DESIGN_FORMATS",
]

#: The formats of :func:`render_design`.
DESIGN_FORMATS = ("text", "json", "md", "tex")
_HEAD = ("scale", "visited branches (s)", "crossings", "sufficient", "not identifiable")
_VERDICT = {True: "yes", False: "no", None: "undecided"}


def _branch(b: Any) -> str:
    """``a(+-) 2.5`` (label, sign pattern, seconds), the pattern alone when the branch has no label."""
    name = (b.label or "") + (f"({b.pattern})" if b.pattern else "")
    return f"{name} {b.seconds:.4g}"


def _when(b: Any) -> str:
    """``at t = 7.12`` of a blow-up (its time), or why it has none."""
    return f"at t = {b.time:.4g}" if b.time is not None else "(the scaled record overflows)"


def _rows(design: Any) -> list[tuple[str, ...]]:
    """One row of strings per simulated scale, and one per scale that blew up (no verdict), by scale."""
    rows = []
    for v in design.visits:
        lost = ", ".join(v.missing) + (f" (undecided: {', '.join(v.undecided)})" if v.undecided else "")
        rows.append(
            (
                v.scale,
                (
                    f"{v.scale:.6g}" + ("*" if v.bisection else ""),
                    "; ".join(_branch(b) for b in v.branches),
                    str(sum(v.crossings.values())),
                    _VERDICT[v.sufficient],
                    lost or "-",
                ),
            )
        )
    for b in getattr(design, "blowups", ()):
        rows.append((b.scale, (f"{b.scale:.6g}", f"blew up {_when(b)} (record {b.record})", "-", "no verdict", "-")))
    return [r for _, r in sorted(rows, key=lambda r: r[0])]


def _blowups(design: Any) -> list[tuple[str, str]]:
    """``("blew up", text)`` per scale whose simulation blew up, the grid scales not tried said with the first."""
    lines = []
    skipped = getattr(design, "skipped", ())
    for i, b in enumerate(getattr(design, "blowups", ())):
        text = (
            f"scale {b.scale:g}: the simulation of record {b.record} blew up {_when(b)} (a non-finite state: the "
            f"fixed-step simulation diverged or left the model's domain); no verdict at that scale"
        )
        if i == 0 and skipped:
            text += (
                f"; larger scales not tried ({', '.join(f'{x:g}' for x in skipped)}): a larger excitation of the "
                f"same record is no better behaved with the fixed step"
            )
        lines.append(("blew up", text))
    return lines


def _sets(sets: Sequence[Sequence[str]]) -> str:
    return "; ".join("{" + ", ".join(s) + "}" for s in sets)


def _summary(design: Any) -> list[tuple[str, str]]:
    """``(heading, text)`` lines: the targets no scale makes identifiable, the smallest scale, the blow-ups, the
    records, the cost, the notes."""
    lo, hi = design.bracket
    first = []
    if getattr(design, "structural", ()):
        first.append(
            ("structural", f"{design.structural_reason}; min_scale is searched for {', '.join(design.searched)} only")
        )
    if design.status == "found":
        scale = (
            f"{design.min_scale:.6g} (bracket [{lo:.6g}, {hi:.6g}]: the upper end suffices, the lower does "
            f"not; relative width at most {design.tol:g})"
        )
    elif design.status == "smallest_suffices":
        scale = f"not estimated: {design.reason}"
    elif design.status == "none_suffices":
        scale = f"none of the scales tried: {design.reason}"
    else:
        scale = f"undecided: {design.reason}"
    left_out = getattr(design, "unjudged_records", ())
    records = _sets(design.sufficient_records) or (
        "none among the records that ran at scale 1"
        if left_out
        else "none: the records together do not suffice at scale 1"
    )
    if design.undecided_records:
        records += f"; undecided: {_sets(design.undecided_records)}"
    if left_out:
        records += f"; not judged: {', '.join(left_out)} (the simulation blew up at scale 1 or below)"
    lines = [
        *first,
        ("min_scale", scale),
        *_blowups(design),
        ("sufficient records (scale 1)", records),
        (
            "analyses",
            f"{design.analyses} joint verdicts for {len(design.visits)} scales (one per visited set)"
            + (
                ", and one over every branch (the targets no scale makes identifiable)"
                if hasattr(design, "structural")
                else ""
            ),
        ),
    ]
    how = getattr(design, "assumptions", None)  # a DesignAssumptions, or None when the design states none
    if how is not None:  # what the simulation assumed: the input between samples, the initial state
        kinds = ", ".join(f"{k} {v}" for k, v in how.between_samples.items()) or "no input"
        start = ", ".join(f"{k} = {v}" for k, v in how.initial_state.items())
        lines.append(("simulated", f"along the continuous trajectory; input between samples: {kinds}; from {start}"))
    return lines + [("note", n) for n in design.notes]


def _title(design: Any) -> str:
    return (
        f"{design.model}: experiment design (targets {', '.join(design.targets)}; sensors "
        f"{', '.join(design.sensors)}; records {', '.join(design.records)})"
    )


def design_text(design: Any) -> str:
    """Plain text: the title, the summary and a table of the scales."""
    rows = [_HEAD, *_rows(design)]
    widths = [max(len(r[j]) for r in rows) for j in range(len(_HEAD))]
    lines = [_title(design), f"switching functions (sign order): {', '.join(design.switching) or 'none'}"]
    lines += [f"{head}: {text}" for head, text in _summary(design)]
    lines.append("")
    lines += ["  " + "  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows]
    if any(v.bisection for v in design.visits):
        lines.append("  * a point of the bisection")
    return "\n".join(lines)


def design_markdown(design: Any) -> str:
    """Markdown: a heading, the summary as a list and the table of the scales."""

    def cell(text: str) -> str:
        return text.replace("|", "\\|").replace("*", "\\*")

    lines = [
        f"## {cell(_title(design))}",
        "",
        f"- switching functions (sign order): {cell(', '.join(design.switching) or 'none')}",
    ]
    lines += [f"- {head}: {cell(text)}" for head, text in _summary(design)]
    lines += ["", "| " + " | ".join(_HEAD) + " |", "|" + "---|" * len(_HEAD)]
    lines += ["| " + " | ".join(cell(c) for c in r) + " |" for r in _rows(design)]
    if any(v.bisection for v in design.visits):
        lines += ["", "\\* a point of the bisection"]
    return "\n".join(lines)


def design_latex(design: Any) -> str:
    """A booktabs LaTeX table of the scales, the summary in the caption (needs ``\\usepackage{booktabs}``)."""
    summary = " ".join(f"{tex_escape(head)}: {tex_escape(text)}." for head, text in _summary(design))
    lines = [
        "% generated by obsnl; needs \\usepackage{booktabs}",
        "\\begin{table}[htbp]",
        "\\centering",
        f"\\caption{{{tex_escape(_title(design))}. {summary}"
        + (" $^*$ a point of the bisection." if any(v.bisection for v in design.visits) else "")
        + "}",
        "\\begin{tabular}{@{}rp{0.4\\linewidth}rll@{}}",
        "\\toprule",
        " & ".join(tex_escape(h) for h in _HEAD) + " \\\\",
        "\\midrule",
    ]
    for r in _rows(design):
        scale = tex_escape(r[0].rstrip("*")) + ("$^*$" if r[0].endswith("*") else "")
        lines.append(" & ".join([scale, *(tex_escape(c) for c in r[1:])]) + " \\\\")
    return "\n".join(lines + ["\\bottomrule", "\\end{tabular}", "\\end{table}"])


def render_design(design: Any, fmt: str) -> str:
    """The design in one of :data:`DESIGN_FORMATS`; an :class:`~obsnl.errors.OptionError` for another.

    Parameters
    ----------
    design : ExperimentDesign
        An :class:`~obsnl.design.experiment.ExperimentDesign`.
    fmt : {"text", "json", "md", "tex"}
        The format (``"json"``: its ``to_dict``).
    """
    if fmt == "json":
        return json.dumps(design.to_dict(), indent=2)
    out = {"text": design_text, "md": design_markdown, "tex": design_latex}.get(fmt)
    if out is None:
        raise OptionError(f"unknown format {fmt!r}; formats are {', '.join(DESIGN_FORMATS)}")
    return out(design)


def undecided_line(design: Any) -> str | None:
    """The one line that says a design is inconclusive, and why; None when it is decided.

    Examples
    --------
    >>> from types import SimpleNamespace as Design
    >>> undecided_line(Design(status="inconclusive", reason="the time limit ran out at scale 10"))
    'inconclusive: the time limit ran out at scale 10'
    >>> undecided_line(Design(status="found", reason="scale 2 suffices, 1 does not")) is None
    True
    """
    return f"inconclusive: {design.reason}" if design.status == "inconclusive" else None


def plot_visits(design: Any, path: str | Path) -> Path:
    """The visited branches against the scale (log axis), coloured by whether the visited set suffices, with
    ``min_scale`` (or the bracket's known end) marked.

    Parameters
    ----------
    design : Any
        An :class:`~obsnl.design.experiment.ExperimentDesign`.
    path : str or Path
        The PNG file (the caller has decided that it may be written).

    Returns
    -------
    Path
    """
    plt = agg_pyplot()
    names: dict[tuple[int, ...], str] = {}
    for v in design.visits:
        for b in v.branches:
            names.setdefault(b.signs, _branch(b).rsplit(" ", 1)[0])
    rows = {signs: i for i, signs in enumerate(names)}
    fig, ax = plt.subplots(figsize=(7.5, 1.6 + 0.4 * len(rows)))
    for verdict, style in (
        (True, dict(color="C2", marker="o")),
        (False, dict(color="C3", marker="x")),
        (None, dict(color="0.5", marker="s")),
    ):
        pts = [(v.scale, rows[b.signs]) for v in design.visits if v.sufficient is verdict for b in v.branches]
        if pts:
            ax.scatter(*zip(*pts), s=22, label=f"sufficient: {_VERDICT[verdict]}", **style)
    lo, hi = design.bracket
    if design.min_scale is not None:
        ax.axvline(design.min_scale, color="k", lw=1, label=f"min_scale {design.min_scale:.4g}")
    elif design.status == "smallest_suffices":
        ax.axvline(hi, color="k", lw=1, ls="--", label=f"min_scale at most {hi:.4g} (structural)")
    for i, b in enumerate(getattr(design, "blowups", ())):
        ax.axvline(b.scale, color="C3", lw=1, ls=":", label="blew up (no verdict)" if i == 0 else None)
    ax.set_xscale("log")
    ax.set_yticks(range(len(rows)), list(names.values()))
    ax.set_ylim(-0.7, len(rows) - 0.3)
    ax.set_xlabel("scale of the records")
    ax.set_title(f"{design.model}: branches visited per scale", fontsize=10)
    ax.legend(fontsize=7, loc="best")
    return save_png(plt, fig, path)
