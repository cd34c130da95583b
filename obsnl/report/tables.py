"""All formatting of analysis results: LaTeX (booktabs), Markdown, JSON branch tables, text.

A branch table has one column per *group* of branches with identical results (merged as the
seed paper merges (A),(C) and (B),(D) in its Table 1) and the rows Condition / Observable /
Unidentifiable / Transcendence degree. The condition of a group is simplified to a single sign
condition on a product of switching functions when one describes the group exactly (for the
seed model ``(r - eta') x2 > 0``), else it is the disjunction of the branch guards.
"""

from __future__ import annotations

import json
import re
from collections.abc import Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

import sympy as sp

from obsnl.errors import OptionError
from obsnl.model.branching.signature import ModelSignature
from obsnl.model.core import Model
from obsnl.observability.results import AnalysisResult
from obsnl.observability.verdicts import Verdict
from obsnl.report.groups import BranchGroup, branch_groups
from obsnl.report.sentences import (
    assumption_texts,
    joint_text,
    names_text,
    opening_lines,
    probability_text,
    union_text,
    verdict_lines,
)
from obsnl.report.tex import latex_expr, latex_factor, latex_name, tex_escape

if TYPE_CHECKING:  # the estimators' contract loads when a branch table is asked for, not with every rendering
    from obsnl.observability.contract.branch_table import BranchTable

__all__ = [
    "ROWS",
    "complete",
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
]
# The room re-exports this list (obsnl.report); group_cell and analysis_header, which the HTML renderer shares, are
# public names of this module, not of the room.

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
    result : AnalysisResult
    model : Model
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


# --------------------------------------------------------------------------- branch table (JSON)
def branch_table(result: AnalysisResult, model: Model | None = None) -> BranchTable:
    """The estimators' branch table (schema ``obsnl.branch-table/1``) of an analysis.

    The result of :func:`obsnl.analyze` carries its model's signature; a result built by hand needs
    ``model`` (:func:`complete` fills what is missing from it).

    Parameters
    ----------
    result : AnalysisResult
    model : Model or None
        The analysis; its model, needed for a result built by hand.

    Returns
    -------
    BranchTable
    """
    from obsnl.observability.contract.branch_table import BranchTable

    if model is not None:
        result = complete(result, model)
    return BranchTable.from_result(result)


def to_json(result: AnalysisResult, model: Model | None = None) -> str:
    """The branch table as JSON text (the estimators' contract).

    Parameters
    ----------
    result : AnalysisResult
    model : Model or None
        As for :func:`branch_table`.

    Returns
    -------
    str
    """
    return branch_table(result, model).to_json()


# --------------------------------------------------------------------------- markdown / text


def group_cell(group: BranchGroup, row: str, *, latex: bool, result: AnalysisResult) -> str:
    """One cell of a branch table: what ``row`` says of a group of branches, in Markdown/text or in LaTeX.

    Parameters
    ----------
    group : BranchGroup
        The group of branches (a column of the table).
    row : str
        A row key of :data:`ROWS`.
    latex : bool
        LaTeX (each relation and each name its own math group, so that a long cell wraps) instead of
        Markdown/text (the condition in backticks).
    result : AnalysisResult
        The analysis, whose LaTeX names name the variables.

    Returns
    -------
    str
        The cell; a name whose verdict is undecided ends with ``?`` among the unidentifiable ones.

    Examples
    --------
    >>> from obsnl import Model, analyze
    >>> from obsnl.report.groups import branch_groups
    >>> m = Model(name="m", states=["x"], parameters=["a", "b"], equations={"x": "-(a + b)*x"}, outputs={"y": "x"})
    >>> r = analyze(m, seed=1)
    >>> (g,) = branch_groups(r)
    >>> [group_cell(g, row, latex=False, result=r) for row in ROWS]
    ['`true`', 'x', 'a, b', '1']
    >>> [group_cell(g, row, latex=True, result=r) for row in ROWS]
    ['always', '$x$', '$a$, $b$', '1']
    """
    if row == "condition":
        if latex:
            if group.condition_expr is None:
                return tex_escape(group.condition)
            if group.condition_expr is sp.true:
                return "always"
            if group.factors:
                prod = " ".join(latex_factor(f, result, wrap=len(group.factors) > 1) for f in group.factors)
                return f"${prod} {'>' if group.sign > 0 else '<'} 0$"
            # one math group per relation, so that a long condition wraps inside its p{} column
            alts = group.condition_expr.args if isinstance(group.condition_expr, sp.Or) else (group.condition_expr,)
            return " or ".join(
                ", ".join(f"${latex_expr(r, result)}$" for r in (a.args if isinstance(a, sp.And) else (a,)))
                for a in alts
            )
        return f"`{group.condition}`"
    if row == "degree":
        return "not decided" if group.branches[0].verdict is Verdict.INCONCLUSIVE else str(group.degree)
    names = group.observable if row == "observable" else group.unobservable
    if row == "unobservable" and group.branches[0].undecided:
        names = tuple(names) + tuple(f"{n}?" for n in group.branches[0].undecided)
    if not latex:
        return names_text(names)
    # one math group per name, so that a long list wraps inside its p{} column
    return ", ".join(f"${latex_name(n, result)}$" for n in names) if names else "none"


