"""Renderings of a sensor search (:class:`obsnl.design.sensor_search.SensorSearch`): text, Markdown, LaTeX and JSON.

The search is read by its attributes (this room sits below :mod:`obsnl.design` and does not import it).
The minimal sets come first, each with how its sufficiency was certified and how each set with one sensor
fewer was proven insufficient; then the practical ranking when a record was given; then what the
verdicts assume.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from typing import Any, Protocol

from obsnl.errors import OptionError
from obsnl.report.sentences import bounds_text, probability_text

__all__ = ["render_sensors", "undecided_line"]

FORMATS = ("text", "json", "md", "tex")


def _set(names: Any) -> str:
    return "{" + ", ".join(names) + "}"


def _tex(name: str) -> str:
    return (
        r"\texttt{"
        + name.replace("\\", r"\textbackslash{}")
        .replace("_", r"\_")
        .replace("&", r"\&")
        .replace("%", r"\%")
        .replace("#", r"\#")
        .replace("$", r"\$")
        .replace("{", r"\{")
        .replace("}", r"\}")
        + "}"
    )


def _tex_set(names: Any) -> str:
    return r"\{" + ", ".join(_tex(n) for n in names) + r"\}"


def _how(ans: Any) -> str:
    """How one set's answer was established, in a few words."""
    if ans is None:
        return "not reached"
    if ans.how == "analysis":
        return f"joint verdict, P >= {probability_text(ans.probability)}, seed {ans.seed}"
    return {"reachability": "dependency graph (exact)", "implied": "monotonicity"}.get(ans.how, ans.how)


def _head(search: Any) -> list[str]:
    lines = []
    if search.none_exists:
        lines.append(f"No set of the {len(search.candidates)} candidate sensors suffices: {search.proof}.")
    elif search.minimal_sets:
        size = (
            "of any size: every larger set without one of them lies within a set proven insufficient"
            if getattr(search, "complete", False) and search.max_size < len(search.candidates)
            else f"at most {search.max_size} sensors"
        )
        lines.append(
            f"{len(search.minimal_sets)} minimal sensor set{'s' if len(search.minimal_sets) != 1 else ''} "
            f"({size}) make {_targets(search)} jointly identifiable."
        )
    else:
        lines.append(f"No set of at most {search.max_size} sensors makes {_targets(search)} jointly identifiable.")
    if search.undecided_sets:
        lines.append("Undecided (not reported minimal): " + "; ".join(_set(s) for s in search.undecided_sets) + ".")
    lines.append(
        f"{search.analyses} joint verdicts for the {search.exhaustive} possible sets of "
        f"{len(search.candidates)} candidates ({search.seconds:.1f} s)."
    )
    return lines


def _targets(search: Any) -> str:
    return "every target" if len(search.targets) > 6 else ", ".join(search.targets)


def _assumptions(search: Any) -> list[str]:
    a = search.assumptions  # a SearchAssumptions, or None when the search states none
    if a is None:
        return ["visited branches: every feasible branch"]
    out = [f"visited branches: {a.visited}"]
    ui = a.analysis.unknown_input_derivatives
    if ui is not None:
        out.append(f"unknown inputs: {ui}")
    known = a.analysis.known_inputs
    if known:
        out.append(f"known inputs: {known}")
    if a.analysis.bounds:
        out.append(bounds_text(a.analysis.bounds))
    out.append(a.monotonicity)
    return [x for x in out if x]


def _rows(search: Any) -> list[tuple[tuple[str, ...], str, list[str]]]:
    """(set, its certificate, per removed sensor how the rest was proven insufficient)."""
    rows = []
    for s in search.minimal_sets:
        without = []
        for name in s:
            rest = tuple(x for x in s if x != name)
            without.append(f"without {name}: " + ("no sensor left" if not rest else _how(search.answer(rest))))
        rows.append((tuple(s), _how(search.answer(s)), without))
    return rows


class _Ranked(Protocol):
    """What the renderings read of one ranked set (:class:`obsnl.design.ranking.RankedSet`)."""

    @property
    def sensors(self) -> Sequence[str]: ...
    @property
    def worst_relative_std(self) -> float: ...
    @property
    def worst(self) -> str: ...
    @property
    def log_det_fim(self) -> float: ...


def _ranking_rows(search: Any) -> list[tuple[_Ranked, bool]]:
    """The ranked sets of ``search``, best first, each with whether effective independence chose it."""
    ranking = getattr(search, "ranking", None)
    if ranking is None:
        return []
    efi = set(getattr(search, "effective_independence", ()) or ())
    return [(r, bool(efi) and set(r.sensors) == efi) for r in ranking.rows]


