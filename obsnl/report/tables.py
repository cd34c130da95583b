"""All formatting of analysis results: LaTeX (booktabs), Markdown, JSON branch tables, text.

A branch table has one column per *group* of branches with identical results (merged as the
seed paper merges (A),(C) and (B),(D) in its Table 1) and the rows Condition / Observable /
Unidentifiable / Transcendence degree. The condition of a group is simplified to a single sign
condition on a product of switching functions when one describes the group exactly (for the
seed model ``(r - eta') x2 > 0``), else it is the disjunction of the branch guards.
"""

from __future__ import annotations

import itertools
import json
import re
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import sympy as sp

from obsnl.observability.branch_table import SCHEMA_ID, BranchEntry, BranchTable
from obsnl.errors import ObsnlError
from obsnl.model.core import Model
from obsnl.observability.results import AnalysisResult, BranchResult, Verdict

__all__ = [
    "ROWS",
    "BranchGroup",
    "complete",
    "branch_groups",
    "branch_table",
    "to_markdown",
    "to_latex",
    "to_json",
    "to_text",
    "to_analysis_json",
    "render",
    "FORMATS",
    "timing_table",
    "write_report",
    "bank_table_markdown",
]

#: Row keys of a branch table and their headings.
ROWS: dict[str, str] = {
    "condition": "Condition",
    "observable": "Observable",
    "unobservable": "Unidentifiable",
    "degree": "Transcendence degree",
}
DEFAULT_ROWS: tuple[str, ...] = ("condition", "observable", "unobservable", "degree")


# --------------------------------------------------------------------------- completing a result
def complete(result: AnalysisResult, model: Model) -> AnalysisResult:
    """Fill what rendering needs (variable order, switching functions, branch signs, LaTeX names)
    from ``model`` when the result does not carry it."""
    from obsnl.model.branches import expr_text, split_branches

    changes: dict = {}
    if not result.variables:
        changes["variables"] = tuple(s.name for s in model.variables)
    if not result.parameters:
        changes["parameters"] = tuple(s.name for s in model.parameters)
    if not result.latex and model.latex:
        changes["latex"] = dict(model.latex)
    needs_signs = any(not b.signs for b in result.branches) and not (
        len(result.branches) == 1 and result.branches[0].guard == "true"
    )
    if needs_signs or not result.switching:
        branches = {b.label: b for b in split_branches(model)}
        if branches and next(iter(branches.values())).switching:
            first = next(iter(branches.values()))
            changes["switching"] = tuple(expr_text(g) for g in first.switching)
            new_b = []
            for b in result.branches:
                if not b.signs and b.label in branches:
                    b = replace(b, signs=branches[b.label].signs)
                new_b.append(b)
            changes["branches"] = tuple(new_b)
    return replace(result, **changes) if changes else result


# --------------------------------------------------------------------------- grouping
@dataclass(frozen=True)
class BranchGroup:
    """Branches with identical results, rendered as one column."""

    labels: tuple[str, ...]
    branches: tuple[BranchResult, ...]
    condition: str  # plain text, sympy syntax
    condition_expr: sp.Basic | None
    factors: tuple[sp.Expr, ...] = ()  # when the condition is "product of factors <sign> 0"
    sign: int = 0

    @property
    def observable(self) -> tuple[str, ...]:
        return self.branches[0].observable

    @property
    def unobservable(self) -> tuple[str, ...]:
        return self.branches[0].unobservable

    @property
    def degree(self) -> int:
        return self.branches[0].transcendence_degree

    @property
    def heading(self) -> str:
        return ", ".join(f"({lab})" for lab in self.labels)


def _key(b: BranchResult) -> tuple:
    return (b.verdict, frozenset(b.observable), frozenset(b.unobservable), frozenset(b.undecided),
            b.transcendence_degree)


def _symbols_in(texts: Iterable[str]) -> dict[str, sp.Symbol]:
    names = set()
    for t in texts:
        names.update(re.findall(r"[A-Za-z_][A-Za-z0-9_]*", t))
    return {n: sp.Symbol(n, real=True) for n in names}


def branch_groups(result: AnalysisResult) -> tuple[BranchGroup, ...]:
    """Group branches with identical verdicts and lists, in order of first appearance."""
    groups: dict[tuple, list[BranchResult]] = {}
    for b in result.branches:
        groups.setdefault(_key(b), []).append(b)
    sw_exprs: list[sp.Expr] = []
    if result.switching:
        loc = _symbols_in(result.switching)
        sw_exprs = [sp.sympify(t, locals=loc) for t in result.switching]
    all_patterns = [b.signs for b in result.branches]
    out = []
    for members in groups.values():
        text, expr, factors, sign = _group_condition(members, sw_exprs, all_patterns)
        out.append(BranchGroup(tuple(b.label for b in members), tuple(members), text, expr, factors, sign))
    return tuple(out)


