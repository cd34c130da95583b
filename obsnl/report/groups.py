"""Branches grouped into the columns of a table: the branches that share a verdict, and the condition that
holds on all of them.
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import sympy as sp

from obsnl.observability.results import AnalysisResult
from obsnl.observability.verdicts import BranchResult

__all__ = ["BranchGroup", "branch_groups"]


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
    return (
        b.verdict,
        frozenset(b.observable),
        frozenset(b.unobservable),
        frozenset(b.undecided),
        b.transcendence_degree,
    )


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


def _group_condition(
    members: Sequence[BranchResult], sw: Sequence[sp.Expr], all_patterns: Sequence[tuple[int, ...]]
) -> tuple[str, sp.Basic | None, tuple, int]:
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
                    return (f"{'*'.join(factors)} {'>' if s > 0 else '<'} 0", rel, tuple(sw[i] for i in subset), s)
    rels = [
        sp.And(*[sp.StrictGreaterThan(g, 0) if si > 0 else sp.StrictLessThan(g, 0) for g, si in zip(sw, b.signs)])
        for b in members
    ]
    return " | ".join(f"({b.guard})" for b in members), sp.Or(*rels), (), 0


def _prod(pattern: tuple[int, ...], subset: Sequence[int]) -> int:
    out = 1
    for i in subset:
        out *= pattern[i]
    return out
