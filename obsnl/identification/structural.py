"""The structural check of an identification: which parameters the analysis proves unidentifiable,
which are identifiable only jointly, and the assignments of frozen values.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from obsnl.errors import OptionError
from obsnl.observability.contract.branch_table import BranchTable

__all__ = ["structurally_unidentifiable", "frozen_but_jointly_identifiable", "parse_assignments"]


def structurally_unidentifiable(result: Any, parameters: Sequence[str]) -> tuple[tuple[str, ...], str]:
    """The ``parameters`` the analysis calls structurally unidentifiable, and which verdict said so.

    Parameters
    ----------
    result : Any
        An :class:`~obsnl.AnalysisResult`; when it has a joint verdict (an attribute ``joint`` with
        ``unobservable``) that is used, else the per-branch union (``overall_unobservable``).
    parameters : sequence of str
        The names to check.

    Returns
    -------
    tuple
        ``(names, "joint" | "union")``.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> structurally_unidentifiable(SimpleNamespace(overall_unobservable=("z", "b")), ["a", "b"])
    (('b',), 'union')
    >>> joint = SimpleNamespace(unobservable=())
    >>> structurally_unidentifiable(SimpleNamespace(overall_unobservable=("b",), joint=joint), ["a", "b"])
    ((), 'joint')
    """
    joint = getattr(result, "joint", None)
    if joint is not None and hasattr(joint, "unobservable"):
        bad, kind = set(joint.unobservable), "joint"
    else:
        bad, kind = set(result.overall_unobservable), "union"
    return tuple(p for p in parameters if p in bad), kind


def parse_assignments(items: Sequence[str], names: Sequence[str], *, option: str, what: str) -> dict[str, float]:
    """``NAME=VALUE`` items as a mapping; one-line errors naming a wrong name or value.

    Parameters
    ----------
    items : sequence of str
        ``NAME=VALUE`` texts.
    names : sequence of str
        Allowed names.
    option : str
        The option, named in the messages.
    what : str
        What the names are, named in the messages.

    Returns
    -------
    dict of str to float

    Raises
    ------
    OptionError
        An unknown name, no ``=``, or a value that is not a number.

    Examples
    --------
    >>> parse_assignments(["k=2.5"], ["k", "c"], option="--guess", what="parameter")
    {'k': 2.5}
    """
    out = {}
    for item in items:
        name, eq, value = item.partition("=")
        name = name.strip()
        if not eq or name not in names:
            raise OptionError(f"{option} {item!r}: {name!r} is not a {what} ({', '.join(names)}); write NAME=VALUE")
        try:
            out[name] = float(value)
        except ValueError:
            raise OptionError(f"{option} {item!r}: {value!r} is not a number") from None
    return out


def frozen_but_jointly_identifiable(table: BranchTable | None, result: Any) -> tuple[str, ...]:
    """Parameters every branch of ``table`` freezes (unidentifiable in each branch) that the joint verdict
    of ``result`` (an analysis of the same model) identifies: a per-branch DUKF cannot learn them.

    Parameters
    ----------
    table : BranchTable or None
        The DUKF's branch table (None: nothing is frozen).
    result : Any
        An :class:`~obsnl.observability.results.AnalysisResult` with its joint verdict.

    Returns
    -------
    tuple of str
    """
    if table is None:
        return ()
    fresh = getattr(result, "joint", None)
    return table.jointly_identifiable_but_frozen(
        None if table.joint is not None or fresh is None else fresh.observable)


def _structural_note(structural: Mapping[str, Any]) -> tuple[str, ...]:
    bad = structural["unidentifiable"]
    if not bad:
        return (f"structural analysis ({structural['verdict']} verdict over {structural['branches']} branches): "
                f"every parameter identifiable",)
    return (f"structural analysis ({structural['verdict']} verdict over {structural['branches']} branches) calls "
            f"{', '.join(bad)} unidentifiable; run anyway (--allow-unidentifiable): their estimates rest on what the "
            f"data reveal beyond that verdict, judge them by the practical-identifiability flags",)