def _group_condition(members: Sequence[BranchResult], sw: Sequence[sp.Expr],
                     all_patterns: Sequence[tuple[int, ...]]) -> tuple[str, sp.Basic | None, tuple, int]:
    from obsnl.model.branches import expr_text

    if len(members) == len(all_patterns):
        return "true", sp.true, (), 0
    if not sw or any(len(b.signs) != len(sw) for b in members):
        texts = [b.guard for b in members]
        return (" | ".join(f"({t})" for t in texts) if len(texts) > 1 else texts[0]), None, (), 0
    mine = {b.signs for b in members}
    # the smallest product of switching functions whose sign singles out exactly this group
    for size in range(1, len(sw) + 1):
        for subset in itertools.combinations(range(len(sw)), size):
            for s in (1, -1):
                chosen = {p for p in all_patterns if _prod(p, subset) == s}
                if chosen == mine:
                    prod = sp.Mul(*[sw[i] for i in subset])
                    rel = sp.StrictGreaterThan(prod, 0) if s > 0 else sp.StrictLessThan(prod, 0)
                    factors = [expr_text(sw[i]) for i in subset]
                    if len(factors) > 1:
                        factors = [f"({f})" if isinstance(sw[i], sp.Add) else f for f, i in zip(factors, subset)]
                    return (f"{'*'.join(factors)} {'>' if s > 0 else '<'} 0", rel,
                            tuple(sw[i] for i in subset), s)
    rels = [sp.And(*[sp.StrictGreaterThan(g, 0) if si > 0 else sp.StrictLessThan(g, 0) for g, si in zip(sw, b.signs)])
            for b in members]
    return " | ".join(f"({b.guard})" for b in members), sp.Or(*rels), (), 0


def _prod(pattern: tuple[int, ...], subset: Sequence[int]) -> int:
    out = 1
    for i in subset:
        out *= pattern[i]
    return out


# --------------------------------------------------------------------------- branch table (JSON)
def branch_table(result: AnalysisResult, model: Model) -> BranchTable:
    """The estimators' branch table (schema ``obsnl.branch-table/1``) of an analysis of ``model``."""
    from obsnl.model.branches import expr_text, split_branches

    result = complete(result, model)
    params = [s.name for s in model.parameters]
    splits = {b.label: b for b in split_branches(model)}
    entries = []
    for b in result.branches:
        sb = splits.get(b.label)
        if sb is None:
            raise ObsnlError(f"the analysis has a branch {b.label!r} that model {model.name!r} does not have; "
                             f"analyse the same model")
        entries.append(BranchEntry(
            label=b.label, guard=b.guard, signs=tuple(sb.signs),
            observable=tuple(b.observable), unobservable=tuple(b.unobservable), absent=tuple(b.absent),
            identifiable_parameters=tuple(p for p in params if p not in b.unobservable),
            unidentifiable_parameters=tuple(p for p in params if p in b.unobservable),
            transcendence_degree=b.transcendence_degree, verdict=b.verdict.value,
        ))
    switching = next(iter(splits.values())).switching if splits else ()
    table = BranchTable(
        model=model.name, fingerprint=model.fingerprint,
        states=tuple(s.name for s in model.states), parameters=tuple(params),
        inputs=tuple(s.name for s in model.inputs), outputs=tuple(model.output_names),
        switching=tuple(expr_text(g) for g in switching), method=result.method, seed=result.seed,
        probability=result.probability, branches=tuple(entries),
        overall_observable=result.overall_observable, overall_unobservable=result.overall_unobservable,
    )
    return BranchTable.from_dict(table.to_dict())  # validated like any table read from disk


def to_json(result: AnalysisResult, model: Model) -> str:
    """The branch table as JSON text (the estimators' contract)."""
    return branch_table(result, model).to_json()


# --------------------------------------------------------------------------- markdown / text
def _names(names: Sequence[str]) -> str:
    return ", ".join(names) if names else "none"


def _cells(group: BranchGroup, row: str, *, latex: bool, result: AnalysisResult) -> str:
    if row == "condition":
        if latex:
            if group.condition_expr is None:
                return _tex_escape(group.condition)
            if group.condition_expr is sp.true:
                return "always"
            if group.factors:
                prod = " ".join(_latex_factor(f, result, wrap=len(group.factors) > 1) for f in group.factors)
                return f"${prod} {'>' if group.sign > 0 else '<'} 0$"
            return "$" + _latex_expr(group.condition_expr, result) + "$"
        return f"`{group.condition}`"
    if row == "degree":
        return str(group.degree)
    names = group.observable if row == "observable" else group.unobservable
    if row == "unobservable" and group.branches[0].undecided:
        names = tuple(names) + tuple(f"{n}?" for n in group.branches[0].undecided)
    if not latex:
        return _names(names)
    # one math group per name, so that a long list wraps inside its p{} column
    return ", ".join(f"${_latex_name(n, result)}$" for n in names) if names else "none"


