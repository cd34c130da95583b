"""Renderings of a model's structure, as the command line prints them: its equations and roles, its smooth
branches, the symmetries of each branch, a reparametrization written to a file, and the one line that
names an inconclusive branch.

Each function takes the library's values (a :class:`~obsnl.model.core.Model`, its branches, a
:class:`~obsnl.observability.certificates.generators.Symmetries` per branch, a reparametrization) and
returns text; nothing here computes a verdict.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Sequence
from typing import Any

__all__ = [
    "render_model",
    "render_branches",
    "render_symmetries",
    "reparametrization_lines",
    "not_identifiable_line",
    "inconclusive_line",
]

_ROLES = ("parameters", "inputs", "unknown_inputs", "known_constants")


def render_model(model: Any, fmt: str = "text") -> str:
    """A model's equations and roles (``obsnl show``).

    Parameters
    ----------
    model : Model
        The model.
    fmt : {"text", "json"}
        ``text``: the equations, then one line per non-empty role and the source; ``json``: the
        model's dictionary (the keys of a model file).

    Returns
    -------
    str
        The rendering, without a final newline.
    """
    if fmt == "json":
        return json.dumps(model.to_dict(), indent=2)
    lines = [str(model)]
    for role in _ROLES:
        if syms := getattr(model, role):
            lines.append(f"  {role.replace('_', ' ')}: {', '.join(s.name for s in syms)}")
    if model.source:
        lines.append(f"  source: {model.source}")
    return "\n".join(lines)


def render_branches(model: Any, branches: Sequence[Any], fmt: str = "text", *, equations: bool = False) -> str:
    """A model's smooth branches: label and guard of each (``obsnl branches``).

    Parameters
    ----------
    model : Model
        The model that was split.
    branches : sequence of Branch
        Its branches (:func:`obsnl.model.branching.branches.split_branches`); a branch no point was
        found in carries its ``undecided`` reason, which is printed.
    fmt : {"text", "json"}
        Output format.
    equations : bool
        Also print each branch's smooth equations (text only).

    Returns
    -------
    str
        The rendering, without a final newline.
    """
    if fmt == "json":
        doc = {
            "model": model.name,
            "branches": [
                {"label": b.label, "guard": b.guard_text, **({"undecided": b.undecided} if b.undecided else {})}
                for b in branches
            ],
        }
        return json.dumps(doc, indent=2)
    lines = [f"{model.name}: {len(branches)} branch{'es' if len(branches) != 1 else ''}"]
    for b in branches:
        lines.append(
            f"  ({b.label}) {b.guard_text}" + (f"  [feasibility undecided: {b.undecided}]" if b.undecided else "")
        )
        if equations:
            lines.extend(f"      d/dt {s} = {b.model.equations[s]}" for s in b.model.states)
    return "\n".join(lines)


def render_symmetries(found: Sequence[tuple[Any, Any]], fmt: str = "text") -> str:
    """The symmetries of each branch (``obsnl symmetries``).

    Parameters
    ----------
    found : sequence of (Branch, Symmetries or None)
        Each branch with the generators found on it (None: its feasibility is undecided, not analysed).
    fmt : {"text", "json"}
        Output format.

    Returns
    -------
    str
        The rendering, without a final newline.
    """
    if fmt == "json":
        return json.dumps(
            [
                {
                    "label": b.label,
                    "guard": b.guard_text,
                    **(
                        s.to_dict()
                        if s
                        else {"undecided": f"not analysed, its feasibility is undecided: {b.undecided}"}
                    ),
                }
                for b, s in found
            ],
            indent=2,
        )
    lines = []
    for b, s in found:
        if s is None:
            lines.append(
                f"branch {b.label} ({b.guard_text}): not analysed, its feasibility is undecided: {b.undecided}"
            )
            continue
        lines.append(
            f"branch {b.label} ({b.guard_text}): {s.dimension} unobservable direction(s), "
            f"{len(s.generators)} with a closed form, {s.missing} without"
        )
        lines.extend(f"  {g.kind:<11} {g}" for g in s.generators)
        lines.extend(f"  note: {n}" for n in s.notes)
    return "\n".join(lines)


def not_identifiable_line(r: Any) -> str | None:
    """The one line that says a reparametrization's new model is not identifiable and what remains, or None when
    it is.

    Parameters
    ----------
    r : Reparametrization
        The result of :func:`obsnl.recombination.reparametrize.reparametrize`.

    Returns
    -------
    str or None
    """
    if r.identifiable:
        return None
    where = "by the joint verdict over its branches"
    if r.remaining:
        head = f"the new model {r.model.name!r} is NOT identifiable: {', '.join(r.remaining)} not identifiable {where}"
        if r.undecided:
            head += f", {', '.join(r.undecided)} undecided"
    else:
        head = f"the new model {r.model.name!r} is not shown identifiable: {', '.join(r.undecided)} undecided {where}"
    return head + (f" ({r.notes[0]})" if r.notes and not r.complete else "")


def reparametrization_lines(r: Any, path: str) -> str:
    """What a reparametrization written to ``path`` holds: its new variables, what was divided out, notes.

    Parameters
    ----------
    r : Reparametrization
        The result of :func:`obsnl.recombination.reparametrize.reparametrize`.
    path : str
        Where its model file was written.

    Returns
    -------
    str
        The summary, one line per item, without a final newline.
    """
    lines = [
        f"wrote {path}: {len(r.mapping)} variables ({'complete' if r.complete else 'incomplete'}, "
        f"{'identifiable' if r.identifiable else 'NOT identifiable'}, method {r.method}, verified "
        f"{'yes' if r.verified else 'no'})"
    ]
    lines += [f"  {k} = {v}" for k, v in r.mapping.items()]
    lines += [f"  divided out: {g}" for g in r.divided]
    lines += [f"  note: {n}" for n in r.notes]
    return "\n".join(lines)


def inconclusive_line(results: Iterable[Any], *, named: bool = False) -> str | None:
    """The one line that names the first inconclusive branch of some analyses, or None when none is.

    Parameters
    ----------
    results : iterable of AnalysisResult
        The analyses, in the order they were asked for.
    named : bool
        Start the line with the model's name (several models).

    Returns
    -------
    str or None
        ``"branch (b) is inconclusive: REASON (and 2 more branch(es))"``, or None.
    """
    stuck = [(r.model, b) for r in results for b in r.branches if b.verdict.value == "inconclusive"]
    if not stuck:
        return None
    name, b = stuck[0]
    more = f" (and {len(stuck) - 1} more branch(es))" if len(stuck) > 1 else ""
    return f"{name + ': ' if named else ''}branch ({b.label}) is inconclusive: {b.reason}{more}"
