"""The structural check of an identification: which parameters the analysis proves unidentifiable,
which are identifiable only jointly, and the assignments of frozen values.

:func:`structural_check` reads one :class:`~obsnl.observability.results.AnalysisResult` once and returns
:class:`StructuralCheck`, the value an :class:`~obsnl.identification.results.Identification` carries
(``identify.json``'s ``structural`` is its :meth:`StructuralCheck.to_dict`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

from obsnl._text import block, one_line, plain_float
from obsnl._text import names as name_list
from obsnl.errors import AnalysisError, OptionError
from obsnl.observability.contract.branch_table import BranchTable
from obsnl.observability.results import AnalysisResult

__all__ = [
    "StructuralCheck",
    "structural_check",
    "structurally_unidentifiable",
    "frozen_but_jointly_identifiable",
    "parse_assignments",
]


@dataclass(frozen=True)
class StructuralCheck:
    """What the structural analysis said about the parameters of one identification.

    Attributes
    ----------
    verdict : {"joint", "union"}
        The verdict read: the joint verdict of the analysis where it has one, else the per-branch union.
    unidentifiable : tuple of str
        The parameters that verdict calls structurally unidentifiable.
    allowed : bool
        Some are and the run went on anyway (``allow_unidentifiable``).
    undecided : tuple of str
        Parameters some branch left undecided (sorted).
    branches : int
        Branches the analysis visited.
    frozen_by_the_dukf : tuple of str
        Parameters identifiable only jointly that every branch of the DUKF's table freezes (empty for the
        UKF): a per-branch filter holds them at their guess.

    Examples
    --------
    >>> check = StructuralCheck("joint", ("b",), True, (), 2)
    >>> check.to_dict()["unidentifiable"], check.identifiable
    (['b'], False)
    """

    verdict: Literal["joint", "union"]
    unidentifiable: tuple[str, ...]
    allowed: bool
    undecided: tuple[str, ...]
    branches: int
    frozen_by_the_dukf: tuple[str, ...] = ()

    @property
    def identifiable(self) -> bool:
        """No parameter is structurally unidentifiable by the verdict read."""
        return not self.unidentifiable

    def note(self) -> str:
        """The line ``identify.json``'s ``assumptions`` carry about the structural analysis."""
        head = f"structural analysis ({self.verdict} verdict over {self.branches} branches)"
        if not self.unidentifiable:
            return f"{head}: every parameter identifiable"
        return (
            f"{head} calls {', '.join(self.unidentifiable)} unidentifiable; run anyway as asked: "
            f"their estimates rest on what the data reveal beyond that verdict, judge them by the "
            f"practical-identifiability flags"
        )

    def __repr__(self) -> str:
        return one_line(
            "StructuralCheck",
            f"verdict={self.verdict!r}",
            f"branches={self.branches}",
            f"unidentifiable={name_list(self.unidentifiable, 6)!r}" if self.unidentifiable else "",
            f"frozen_by_the_dukf={name_list(self.frozen_by_the_dukf, 6)!r}" if self.frozen_by_the_dukf else "",
            f"undecided={name_list(self.undecided, 4)!r}" if self.undecided else "",
        )

    def summary(self) -> str:
        """A line or two of plain text: the verdict read and what it names."""
        return block(
            self.note(),
            f"identifiable only jointly, frozen by the DUKF's branches: {', '.join(self.frozen_by_the_dukf)}"
            if self.frozen_by_the_dukf
            else "",
            f"undecided in some branch: {', '.join(self.undecided)}" if self.undecided else "",
        )

    def to_dict(self) -> dict[str, Any]:
        """The ``structural`` object of ``identify.json``."""
        return {
            "verdict": self.verdict,
            "unidentifiable": list(self.unidentifiable),
            "allowed": self.allowed,
            "undecided": list(self.undecided),
            "branches": self.branches,
            "frozen_by_the_dukf": list(self.frozen_by_the_dukf),
        }