def probability_text(p: float | None) -> str:
    """A probability bound as text that does not round a near-certainty up to 1."""
    if p is None:
        return "deterministic"
    if p >= 1.0:
        return "1 (certified)"
    if p > 0.999:
        return f"1 - {1.0 - p:.1e}"
    return f"{p:.4g}"


def _header_line(result: AnalysisResult) -> str:
    bits = [f"method {result.method}"]
    if result.seed is not None:
        bits.append(f"seed {result.seed}")
    if result.probability is not None:
        bits.append(f"every verdict right with probability >= {probability_text(result.probability)}")
    return ", ".join(bits)


def to_markdown(result: AnalysisResult, *, rows: Sequence[str] = DEFAULT_ROWS, title: str | None = None) -> str:
    """A Markdown branch table: one column per group of branches with identical results."""
    _check_rows(rows)
    groups = branch_groups(result)
    lines = [f"### {title or 'Observability of ' + result.model}", "", f"_{_header_line(result)}_", ""]
    lines.append("| Branches | " + " | ".join(g.heading for g in groups) + " |")
    lines.append("|---|" + "---|" * len(groups))
    for row in rows:
        lines.append(f"| {ROWS[row]} | " + " | ".join(_cells(g, row, latex=False, result=result) for g in groups)
                     + " |")
    lines.append("")
    lines.append(f"Union over branches (observable in at least one branch): "
                 f"{_union_text(result)}.")
    inconclusive = [b for b in result.branches if b.verdict is Verdict.INCONCLUSIVE]
    for b in inconclusive:
        lines.append(f"Branch ({b.label}) is inconclusive: {b.reason}")
    return "\n".join(lines) + "\n"


def _union_text(result: AnalysisResult) -> str:
    unobs = result.overall_unobservable
    if not unobs and result.verdict is Verdict.OBSERVABLE:
        return "every state and parameter is observable"
    return f"unobservable in every branch: {_names(unobs)}"


def to_text(result: AnalysisResult) -> str:
    """A plain-text summary for terminals (``obsnl analyze --format text``)."""
    prob = (f"P(all verdicts right) >= {probability_text(result.probability)}" if result.probability is not None
            else "deterministic")
    lines = [f"{result.model}: method {result.method}, seed {result.seed}, {prob}, {result.seconds:.3f} s"]
    for b in result.branches:
        lines.append(f"  ({b.label}) {b.guard}  [{b.method or result.method}, rank {b.rank}/{b.size}, "
                     f"transcendence degree {b.transcendence_degree}, {b.seconds:.3f} s]")
        if b.verdict is Verdict.INCONCLUSIVE:
            lines.append(f"      INCONCLUSIVE: {b.reason}")
            if b.undecided:
                lines.append(f"      undecided:    {_names(b.undecided)}")
        lines.append(f"      observable:   {_names(b.observable)}")
        lines.append(f"      unobservable: {_names(b.unobservable)}")
        if b.absent:
            lines.append(f"      absent:       {_names(b.absent)}")
        for k, v in b.unknown_inputs.items():
            lines.append(f"      unknown inputs {k}: {_names(v)}")
        for note in b.notes:
            lines.append(f"      note: {note}")
    lines.append(f"  overall observable:   {_names(result.overall_observable)}")
    lines.append(f"  overall unobservable: {_names(result.overall_unobservable)}")
    return "\n".join(lines) + "\n"


def to_analysis_json(result: AnalysisResult) -> str:
    """The analysis as JSON with exactly the keys of ``obsnl analyze --format json``."""
    return json.dumps(result.to_dict(), indent=2) + "\n"


#: Formats of :func:`render` (``obsnl analyze --format``).
FORMATS: tuple[str, ...] = ("text", "json", "md", "tex", "json-table")


def render(result: AnalysisResult, model: Model, fmt: str) -> str:
    """Render an analysis of ``model`` in one of :data:`FORMATS`.

    ``json`` is the analysis itself (keys ``model, method, seed, probability, seconds, branches,
    overall``); ``json-table`` is the estimators' branch table (schema ``obsnl.branch-table/1``);
    ``md`` and ``tex`` are the branch tables for documents.
    """
    if fmt == "text":
        return to_text(result)
    if fmt == "json":
        return to_analysis_json(result)
    result = complete(result, model)
    if fmt == "md":
        return to_markdown(result)
    if fmt == "tex":
        return to_latex(result)
    if fmt == "json-table":
        return to_json(result, model)
    raise ObsnlError(f"unknown format {fmt!r}; formats are {', '.join(FORMATS)}")