def _num(x: Any) -> str:
    """A bound or a log-determinant in 3 digits; an infinity with its sign (a singular information matrix has
    ``log det FIM`` -inf, an uninformed parameter a relative std +inf), ``n/a`` for a missing value."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "n/a"
    if isinstance(x, float) and math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return f"{x:.3g}"


#: What a null of the JSON ranking means (JSON has no infinities): stated in ``ranking_setup``.
NULLS = (
    "worst_relative_std or relative_std null: an infinite bound (the record does not inform that parameter); "
    "log_det_fim null: an infinite log-determinant, its sign in log_det_fim_infinite "
    "('-inf': a singular Fisher information)"
)


def _json(search: Any) -> str:
    """The search as JSON: infinities stay null (valid JSON), each ranked row says which infinity its
    ``log_det_fim`` is (``log_det_fim_infinite``: ``"-inf"``, ``"inf"`` or None) and ``ranking_setup.nulls``
    what a null means."""
    doc = search.to_dict()
    ranking = getattr(search, "ranking", None)
    if ranking is not None and "ranking" in doc:
        for row, r in zip(doc["ranking"], ranking.rows):
            x = r.log_det_fim
            row["log_det_fim_infinite"] = ("inf" if x > 0 else "-inf") if math.isinf(x) else None
        doc.setdefault("ranking_setup", {})["nulls"] = NULLS
    return json.dumps(doc, indent=2)


def render_sensors(search: Any, fmt: str = "text") -> str:
    """``search`` as ``"text"``, ``"md"``, ``"tex"`` or ``"json"``.

    Parameters
    ----------
    search : SensorSearch
        The result of :func:`obsnl.design.sensors.sensors`.
    fmt : str
        One of ``text``, ``md``, ``tex``, ``json``.

    Returns
    -------
    str
    """
    if fmt == "json":
        return _json(search)
    rows, ranked = _rows(search), _ranking_rows(search)
    efi = getattr(search, "effective_independence", ())
    if fmt == "text":
        lines = [f"model {search.model}: candidate sensors {', '.join(search.candidates)}"] + _head(search)
        for s, how, without in rows:
            lines.append(f"  {_set(s)}  [{how}]")
            lines.extend(f"      {w}" for w in without)
        if ranked:
            lines.append("ranking along the record (Cramer-Rao bound, best first):")
            lines.extend(
                f"  {_set(r.sensors)}: worst relative std {_num(r.worst_relative_std)} "
                f"({r.worst}), log det FIM {_num(r.log_det_fim)}" + ("  <- effective independence" if chosen else "")
                for r, chosen in ranked
            )
        if efi:
            lines.append(f"effective independence (linear modes) chooses {_set(efi)}")
        lines.append("assumes: " + "; ".join(_assumptions(search)))
        return "\n".join(lines)
    if fmt == "md":
        lines = [
            f"# Sensor sets of {search.model}",
            "",
            *_head(search),
            "",
            "| minimal set | certificate | with one sensor removed |",
            "|---|---|---|",
        ]
        lines += [f"| {_set(s)} | {how} | {'; '.join(without)} |" for s, how, without in rows]
        if ranked:
            lines += [
                "",
                "| rank | sensors | worst relative std | worst parameter | log det FIM | effective independence |",
                "|---:|---|---:|---|---:|---|",
            ]
            lines += [
                f"| {i} | {_set(r.sensors)} | {_num(r.worst_relative_std)} | {r.worst} | "
                f"{_num(r.log_det_fim)} | {'chosen' if chosen else ''} |"
                for i, (r, chosen) in enumerate(ranked, 1)
            ]
        if efi:
            lines += ["", f"Effective independence (linear modes) chooses {_set(efi)}."]
        lines += ["", "Assumes: " + "; ".join(_assumptions(search)) + "."]
        return "\n".join(lines)
    if fmt == "tex":
        lines = [
            r"\begin{table}[htbp]",
            r"\centering",
            r"\caption{Minimal sensor sets of \texttt{"
            + search.model.replace("_", r"\_")
            + "}: "
            + f"{search.analyses} joint verdicts for {search.exhaustive} possible sets"
            + "}",
            r"\begin{tabular}{ll}",
            r"\toprule",
            r"minimal set & certificate \\",
            r"\midrule",
        ]
        geq = r"$\geq$"
        lines += [_tex_set(s) + " & " + how.replace(">=", geq) + r" \\" for s, how, _ in rows]
        if not rows:
            lines.append(r"\multicolumn{2}{l}{none} \\")
        lines += [r"\bottomrule", r"\end{tabular}", r"\end{table}"]
        if ranked:
            lines += [
                "",
                r"\begin{table}[htbp]",
                r"\centering",
                r"\caption{Sensor sets ranked by the Cram\'er-Rao bound along the record}",
                r"\begin{tabular}{rlrr}",
                r"\toprule",
                r"rank & sensors & worst rel.\ std & $\log\det F$ \\",
                r"\midrule",
            ]
            lines += [
                f"{i} & {_tex_set(r.sensors)} & {_num(r.worst_relative_std)} & {_num(r.log_det_fim)} \\\\"
                for i, (r, _) in enumerate(ranked, 1)
            ]
            lines += [r"\bottomrule", r"\end{tabular}", r"\end{table}"]
        return "\n".join(lines)
    raise OptionError(f"unknown format {fmt!r}; formats are {', '.join(FORMATS)}")


def undecided_line(search: Any) -> str | None:
    """The one line that names the sensor sets a search left undecided, or None when it decided every set.

    Parameters
    ----------
    search : SensorSearch
        The result of :func:`obsnl.design.sensors.sensors`.

    Returns
    -------
    str or None
        ``"2 sensor set(s) undecided, e.g. {a, b}: REASON; raise max_seconds="``, or None.
    """
    if not (undecided := search.undecided_sets):
        return None
    first = search.answer(undecided[0])
    return (
        f"{len(undecided)} sensor set(s) undecided, e.g. {{{', '.join(first.sensors)}}}: "
        f"{first.reason or 'minimality undecided'}; raise max_seconds="
    )