def analysis_header(result: AnalysisResult) -> str:
    """The line under a rendering's title: the method, the seed and the probability that every verdict is right.

    Parameters
    ----------
    result : AnalysisResult
        The analysis.

    Returns
    -------
    str
        Plain text (the renderings escape or mark it up); no probability is claimed for an inconclusive analysis.

    Examples
    --------
    >>> from obsnl import Model, analyze
    >>> m = Model(name="m", states=["x"], parameters=["a", "b"], equations={"x": "-(a + b)*x"}, outputs={"y": "x"})
    >>> analysis_header(analyze(m, seed=1))
    'method auto, seed 1, every verdict right with probability >= 1 (certified)'
    """
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
    lines = [
        f"### {title or 'Observability of ' + result.model}",
        "",
        f"_{analysis_header(result)}_",
        "",
        *"\n\n".join(opening_lines(result, suffix=".", strong=lambda w: f"**{w}**")).split("\n"),
        "",
    ]
    lines.append("| Branches | " + " | ".join(g.heading for g in groups) + " |")
    lines.append("|---|" + "---|" * len(groups))
    for row in rows:
        lines.append(
            f"| {ROWS[row]} | " + " | ".join(group_cell(g, row, latex=False, result=result) for g in groups) + " |"
        )
    lines.append("")
    if result.visited is not None and result.visited.how != "all":
        lines.append(f"Visited branches: {result.visited.note}.")
    inconclusive = [b for b in result.branches if b.verdict is Verdict.INCONCLUSIVE]
    for b in inconclusive:
        lines.append(f"Branch ({b.label}) is inconclusive: {b.reason}")
    lines += verdict_lines(result)
    return "\n".join(lines) + "\n"