# --------------------------------------------------------------------------- latex
_TEX_SPECIAL = {"_": r"\_", "%": r"\%", "&": r"\&", "#": r"\#", "$": r"\$", "{": r"\{", "}": r"\}",
                "~": r"\textasciitilde{}", "^": r"\textasciicircum{}", "\\": r"\textbackslash{}"}


def _tex_escape(text: str) -> str:
    return "".join(_TEX_SPECIAL.get(c, c) for c in text)


def _latex_name(name: str, result: AnalysisResult) -> str:
    if name in result.latex:
        return result.latex[name]
    return sp.latex(sp.Symbol(name))


def _latex_factor(f: sp.Expr, result: AnalysisResult, *, wrap: bool) -> str:
    """LaTeX of a switching function with positive terms first (``r - \\eta'``, not ``-\\eta' + r``)."""
    if not isinstance(f, sp.Add):
        return _latex_expr(f, result)
    terms = sorted(f.args, key=lambda t: (t.could_extract_minus_sign(), sp.default_sort_key(t)))
    out = ""
    for i, t in enumerate(terms):
        neg = t.could_extract_minus_sign()
        body = _latex_expr(-t if neg else t, result)
        out += (" - " if neg else " + ") + body if i else ("-" if neg else "") + body
    return f"\\left({out}\\right)" if wrap else out


def _latex_expr(expr: sp.Basic, result: AnalysisResult) -> str:
    names = {s: _latex_name(s.name, result) for s in expr.free_symbols}
    return sp.latex(expr, symbol_names=names)


def to_latex(result: AnalysisResult, *, rows: Sequence[str] = DEFAULT_ROWS, caption: str | None = None,
             label: str | None = None, environment: bool = True) -> str:
    """A booktabs LaTeX table, ready to ``\\input`` (needs ``\\usepackage{booktabs}``).

    Parameters
    ----------
    rows
        Row keys among :data:`ROWS`, in order.
    caption, label
        Caption and label of the ``table`` environment (defaults name the model).
    environment
        False gives the bare ``tabular`` (e.g. for notebooks or your own float).
    """
    _check_rows(rows)
    groups = branch_groups(result)
    width = f"{0.60 / max(1, len(groups)):.2f}\\linewidth"
    body = [
        "\\begin{tabular}{@{}l" + "".join("p{" + width + "}" for _ in groups) + "@{}}",
        "\\toprule",
        "Branches & " + " & ".join(g.heading for g in groups) + " \\\\",
        "\\midrule",
    ]
    for row in rows:
        body.append(f"{ROWS[row]} & " + " & ".join(_cells(g, row, latex=True, result=result) for g in groups)
                    + " \\\\")
    body += ["\\bottomrule", "\\end{tabular}"]
    if not environment:
        return "\n".join(body) + "\n"
    header = _tex_escape(_header_line(result)).replace(">=", "$\\geq$")
    cap = caption or (f"Observability of the model {_tex_escape(result.model)} by branch "
                      f"({header}). {_tex_escape(_union_text(result)).capitalize()}.")
    lab = label or f"tab:obsnl-{re.sub(r'[^A-Za-z0-9-]+', '-', result.model)}"
    head = ["% generated by obsnl; needs \\usepackage{booktabs}", "\\begin{table}[htbp]", "\\centering",
            f"\\caption{{{cap}}}", f"\\label{{{lab}}}"]
    return "\n".join(head + body + ["\\end{table}"]) + "\n"


def _check_rows(rows: Sequence[str]) -> None:
    bad = [r for r in rows if r not in ROWS]
    if bad:
        raise ObsnlError(f"unknown table row {bad[0]!r}; rows are {', '.join(ROWS)}")


# --------------------------------------------------------------------------- timing / index / report
def timing_table(entries: Sequence[tuple[str, str, int, float]]) -> str:
    """Markdown timing table from ``(model, method, number of branches, seconds)`` rows."""
    lines = ["| Model | Method | Branches | Seconds |", "|---|---|---:|---:|"]
    lines += [f"| {m} | {meth} | {n} | {s:.3f} |" for m, meth, n, s in entries]
    return "\n".join(lines) + "\n"


def _index(results: Sequence[AnalysisResult]) -> str:
    lines = ["# obsnl observability reports", "", "| Model | Branches | Union over branches | Files |",
             "|---|---:|---|---|"]
    for r in results:
        files = ", ".join(f"[{ext}]({r.model}.{ext})" for ext in ("md", "tex", "json"))
        lines.append(f"| {r.model} | {len(r.branches)} | {_union_text(r)} | {files} |")
    lines += ["", "Timings are in [timings.md](timings.md). The `.json` files are branch tables "
              f"(schema `{SCHEMA_ID}`), read by the DUKF."]
    return "\n".join(lines) + "\n"


