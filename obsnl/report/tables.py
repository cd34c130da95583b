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
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, replace

import sympy as sp

from obsnl.errors import OptionError
from obsnl.model.core import Model
from obsnl.model.branching.signature import ModelSignature
from obsnl.observability.contract.branch_table import BranchTable
from obsnl.observability.results import AnalysisResult
from obsnl.observability.verdicts import BranchResult, Verdict
from obsnl.report.sentences import (
    _first_lines,
    _names,
    _verdict_lines,
    assumption_texts,
    joint_text,
    probability_text,
    union_text,
)

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
    "union_text",
    "joint_text",
    "tex_escape",
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
    from ``model`` when the result does not carry it.

    Parameters
    ----------
    result, model : AnalysisResult, Model
        The result and the analysed model.

    Returns
    -------
    AnalysisResult
    """
    from obsnl.model.branching.branches import split_branches
    from obsnl.model.branching.switching import expr_text

    changes: dict = {}
    if result.signature is None:
        changes["signature"] = ModelSignature.of(model)
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
    """The names of the symbols in expression texts (function names such as ``exp`` are not symbols)."""
    from obsnl.model.reading.parse import ALLOWED_FUNCTIONS, make_symbol

    names = set()
    for t in texts:
        names.update(re.findall(r"[^\W\d]\w*", t))
    return {n: make_symbol(n) for n in names if n not in ALLOWED_FUNCTIONS and n != "pi"}


def branch_groups(result: AnalysisResult) -> tuple[BranchGroup, ...]:
    """Group branches with identical verdicts and lists, in order of first appearance."""
    groups: dict[tuple, list[BranchResult]] = {}
    for b in result.branches:
        groups.setdefault(_key(b), []).append(b)
    sw_exprs: list[sp.Expr] = []
    if result.switching:
        loc = _symbols_in(result.switching)
        from obsnl.model.reading.parse import parse_expression

        sw_exprs = [parse_expression(t, loc, where="switching function") for t in result.switching]
    all_patterns = [b.signs for b in result.branches]
    out = []
    for members in groups.values():
        text, expr, factors, sign = _group_condition(members, sw_exprs, all_patterns)
        out.append(BranchGroup(tuple(b.label for b in members), tuple(members), text, expr, factors, sign))
    return tuple(out)


def _group_condition(members: Sequence[BranchResult], sw: Sequence[sp.Expr],
                     all_patterns: Sequence[tuple[int, ...]]) -> tuple[str, sp.Basic | None, tuple, int]:
    from obsnl.model.branching.switching import expr_text

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
def branch_table(result: AnalysisResult, model: Model | None = None) -> BranchTable:
    """The estimators' branch table (schema ``obsnl.branch-table/1``) of an analysis.

    The result of :func:`obsnl.analyze` carries its model's signature; a result built by hand needs
    ``model`` (:func:`complete` fills what is missing from it).

    Parameters
    ----------
    result, model : AnalysisResult, Model or None
        The analysis; its model, needed for a result built by hand.

    Returns
    -------
    BranchTable
    """
    if model is not None:
        result = complete(result, model)
    return BranchTable.from_result(result)


def to_json(result: AnalysisResult, model: Model | None = None) -> str:
    """The branch table as JSON text (the estimators' contract).

    Parameters
    ----------
    result, model : AnalysisResult, Model or None
        As for :func:`branch_table`.

    Returns
    -------
    str
    """
    return branch_table(result, model).to_json()


# --------------------------------------------------------------------------- markdown / text


def _cells(group: BranchGroup, row: str, *, latex: bool, result: AnalysisResult) -> str:
    if row == "condition":
        if latex:
            if group.condition_expr is None:
                return tex_escape(group.condition)
            if group.condition_expr is sp.true:
                return "always"
            if group.factors:
                prod = " ".join(_latex_factor(f, result, wrap=len(group.factors) > 1) for f in group.factors)
                return f"${prod} {'>' if group.sign > 0 else '<'} 0$"
            # one math group per relation, so that a long condition wraps inside its p{} column
            alts = group.condition_expr.args if isinstance(group.condition_expr, sp.Or) else (group.condition_expr,)
            return " or ".join(
                ", ".join(f"${_latex_expr(r, result)}$" for r in (a.args if isinstance(a, sp.And) else (a,)))
                for a in alts)
        return f"`{group.condition}`"
    if row == "degree":
        return "not decided" if group.branches[0].verdict is Verdict.INCONCLUSIVE else str(group.degree)
    names = group.observable if row == "observable" else group.unobservable
    if row == "unobservable" and group.branches[0].undecided:
        names = tuple(names) + tuple(f"{n}?" for n in group.branches[0].undecided)
    if not latex:
        return _names(names)
    # one math group per name, so that a long list wraps inside its p{} column
    return ", ".join(f"${_latex_name(n, result)}$" for n in names) if names else "none"


def _header_line(result: AnalysisResult) -> str:
    bits = [f"method {result.method}"]
    if result.seed is not None:
        bits.append(f"seed {result.seed}")
    if result.verdict is Verdict.INCONCLUSIVE:
        bits.append("inconclusive: no probability bound claimed")
    elif result.probability is not None:
        bits.append(f"every verdict right with probability >= {probability_text(result.probability)}")
    return ", ".join(bits)


def to_markdown(result: AnalysisResult, *, rows: Sequence[str] = DEFAULT_ROWS, title: str | None = None) -> str:
    """A Markdown branch table: one column per group of branches with identical results.

    Parameters
    ----------
    result : AnalysisResult
        The analysis.
    rows : sequence of str
        Row keys of :data:`ROWS`.
    title : str or None
        Heading (default: the model's name).

    Returns
    -------
    str
    """
    _check_rows(rows)
    groups = branch_groups(result)
    lines = [f"### {title or 'Observability of ' + result.model}", "", f"_{_header_line(result)}_", "",
             *"\n\n".join(_first_lines(result, suffix=".", strong=lambda w: f"**{w}**")).split("\n"), ""]
    lines.append("| Branches | " + " | ".join(g.heading for g in groups) + " |")
    lines.append("|---|" + "---|" * len(groups))
    for row in rows:
        lines.append(f"| {ROWS[row]} | " + " | ".join(_cells(g, row, latex=False, result=result) for g in groups)
                     + " |")
    lines.append("")
    if result.visited is not None and result.visited.how != "all":
        lines.append(f"Visited branches: {result.visited.note}.")
    inconclusive = [b for b in result.branches if b.verdict is Verdict.INCONCLUSIVE]
    for b in inconclusive:
        lines.append(f"Branch ({b.label}) is inconclusive: {b.reason}")
    lines += _verdict_lines(result)
    return "\n".join(lines) + "\n"


def to_text(result: AnalysisResult) -> str:
    """A plain-text summary for terminals (``obsnl analyze --format text``)."""
    prob = (f"P(all verdicts right) >= {probability_text(result.probability)}" if result.probability is not None
            else "deterministic")
    if result.verdict is Verdict.INCONCLUSIVE:
        prob = "no probability bound (not every verdict was decided)"
    lines = [f"{result.model}: method {result.method}, seed {result.seed}, {prob}, {result.seconds:.3f} s"]
    lines += [f"  {line}" for line in _first_lines(result, union=False)]
    lines.append(f"  union observable:     {_names(result.overall_observable)}   (in at least one branch)")
    lines.append(f"  union unobservable:   {_names(result.overall_unobservable)}")
    for text in assumption_texts(result):
        lines.append(f"  assumes: {text}")
    for b in result.branches:
        degree = ("transcendence degree not decided" if b.verdict is Verdict.INCONCLUSIVE
                  else f"rank {b.rank}/{b.size}, transcendence degree {b.transcendence_degree}")
        lines.append(f"  ({b.label}) {b.guard}  [{b.method or result.method}, {degree}, {b.seconds:.3f} s]  "
                     f"{b.verdict.value}")
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
    if result.joint is not None:
        j = result.joint
        for k, v in j.unknown_inputs.items():
            lines.append(f"  joint unknown inputs {k}: {_names(v)}")
        visits = ", ".join(f"{v.kind} {'/'.join(v.labels)}" + (
            f" (skipped: {v.reason})" if v.reason else "" if v.visible or v.kind == "branch" else " (invisible)")
            for v in j.visits)
        lines.append(f"  joint visits:         {visits}; P(right) >= {probability_text(j.probability)}")
    if result.visited is not None and result.visited.how != "all":
        lines.append(f"  visited branches:     {result.visited.note}")
        for label, sec in result.visited.durations.items():
            lines.append(f"      ({label}) {sec:.3f} s")
        for g, n in result.visited.crossings.items():
            lines.append(f"      crossings of {g} = 0: {n}")
    for k, v in result.unknown_inputs.items():
        lines.append(f"  union unknown inputs {k}: {_names(v)}")
    lines.append(f"  verdict: {result.overall_verdict.value} (joint); {result.verdict.value} (union over branches)"
                 if result.joint is not None else f"  verdict: {result.verdict.value} (union over branches)")
    return "\n".join(lines) + "\n"


def to_analysis_json(result: AnalysisResult) -> str:
    """The analysis as JSON with exactly the keys of ``obsnl analyze --format json``."""
    return json.dumps(result.to_dict(), indent=2) + "\n"


#: Formats of :func:`render` (``obsnl analyze --format``).
FORMATS: tuple[str, ...] = ("text", "json", "md", "tex", "json-table")


def render(result: AnalysisResult, fmt: str) -> str:
    """Render an analysis result in one of :data:`FORMATS` (the result carries all it needs).

    ``json`` is the analysis itself (keys ``model, method, seed, probability, seconds, branches,
    overall``); ``json-table`` is the estimators' branch table (schema ``obsnl.branch-table/1``);
    ``md`` and ``tex`` are the branch tables for documents.

    Parameters
    ----------
    result, fmt : AnalysisResult, str
        The analysis; one of :data:`FORMATS`.

    Returns
    -------
    str

    Raises
    ------
    OptionError
        For an unknown format.
    """
    if fmt == "text":
        return to_text(result)
    if fmt == "json":
        return to_analysis_json(result)
    if fmt == "md":
        return to_markdown(result)
    if fmt == "tex":
        return to_latex(result)
    if fmt == "json-table":
        return to_json(result)
    raise OptionError(f"unknown format {fmt!r}; formats are {', '.join(FORMATS)}")


# --------------------------------------------------------------------------- latex
_TEX_SPECIAL = {"_": r"\_", "%": r"\%", "&": r"\&", "#": r"\#", "$": r"\$", "{": r"\{", "}": r"\}",
                "~": r"\textasciitilde{}", "^": r"\textasciicircum{}", "\\": r"\textbackslash{}"}


def tex_escape(text: str) -> str:
    return "".join(_TEX_SPECIAL.get(c, c) for c in text)


def _latex_name(name: str, result: AnalysisResult) -> str:
    from obsnl.model.reading.latex import default_latex, latex_problem

    given = result.latex.get(name)
    if isinstance(given, str) and latex_problem(given) is None:  # only a whitelisted name reaches the .tex
        return given
    return default_latex(name)


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
    header = tex_escape(_header_line(result)).replace(">=", "$\\geq$")
    first = _first_lines(result, suffix=".", name=lambda n: f"${_latex_name(n, result)}$", escape=tex_escape)
    cap = caption or (f"Observability of the model {tex_escape(result.model)} by branch ({header}): "
                      + " ".join(first + [tex_escape(t) for t in _verdict_lines(result)]))
    lab = label or f"tab:obsnl-{re.sub(r'[^A-Za-z0-9-]+', '-', result.model)}"
    head = ["% generated by obsnl; needs \\usepackage{booktabs}", "\\begin{table}[htbp]", "\\centering",
            f"\\caption{{{cap}}}", f"\\label{{{lab}}}"]
    return "\n".join(head + body + ["\\end{table}"]) + "\n"


def _check_rows(rows: Sequence[str]) -> None:
    bad = [r for r in rows if r not in ROWS]
    if bad:
        raise OptionError(f"unknown table row {bad[0]!r}; rows are {', '.join(ROWS)}")
