"""``obsnl branches``: a model's smooth branches, as one request.

:class:`BranchesRequest` reads the model once when it is made; :func:`run_branches` splits it
(:func:`obsnl.model.branching.branches.split_branches`, a branch of undecided feasibility kept with its reason) and
renders the branches (:func:`obsnl.report.structure.render_branches`); :func:`branches_printed` is what the command prints.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from obsnl.report.printed import STRUCTURE_FORMATS, Printed, check_format

if TYPE_CHECKING:
    from obsnl.model.branching.branches import Branch
    from obsnl.model.core import Model

__all__ = ["BranchesRequest", "BranchesResult", "run_branches", "branches_printed"]


@dataclass(frozen=True, kw_only=True)
class BranchesRequest:
    """A model whose branches to list, read when the request is made.

    Parameters
    ----------
    model : Model, str or Path
        The model, its file or ``obsnl:NAME``.
    fmt : {"text", "json"}
        The format.
    equations : bool
        Also each branch's smooth equations (text only).
    """

    model: Model | str | Path
    fmt: str = "text"
    equations: bool = False
    #: The model read: what :func:`run_branches` uses.
    resolved: Model = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        check_format(self.fmt, STRUCTURE_FORMATS)  # before the model is read
        from obsnl.model.files import as_model

        object.__setattr__(self, "resolved", as_model(self.model))


@dataclass(frozen=True)
class BranchesResult:
    """What :func:`run_branches` returns: the branches and their rendering."""

    branches: tuple[Branch, ...]
    rendering: str

    def to_dict(self) -> dict[str, Any]:
        """The branches' labels and the rendering."""
        return {"branches": [b.label for b in self.branches], "rendering": self.rendering}


def run_branches(request: BranchesRequest) -> BranchesResult:
    """Split the request's model into its smooth branches and render them.

    Parameters
    ----------
    request : BranchesRequest

    Returns
    -------
    BranchesResult

    Examples
    --------
    >>> print(run_branches(BranchesRequest(model="obsnl:coulomb_friction")).rendering.splitlines()[0])
    coulomb_friction: 2 branches
    """
    from obsnl.model.branching.branches import split_branches
    from obsnl.report.structure import render_branches

    m = request.resolved
    found = split_branches(m, undecided=True)
    return BranchesResult(tuple(found), render_branches(m, found, request.fmt, equations=request.equations))


def branches_printed(result: BranchesResult) -> Printed:
    """What ``obsnl branches`` prints: the rendering.

    Parameters
    ----------
    result : BranchesResult

    Returns
    -------
    Printed
    """
    return Printed(result.rendering)