def write_report(models: Sequence[Model], out: str | Path, *, method: str = "auto", seed: int = 0,
                 force: bool = False, max_seconds: float | None = None) -> tuple[AnalysisResult, ...]:
    """Analyse ``models`` and write one table per model (``.md``, ``.tex``, ``.json``), ``index.md``
    and ``timings.md`` into ``out``.

    Raises
    ------
    ObsnlError
        When a file to write exists and ``force`` is False (nothing is written then).
    """
    from obsnl.observability.analyze import analyze

    out = Path(out)
    names = [m.name for m in models]
    if len(set(names)) != len(names):
        raise ObsnlError(f"two models share a name ({names}); file names come from model names")
    targets = [out / f"{m.name}.{ext}" for m in models for ext in ("md", "tex", "json")]
    targets += [out / "index.md", out / "timings.md"]
    existing = [str(t) for t in targets if t.exists()]
    if existing and not force:
        raise ObsnlError(f"{existing[0]} exists; pass --force to overwrite the report")
    results = []
    for m in models:
        r = complete(analyze(m, method=method, seed=seed, max_seconds=max_seconds), m)
        results.append(r)
    out.mkdir(parents=True, exist_ok=True)
    for m, r in zip(models, results):
        (out / f"{m.name}.md").write_text(to_markdown(r), encoding="utf-8")
        (out / f"{m.name}.tex").write_text(to_latex(r), encoding="utf-8")
        (out / f"{m.name}.json").write_text(to_json(r, m), encoding="utf-8")
    (out / "index.md").write_text(_index(results), encoding="utf-8")
    (out / "timings.md").write_text(
        timing_table([(r.model, r.method, len(r.branches), r.seconds) for r in results]), encoding="utf-8")
    return tuple(results)


# ---- observer bank (seed 001_d0508a78c5399696.txt; numbers from obsnl.linear.bank.run_link_study)
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


# ---- identification (Table 2 analog)
# Text of the Table 2 analog (seed paper 000_d24855f97fc8bdd4.txt) from the plain ``table2.json``
# document written by ``obsnl reproduce`` (``obsnl.studies.seed_paper``), so that a committed table2.json
# can be re-rendered without running anything. Writing files and figures stays in obsnl.studies.seed_paper.
__all__ += ["table2_summary", "table2_markdown", "table2_latex"]

_T2_TEX = {"k_m": r"$k_m$", "c_dm": r"$c_{dm}$", "c_eta_p": r"$c'_\eta$", "w_h": r"$w_h$", "c_p": r"$c'$",
           "h_p": r"$h'$", "Delta1": r"$\Delta_1$", "Delta2": r"$\Delta_2$", "N": r"$N$"}
_T2_MD = {"k_m": "k_m", "c_dm": "c_dm", "c_eta_p": "c'_eta", "w_h": "w_h", "c_p": "c'", "h_p": "h'",
          "Delta1": "Δ1", "Delta2": "Δ2", "N": "N"}
_T2_METHODS = {"ukf": "UKF", "dukf": "DUKF", "dukf-zero": "DUKF, P_AU = 0"}


def table2_summary(doc: Mapping[str, Any]) -> dict[tuple[str, int], dict[str, Any]]:
    """Per (method, passes): mean estimate, mean and worst |error| per parameter, flags, cost, interventions."""
    groups: dict[tuple[str, int], list[Mapping[str, Any]]] = {}
    for r in doc["runs"]:
        groups.setdefault((r["method"], r["passes"]), []).append(r)
    out = {}
    for key, every in groups.items():
        runs = [r for r in every if not r.get("error")] or every[:1]
        failed = [r for r in every if r.get("error")]
        params = list(runs[0]["parameters"])
        est = np.array([[r["parameters"][p]["estimate"] for p in params] for r in runs], float)
        err = np.abs(np.array([[r["parameters"][p]["error_percent"] for p in params] for r in runs], float))
        kinds: Counter[str] = Counter()
        for r in every:
            kinds.update(r.get("interventions") or {})
        out[key] = {
            "parameters": params, "seeds": [r["seed"] for r in runs], "mean_estimate": est.mean(axis=0),
            "mean_abs_error": err.mean(axis=0), "worst_abs_error": err.max(axis=0),
            "worst_seed": [runs[i]["seed"] for i in err.argmax(axis=0)],
            "flag_counts": {p: sum(p in (r["practically_unidentifiable"] or ()) for r in runs) for p in params},
            "flag_counts_linearised": {p: sum(p in _linearised_flags(r) for r in runs) for p in params},
            "spread": _mean_spread(runs, params),
            "yield": _yield_errors(runs, doc["experiment"]["truth"]),
            "undecided": [(r["seed"], (r.get("practical_identifiability") or {}).get("inconclusive") or r.get("error")
                           or "no estimate") for r in runs if r["practically_unidentifiable"] is None],
            "seconds": float(np.mean(np.array([r["seconds"] for r in runs], float))),
            "seconds_per_pass": float(np.mean(np.array([r["seconds"] for r in runs], float) / key[1])),
            "repairs": int(sum(r["repairs"] for r in every)), "interventions": dict(kinds),
            "implicit": int(sum(r["implicit_sigma_point_steps"] for r in every)),
            "misfits": [r["output_misfit"] for r in runs],
            "tuning": max((r["tuning"] for r in every), key=[r["tuning"] for r in every].count),
            "redone": [(r["seed"], r["redone"], r["tuning"]) for r in every if r.get("redone")],
            "failed": [(r["seed"], r["error"]) for r in failed],
        }
    return out