def structural_check(
    result: AnalysisResult,
    model: str,
    parameters: Sequence[str],
    *,
    table: BranchTable | None = None,
    method: str = "ukf",
    allow_unidentifiable: bool = False,
) -> StructuralCheck:
    """The structural check of an identification of ``parameters`` by ``method``, from one analysis.

    Parameters
    ----------
    result : AnalysisResult
        The analysis of the model (its joint verdict where it has one).
    model : str
        The model's name, for the messages.
    parameters : sequence of str
        The parameters to identify.
    table : BranchTable or None
        The DUKF's branch table (None: none).
    method : str
        ``"ukf"`` or ``"dukf"``; only the DUKF freezes parameters per branch.
    allow_unidentifiable : bool
        Go on although parameters are unidentifiable (or frozen by the DUKF); they are named in the value.

    Returns
    -------
    StructuralCheck

    Raises
    ------
    AnalysisError
        A structurally unidentifiable parameter, or (``method="dukf"``) one identifiable only jointly that
        every branch of ``table`` freezes, unless ``allow_unidentifiable``.
    """
    bad, kind = structurally_unidentifiable(result, parameters)
    if bad and not allow_unidentifiable:
        which = "the joint verdict" if kind == "joint" else "every branch"
        raise AnalysisError(
            f"{', '.join(bad)} of {model!r} {'is' if len(bad) == 1 else 'are'} structurally unidentifiable "
            f"from its outputs ({which}); write identifiable combinations with `obsnl reparametrize MODEL -o NEW.toml` "
            f"and identify NEW.toml, or pass allow_unidentifiable=True"
        )
    frozen = frozen_but_jointly_identifiable(table, result) if method == "dukf" else ()
    if frozen and not allow_unidentifiable:
        one = len(frozen) == 1
        raise AnalysisError(
            f"{', '.join(frozen)} of {model!r} {'is' if one else 'are'} identifiable only jointly: "
            f"every branch of the table freezes {'it' if one else 'them'}, so the DUKF would hold "
            f"{'it' if one else 'them'} at the guess; reparametrize with `obsnl reparametrize MODEL -o "
            f"NEW.toml` (the seed paper's Delta1, Delta2), use method='ukf', or pass allow_unidentifiable=True"
        )
    undecided = set().union(*(b.undecided for b in result.branches)) & set(parameters)
    return StructuralCheck(
        verdict=kind,
        unidentifiable=bad,
        allowed=bool(bad and allow_unidentifiable),
        undecided=tuple(sorted(undecided)),
        branches=len(result.branches),
        frozen_by_the_dukf=tuple(frozen),
    )


def structurally_unidentifiable(
    result: AnalysisResult, parameters: Sequence[str]
) -> tuple[tuple[str, ...], Literal["joint", "union"]]:
    """The ``parameters`` the analysis calls structurally unidentifiable, and which verdict said so.

    Parameters
    ----------
    result : AnalysisResult
        The analysis; its joint verdict (:attr:`~obsnl.observability.results.AnalysisResult.joint`) is
        used when it was computed, else the per-branch union (``overall_unobservable``).
    parameters : sequence of str
        The names to check.

    Returns
    -------
    tuple
        ``(names, "joint" | "union")``.

    Examples
    --------
    >>> from obsnl import Model, analyze
    >>> m = Model(name="drift", states=["x"], parameters=["a", "b"], inputs=["u"],
    ...           equations={"x": "(a + b)*u"}, outputs={"y": "x"})
    >>> structurally_unidentifiable(analyze(m, seed=0), ["a", "b"])
    (('a', 'b'), 'joint')
    >>> structurally_unidentifiable(analyze(m, seed=0, joint=False), ["b"])
    (('b',), 'union')
    """
    kind: Literal["joint", "union"]
    if result.joint is not None:
        bad, kind = set(result.joint.unobservable), "joint"
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
        An unknown name, no ``=``, a value that is not a number, or a name given twice.

    Examples
    --------
    >>> parse_assignments(["k=2.5"], ["k", "c"], option="guess=", what="parameter")
    {'k': 2.5}
    """
    out: dict[str, float] = {}
    for item in items:
        name, eq, value = item.partition("=")
        name = name.strip()
        if not eq or name not in names:
            raise OptionError(f"{option} {item!r}: {name!r} is not a {what} ({', '.join(names)}); write NAME=VALUE")
        if name in out:  # two values for one name: neither silently wins
            raise OptionError(f"{option} gives {name} twice ({name}={out[name]:g} and {item!r}); give it once")
        try:
            out[name] = plain_float(value)
        except ValueError:
            raise OptionError(f"{option} {item!r}: {value!r} is not a number") from None
    return out


def frozen_but_jointly_identifiable(table: BranchTable | None, result: AnalysisResult) -> tuple[str, ...]:
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
    fresh = result.joint
    return table.jointly_identifiable_but_frozen(None if table.joint is not None or fresh is None else fresh.observable)