def to_text(result: AnalysisResult) -> str:
    """A plain-text summary for terminals (``obsnl analyze --format text``)."""
    prob = (
        f"P(all verdicts right) >= {probability_text(result.probability)}"
        if result.probability is not None
        else "deterministic"
    )
    if result.verdict is Verdict.INCONCLUSIVE:
        prob = "no probability bound (not every verdict was decided)"
    lines = [f"{result.model}: method {result.method}, seed {result.seed}, {prob}, {result.seconds:.3f} s"]
    lines += [f"  {line}" for line in opening_lines(result, union=False)]
    lines.append(f"  union observable:     {names_text(result.overall_observable)}   (in at least one branch)")
    lines.append(f"  union unobservable:   {names_text(result.overall_unobservable)}")
    for text in assumption_texts(result):
        lines.append(f"  assumes: {text}")
    for b in result.branches:
        degree = (
            "transcendence degree not decided"
            if b.verdict is Verdict.INCONCLUSIVE
            else f"rank {b.rank}/{b.size}, transcendence degree {b.transcendence_degree}"
        )
        lines.append(
            f"  ({b.label}) {b.guard}  [{b.method or result.method}, {degree}, {b.seconds:.3f} s]  {b.verdict.value}"
        )
        if b.verdict is Verdict.INCONCLUSIVE:
            lines.append(f"      INCONCLUSIVE: {b.reason}")
            if b.undecided:
                lines.append(f"      undecided:    {names_text(b.undecided)}")
        lines.append(f"      observable:   {names_text(b.observable)}")
        lines.append(f"      unobservable: {names_text(b.unobservable)}")
        if b.absent:
            lines.append(f"      absent:       {names_text(b.absent)}")
        for k, v in b.unknown_inputs.items():
            lines.append(f"      unknown inputs {k}: {names_text(v)}")
        for note in b.notes:
            lines.append(f"      note: {note}")
    if result.joint is not None:
        j = result.joint
        for k, v in j.unknown_inputs.items():
            lines.append(f"  joint unknown inputs {k}: {names_text(v)}")
        visits = ", ".join(
            f"{v.kind} {'/'.join(v.labels)}"
            + (f" (skipped: {v.reason})" if v.reason else "" if v.visible or v.kind == "branch" else " (invisible)")
            for v in j.visits
        )
        lines.append(f"  joint visits:         {visits}; P(right) >= {probability_text(j.probability)}")
    if result.visited is not None and result.visited.how != "all":
        lines.append(f"  visited branches:     {result.visited.note}")
        for label, sec in result.visited.durations.items():
            lines.append(f"      ({label}) {sec:.3f} s")
        for g, n in result.visited.crossings.items():
            lines.append(f"      crossings of {g} = 0: {n}")
    for k, v in result.unknown_inputs.items():
        lines.append(f"  union unknown inputs {k}: {names_text(v)}")
    lines.append(
        f"  verdict: {result.overall_verdict.value} (joint); {result.verdict.value} (union over branches)"
        if result.joint is not None
        else f"  verdict: {result.verdict.value} (union over branches)"
    )
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
    result : AnalysisResult
    fmt : str
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


def to_latex(
    result: AnalysisResult,
    *,
    rows: Sequence[str] = DEFAULT_ROWS,
    caption: str | None = None,
    label: str | None = None,
    environment: bool = True,
) -> str:
    """A booktabs LaTeX table, ready to ``\\input`` (needs ``\\usepackage{booktabs}``).

    Parameters
    ----------
    rows : sequence of str
        Row keys among :data:`ROWS`, in order.
    caption, label : str or None
        Caption and label of the ``table`` environment (defaults name the model).
    environment : bool
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
        body.append(
            f"{ROWS[row]} & " + " & ".join(group_cell(g, row, latex=True, result=result) for g in groups) + " \\\\"
        )
    body += ["\\bottomrule", "\\end{tabular}"]
    if not environment:
        return "\n".join(body) + "\n"
    header = tex_escape(analysis_header(result)).replace(">=", "$\\geq$")
    first = opening_lines(result, suffix=".", name=lambda n: f"${latex_name(n, result)}$", escape=tex_escape)
    cap = caption or (
        f"Observability of the model {tex_escape(result.model)} by branch ({header}): "
        + " ".join(first + [tex_escape(t) for t in verdict_lines(result)])
    )
    lab = label or f"tab:obsnl-{re.sub(r'[^A-Za-z0-9-]+', '-', result.model)}"
    head = [
        "% generated by obsnl; needs \\usepackage{booktabs}",
        "\\begin{table}[htbp]",
        "\\centering",
        f"\\caption{{{cap}}}",
        f"\\label{{{lab}}}",
    ]
    return "\n".join(head + body + ["\\end{table}"]) + "\n"


def _check_rows(rows: Sequence[str]) -> None:
    bad = [r for r in rows if r not in ROWS]
    if bad:
        raise OptionError(f"unknown table row {bad[0]!r}; rows are {', '.join(ROWS)}")