def _yield_displacement(delta: float, n: float) -> float:
    """``|Delta|**(-1/(2N))``: with ``Delta = (beta +- gamma) / r_y**(2N)`` (DESIGN.md) the yield
    displacement up to the factor ``|beta +- gamma|**(-1/(2N))``."""
    return abs(delta) ** (-1 / (2 * n))


def _yield_errors(runs: Sequence[Mapping[str, Any]],
                  truth: Mapping[str, float]) -> dict[str, tuple[float, np.ndarray]] | None:
    """Per Delta: the true yield displacement and the |error| in % of each run's (the direction the
    seed model's data inform along the Delta-N ridge); None for a model without Delta1, Delta2, N."""
    if not {"Delta1", "Delta2", "N"} <= set(truth):
        return None
    out = {}
    for d in ("Delta1", "Delta2"):
        true = _yield_displacement(truth[d], truth["N"])
        est = np.array([_yield_displacement(r["parameters"][d]["estimate"], r["parameters"]["N"]["estimate"])
                        if r["parameters"][d]["estimate"] is not None and r["parameters"]["N"]["estimate"] else np.nan
                        for r in runs], float)
        out[d] = (true, np.abs(100 * (est - true) / true))
    return out


def _linearised_flags(run: Mapping[str, Any]) -> Sequence[str]:
    """The flags of a run by the linearised criteria alone (Cramér-Rao bound, posterior)."""
    prac = run.get("practical_identifiability") or {}
    return prac.get("flagged_linearised", run.get("practically_unidentifiable")) or ()


def _mean_spread(runs: Sequence[Mapping[str, Any]], params: Sequence[str]) -> list[float] | None:
    """Mean Monte-Carlo relative std per parameter over the runs that have one (None: no run has)."""
    mcs = [(r.get("practical_identifiability") or {}).get("monte_carlo") or {} for r in runs]
    rows = [[np.nan if v is None or p in mc.get("held", ()) else v for p, v in zip(params, mc["relative_std"])]
            for mc in mcs if mc.get("relative_std")]  # held at the guess: no spread to show
    if not rows:
        return None
    a = np.array(rows, float)
    return [float(np.nanmean(c)) if np.isfinite(c).any() else float("nan") for c in a.T]


def _t2_flagged(s: Mapping[str, Any], p: str, key: str = "flag_counts") -> bool:
    return s[key][p] * 2 >= len(s["seeds"])


def _t2_misfit(s: Mapping[str, Any]) -> str:
    """Mean output misfit of the runs whose estimate could be simulated; the others are named."""
    ok = [v for v in s["misfits"] if v is not None and np.isfinite(v)]
    bad = [seed for seed, v in zip(s["seeds"], s["misfits"]) if v is None or not np.isfinite(v)]
    text = f"{np.mean(ok):.5f}" if ok else "-"
    if bad:
        text += f" (seed {', '.join(map(str, bad))}: the estimate cannot be simulated)"
    return text


def _t2_goal(s: Mapping[str, Any], key: str = "flag_counts") -> str:
    if s["failed"]:
        return f"not met ({len(s['failed'])} run(s) stopped: seed {', '.join(str(k) for k, _ in s['failed'])})"
    worst = [(p, w) for p, w in zip(s["parameters"], s["worst_abs_error"]) if not _t2_flagged(s, p, key)]
    bad = [f"{_T2_MD.get(p, p)} {w:.1f} %" for p, w in worst if w > 5.0]
    return "met" if not bad else "not met (" + ", ".join(bad) + ")"


def _t2_tuning(t: Mapping[str, Any]) -> str:
    gate = t.get("gate")
    return f"{t['s0']:g}, {t['q_theta']:g}, {t['q_x']:g}, {'off' if gate is None else f'{gate:g}'}"


