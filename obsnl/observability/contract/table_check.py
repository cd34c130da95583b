"""A branch table checked against a fresh analysis of the model, before an estimator trusts it.

The schema and :meth:`BranchTable._check_consistency` catch a table that contradicts itself; a table
that is consistent but wrong (verdicts swapped between branches, a switching function with its sign
flipped, guards that do not match the sign patterns, branches missing, a ``joint`` key that moves a
jointly identifiable parameter into ``unobservable``) would silently change what the DUKF freezes, or
which refusal it skips. :func:`check_table` re-runs the analysis with the table's own method and seed
and refuses any difference, naming the first one.

:func:`check_table` is the door; a caller that runs the analysis itself (an identification, whose structural check
is that same analysis) checks the table's analysis with :func:`table_analysis` before any work, runs it, and
compares with :func:`compare_table`.
"""

from __future__ import annotations

import sympy as sp

from obsnl._text import quote, quoted
from obsnl.errors import ObsnlError, TableError
from obsnl.model.branching.signature import TABLE_FIX, ModelSignature
from obsnl.model.core import Model
from obsnl.model.reading.parse import parse_expression
from obsnl.observability.analyze import CheckedAnalysis, check_analysis, run_analysis
from obsnl.observability.contract.branch_table import BranchEntry, BranchTable
from obsnl.observability.results import AnalysisResult

__all__ = ["check_table", "table_analysis", "compare_table"]

#: Time limit of the analysis that confirms a table, in seconds.
TABLE_SECONDS = 120.0


def _compared(a: str, b: str, model: Model, *, relation: bool = False) -> str:
    """``"same"`` when the texts ``a`` and ``b`` say the same (equal but for spaces, or equal once parsed: a relation
    equivalent), ``"flipped"`` when one expression is the other's negative, else ``"different"`` (also when either
    does not parse): each text is parsed at most once."""
    if "".join(a.split()) == "".join(b.split()):
        return "same"
    try:
        ea = parse_expression(a, model.symbols, where="table", allow_relations=relation)
        eb = parse_expression(b, model.symbols, where="table", allow_relations=relation)
    except ObsnlError:
        return "different"
    if relation:
        return "same" if ea == eb or sp.simplify(sp.Equivalent(ea, eb)) is sp.true else "different"
    if sp.simplify(ea - eb) == 0:
        return "same"
    return "flipped" if sp.simplify(ea + eb) == 0 else "different"


def check_table(table: BranchTable, model: Model, *, max_seconds: float | None = TABLE_SECONDS) -> AnalysisResult:
    """Refuse ``table`` unless a fresh analysis of ``model`` gives the same table; return that analysis.

    Compared: the model signature (names, order, fingerprint), the switching functions and their
    orientation, the set of sign patterns (no branch missing or invented), and per branch the guard,
    verdict, observable / unobservable / absent variables and transcendence degree, the union
    over branches, and the joint verdict (the ``joint`` key, when the table has one: its observable,
    unobservable and inconclusive sets must be the fresh analysis's). The analysis uses the table's method and
    seed, so a table obsnl wrote passes.

    Parameters
    ----------
    table : BranchTable
        A table read with :func:`~obsnl.observability.contract.branch_table.read_branch_table`.
    model : Model
        The model the estimator will run.
    max_seconds : float or None
        Time limit of the fresh analysis.

    Returns
    -------
    AnalysisResult
        The fresh analysis (with the table's method and seed), for the caller to use rather than analyse again.

    Raises
    ------
    TableError
        The first difference, and how to regenerate the table; or the fresh analysis could not
        decide a branch, so the table cannot be confirmed.

    Examples
    --------
    >>> import obsnl
    >>> from obsnl.observability.analyze import analyze
    >>> m = obsnl.read_model("obsnl:coulomb_friction")
    >>> table = BranchTable.from_result(analyze(m, seed=0))
    >>> check_table(table, m).model
    'coulomb_friction'
    >>> bad = BranchTable.from_dict({**table.to_dict(), "branches": table.to_dict()["branches"][:1]})
    >>> check_table(bad, m)
    Traceback (most recent call last):
    ...
    obsnl.errors.TableError: the branch table lacks the branch with signs [-1] (v < 0) that the model has; regenerate it with `obsnl analyze MODEL --format json-table -o TABLE.json`
    """
    result = run_analysis(table_analysis(table, model, max_seconds=max_seconds))
    compare_table(table, result, model)
    return result


def table_analysis(table: BranchTable, model: Model, *, max_seconds: float | None = TABLE_SECONDS) -> CheckedAnalysis:
    """The analysis that confirms ``table``, checked before any work: the table's method and seed on ``model``.

    A table made for another model (its signature: names, order, fingerprint) is refused here, before the
    analysis runs.

    Parameters
    ----------
    table : BranchTable
        The table.
    model : Model
        The model the estimator will run.
    max_seconds : float or None
        Time limit of the analysis.

    Returns
    -------
    CheckedAnalysis
        For :func:`~obsnl.observability.analyze.run_analysis`; compare its result with :func:`compare_table`.

    Raises
    ------
    TableError
        The table was made for another model.

    Examples
    --------
    >>> import obsnl
    >>> from obsnl.observability.analyze import analyze
    >>> m = obsnl.read_model("obsnl:coulomb_friction")
    >>> table = BranchTable.from_result(analyze(m, seed=3))
    >>> checked = table_analysis(table, m)
    >>> checked.seed, checked.max_seconds
    (3, 120.0)
    """
    table.signature.check(ModelSignature.of(model))
    method = table.method if table.method in ("auto", "orc", "sedoglavic") else "auto"
    return check_analysis(
        model, method=method, seed=table.seed if table.seed is not None else 0, max_seconds=max_seconds
    )