def _t2_kinds(s: Mapping[str, Any]) -> str:
    return ", ".join(f"{k} {v}" for k, v in s["interventions"].items() if v) or "none"


def table2_markdown(doc: Mapping[str, Any]) -> str:
    """The Table 2 analog as Markdown: one table per protocol, then costs, interventions and flags."""
    summ = table2_summary(doc)
    exp = doc["experiment"]
    paper = doc["paper_errors_percent"]
    lines = [f"# Table 2 analog: {exp['model']} under {exp['record']['name']}", "",
             f"Noise {100 * exp['noise_ratio']:g} % (RMS) on input and output; branch table: {doc['branch_table']}; "
             f"tuning seeds {doc['tuning_seeds']} (never reported). Errors are |estimate - true| / |true| in %; "
             f"mean and worst over the reported seeds that ran to the end. † = flagged practically unidentifiable "
             f"in at least half of the seeds: these data cannot pin it within 5 % at 3 sigma, by the linearised "
             f"Cramér-Rao bound, the filter's posterior or the Monte-Carlo spread of the protocol at the estimate "
             f"(see the flags below). The goal column is given with all flags and with the linearised ones alone.",
             ""]
    for passes in sorted({k for _, k in summ}):
        methods = [m for m in _T2_METHODS if (m, passes) in summ]
        title = "one pass (the paper's protocol)" if passes == 1 else f"{passes} passes over the record"
        lines += [f"## {title}", ""]
        head = "| parameter | true | guess | " + " | ".join(
            f"{_T2_METHODS[m]} mean est. | {_T2_METHODS[m]} mean % | {_T2_METHODS[m]} worst %" for m in methods)
        head += " | paper UKF % | paper DUKF % |" if passes == 1 else " |"
        lines += [head, "|" + "---|" * (head.count("|") - 1)]
        for i, p in enumerate(summ[(methods[0], passes)]["parameters"]):
            cells = [_T2_MD.get(p, p), f"{exp['truth'][p]:.4g}", f"{exp['guess'][p]:.4g}"]
            for m in methods:
                s = summ[(m, passes)]
                mark = " †" if _t2_flagged(s, p) else ""
                cells += [f"{s['mean_estimate'][i]:.4g}", f"{s['mean_abs_error'][i]:.2f}{mark}",
                          f"{s['worst_abs_error'][i]:.2f}{mark}"]
            if passes == 1:
                cells += [f"{paper['ukf'][p]:.2f}", f"{paper['dukf'][p]:.2f}"]
            lines.append("| " + " | ".join(cells) + " |")
        if all(summ[(m, passes)]["yield"] for m in methods):  # the combinations the ridge leaves informed
            for d in ("Delta1", "Delta2"):
                true = summ[(methods[0], passes)]["yield"][d][0]
                cells = [f"abs({_T2_MD[d]})^(-1/2N) (yield displ.)", f"{true:.4g}", "-"]
                for m in methods:
                    e = summ[(m, passes)]["yield"][d][1]
                    cells += ["-", f"{np.nanmean(e):.2f}", f"{np.nanmax(e):.2f}"]
                if passes == 1:
                    cells += ["-", "-"]
                lines.append("| " + " | ".join(cells) + " |")
        lines += ["", "| filter | tuning (s0, q_theta, q_x, gate) | s per run | s per pass | repairs | interventions "
                      "(all seeds) | implicit sigma-point steps | output misfit | 5 % goal (worst seed, unflagged) "
                      "| 5 % goal, linearised flags only |",
                  "|---|---|---|---|---|---|---|---|---|---|"]
        for m in methods:
            s = summ[(m, passes)]
            lines.append(f"| {_T2_METHODS[m]} | {_t2_tuning(s['tuning'])} | {s['seconds']:.3f} | "
                         f"{s['seconds_per_pass']:.3f} | {s['repairs']} | {_t2_kinds(s)} | {s['implicit']} | "
                         f"{_t2_misfit(s)} | {_t2_goal(s)} | {_t2_goal(s, 'flag_counts_linearised')} |")
        redone = [(m, r) for m in methods for r in summ[(m, passes)]["redone"]]
        if redone:
            factor = doc.get("diverged_factor", 10)
            lines += ["", f"Redone (the run diverged: it stopped or its output misfit was above {factor:g}x the "
                          "noise level; the next configuration of the tuning ranking was run instead):", ""]
            for m, (seed, attempts, final) in redone:
                tried = "; ".join(f"({_t2_tuning(a['tuning'])}) misfit "
                                  + (f"{a['output_misfit']:.3g}" if a["output_misfit"] is not None else "inf")
                                  + (f", {a['error']}" if a["error"] else "") for a in attempts)
                lines.append(f"- {_T2_METHODS[m]}, seed {seed}: {tried} -> ({_t2_tuning(final)})")
        lines.append("")
    lines += ["## Practically unidentifiable (flag counts over seeds)", ""]
    for (m, k), s in sorted(summ.items()):
        flags = ", ".join(f"{_T2_MD.get(p, p)} {c}/{len(s['seeds'])}" for p, c in s["flag_counts"].items() if c)
        undecided = "".join(f"; not decided on seed {seed}: {why}" for seed, why in s["undecided"])
        spread = ("; Monte-Carlo std (mean over seeds) " + ", ".join(
            f"{_T2_MD.get(p, p)} " + (f"{100 * v:.2g} %" if np.isfinite(v) else "held")
            for p, v in zip(s["parameters"], s["spread"])) if s["spread"] else "")
        lines.append(f"- {_T2_METHODS[m]}, {k} pass(es): {flags or 'none'}{undecided}{spread}")
    stopped = [r for r in doc["runs"] if r.get("error")]
    if stopped:
        lines += ["", "## Runs that stopped (reported, not dropped)", ""]
        lines += [f"- {_T2_METHODS[r['method']]}, {r['passes']} pass(es), seed {r['seed']}: {r['error']}"
                  for r in stopped]
    for k in sorted({k for m, k in summ if m == "ukf"}):
        first = next((r["practical_identifiability"] for r in doc["runs"] if r["method"] == "ukf"
                      and r["passes"] == k and r.get("practical_identifiability")), {})
        if first.get("reasons") or first.get("undecided"):
            lines += ["", f"Reasons (first seed of the UKF, {k} pass(es)):", ""]
            lines += [f"- {_T2_MD.get(p, p)}: {why}" for p, why in first.get("reasons", {}).items()]
            lines += [f"- {_T2_MD.get(p, p)}: not decided, {why}" for p, why in (first.get("undecided") or {}).items()]
    return "\n".join(lines) + "\n"