def compare_table(table: BranchTable, result: AnalysisResult, model: Model) -> None:
    """Refuse ``table`` unless it is the table of ``result``, the analysis of ``model`` that
    :func:`table_analysis` checked; :func:`check_table` lists what is compared.

    Parameters
    ----------
    table : BranchTable
        The table.
    result : AnalysisResult
        The analysis of ``model`` with the table's method and seed.
    model : Model
        The model (its symbols parse the table's expressions).

    Raises
    ------
    TableError
        The first difference, and how to regenerate the table; or the analysis could not decide a branch, so the
        table cannot be confirmed.
    """
    fresh = BranchTable.from_result(result)
    if len(table.switching) != len(fresh.switching):
        raise TableError(
            f"the table has {len(table.switching)} switching functions, the model {len(fresh.switching)}; {TABLE_FIX}"
        )
    for mine, theirs in zip(table.switching, fresh.switching):
        said = _compared(mine, theirs, model)
        if said != "same":
            how = "the opposite orientation of" if said == "flipped" else "not"
            raise TableError(
                f"the table's switching function {quote(mine)} is {how} the model's {quote(theirs)}; {TABLE_FIX}"
            )
    ours = {b.signs: b for b in table.branches}
    for b in fresh.branches:
        if b.signs not in ours:
            raise TableError(
                f"the branch table lacks the branch with signs {list(b.signs)} ({b.guard}) that the "
                f"model has; {TABLE_FIX}"
            )
    known = {b.signs for b in fresh.branches}
    for b in table.branches:
        if b.signs not in known:
            raise TableError(
                f"branch {quote(b.label)} has signs {list(b.signs)}, which no point of the model has; {TABLE_FIX}"
            )
    for b in fresh.branches:
        _compare(ours[b.signs], b, model)
    if set(table.overall_observable) != set(fresh.overall_observable) or set(table.overall_unobservable) != set(
        fresh.overall_unobservable
    ):
        raise TableError(f"the table's 'overall' differs from the model's union over branches; {TABLE_FIX}")
    _compare_joint(table, fresh)


def _compare_joint(table: BranchTable, fresh: BranchTable) -> None:
    """Refuse a ``joint`` key that is not the fresh analysis's joint verdict (a table without one passes:
    its readers take the joint verdict from their own analysis)."""
    if table.joint is None:
        return
    if fresh.joint is None:  # pragma: no cover - analyze(joint=True) always gives one
        raise TableError(f"the table has a 'joint' key the fresh analysis cannot confirm; {TABLE_FIX}")
    undecided = sorted(set(fresh.joint.get("inconclusive", ())) - set(table.joint.get("inconclusive", ())))
    if undecided:
        raise TableError(
            f"the fresh joint verdict is inconclusive for {quoted(undecided)}, so the table's 'joint' key cannot "
            f"be confirmed; analyse the model with a longer time limit"
        )
    for key in ("observable", "unobservable", "inconclusive"):
        mine, theirs = set(table.joint.get(key, ())), set(fresh.joint.get(key, ()))
        if mine != theirs:
            extra, missing = sorted(mine - theirs), sorted(theirs - mine)
            what = ", ".join(
                x
                for x in (f"lacks {quoted(missing)}" if missing else "", f"adds {quoted(extra)}" if extra else "")
                if x
            )
            raise TableError(
                f"the table's joint verdict contradicts the model's: joint.{key} is {quoted(sorted(mine))} in "
                f"the table, which {what}; {TABLE_FIX}"
            )


def _compare(mine: BranchEntry, fresh: BranchEntry, model: Model) -> None:
    where = f"branch {quote(mine.label)} (signs {list(mine.signs)})"
    if fresh.verdict == "inconclusive":
        raise TableError(
            f"{where}: the fresh analysis of the model is inconclusive there, so the table cannot be "
            f"confirmed; analyse the model with a longer time limit"
        )
    if _compared(mine.guard, fresh.guard, model, relation=True) != "same":
        raise TableError(
            f"{where}: guard {quote(mine.guard)} contradicts its signs (the model gives {quote(fresh.guard)}); "
            f"{TABLE_FIX}"
        )
    for key in ("verdict", "observable", "unobservable", "absent", "transcendence_degree"):
        a, b = getattr(mine, key), getattr(fresh, key)
        if (set(a) != set(b)) if isinstance(a, tuple) else a != b:
            raise TableError(
                f"{where}: {key} is {quoted(a) if isinstance(a, tuple) else quote(a)} in the table but "
                f"{quoted(b) if isinstance(b, tuple) else quote(b)} for the model; {TABLE_FIX}"
            )