def table2_latex(doc: Mapping[str, Any]) -> str:
    """The Table 2 analog as a booktabs LaTeX table (one pass and refined, UKF and DUKF, worst seed)."""
    summ = table2_summary(doc)
    exp = doc["experiment"]
    keys = [k for k in sorted(summ, key=lambda k: (k[1], k[0])) if k[0] in ("ukf", "dukf")]
    cols = "l" + "r" * (2 + 2 * len(keys))
    head = " & ".join(["", "true", "guess"] + [
        rf"\multicolumn{{2}}{{c}}{{{_T2_METHODS[m]}, {k} pass{'es' if k > 1 else ''}}}" for m, k in keys]) + r" \\"
    sub = " & ".join(["", "", ""] + ["mean \\%", "worst \\%"] * len(keys)) + r" \\"
    rows = []
    for i, p in enumerate(summ[keys[0]]["parameters"]):
        cells = [_T2_TEX.get(p, p), f"{exp['truth'][p]:.3g}", f"{exp['guess'][p]:.3g}"]
        for key in keys:
            s = summ[key]
            mark = r"$^\dagger$" if _t2_flagged(s, p) else ""
            cells += [f"{s['mean_abs_error'][i]:.2f}{mark}", f"{s['worst_abs_error'][i]:.2f}{mark}"]
        rows.append(" & ".join(cells) + r" \\")
    if all(summ[key]["yield"] for key in keys):  # the combinations the Delta-N ridge leaves informed
        rows.append(r"\midrule")
        for d in ("Delta1", "Delta2"):
            true = summ[keys[0]]["yield"][d][0]
            cells = [rf"$|{_T2_TEX[d].strip('$')}|^{{-1/2N}}$", f"{true:.3g}", "--"]
            for key in keys:
                e = summ[key]["yield"][d][1]
                cells += [f"{np.nanmean(e):.2f}", f"{np.nanmax(e):.2f}"]
            rows.append(" & ".join(cells) + r" \\")
    return "\n".join([
        r"\begin{table}[ht]", r"\centering",
        rf"\caption{{Table 2 analog ({_tex_escape(exp['record']['name'])}, {100 * exp['noise_ratio']:g}\,\% noise, "
        rf"{len(summ[keys[0]]['seeds'])} seeds). $^\dagger$ practically unidentifiable on this record"
        + (r"; last rows: the yield displacements $|\Delta_i|^{-1/2N}$, which the record pins along the "
           r"$\Delta$--$N$ ridge" if all(summ[key]["yield"] for key in keys) else "") + ".}",
        rf"\begin{{tabular}}{{{cols}}}", r"\toprule", head, sub, r"\midrule", *rows, r"\bottomrule",
        r"\end{tabular}", r"\end{table}"]) + "\n"
