"""``obsnl symmetries``: the generators of the unobservable directions of each branch, as one request.

:class:`SymmetriesRequest` reads the model once, its size checked first, when it is made; :func:`run_symmetries` calls
:func:`obsnl.observability.certificates.symmetry.branch_symmetries` and renders what it finds
(:func:`obsnl.report.structure.render_symmetries`); :func:`symmetries_printed` is what the command prints.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from obsnl.report.printed import STRUCTURE_FORMATS, Printed, check_format

if TYPE_CHECKING:
    from obsnl.model.branching.branches import Branch
    from obsnl.model.core import Model
    from obsnl.observability.certificates.generators import Symmetries

__all__ = ["SymmetriesRequest", "SymmetriesResult", "run_symmetries", "symmetries_printed"]


@dataclass(frozen=True, kw_only=True)
class SymmetriesRequest:
    """A model whose symmetries to find, read (its size checked first) when the request is made.

    Parameters
    ----------
    model : Model, str or Path
        The model or its file.
    fmt : {"text", "json"}
        The format.
    degree, seed : int
        As for :func:`~obsnl.observability.certificates.symmetry.branch_symmetries`.
    """

    model: Model | str | Path
    fmt: str = "text"
    degree: int = 1
    seed: int = 0
    #: The model read: what :func:`run_symmetries` uses.
    resolved: Model = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        check_format(self.fmt, STRUCTURE_FORMATS)  # before the model is read
        from obsnl.model.files import as_model
        from obsnl.observability.limits import check_file_limits

        object.__setattr__(self, "resolved", as_model(self.model, check=check_file_limits))


@dataclass(frozen=True)
class SymmetriesResult:
    """What :func:`run_symmetries` returns: each branch with its generators (None: a branch of undecided feasibility, not
    analysed), and their rendering."""

    found: tuple[tuple[Branch, Symmetries | None], ...]
    rendering: str

    def to_dict(self) -> dict[str, Any]:
        """The rendering (its JSON form holds the generators)."""
        return {"rendering": self.rendering}


def run_symmetries(request: SymmetriesRequest) -> SymmetriesResult:
    """The generators of the unobservable directions of each branch of the request's model, rendered.

    Parameters
    ----------
    request : SymmetriesRequest

    Returns
    -------
    SymmetriesResult
    """
    from obsnl.observability.certificates.symmetry import branch_symmetries
    from obsnl.report.structure import render_symmetries

    found = branch_symmetries(request.resolved, seed=request.seed, degree=request.degree)
    return SymmetriesResult(tuple(found), render_symmetries(found, request.fmt))


def symmetries_printed(result: SymmetriesResult) -> Printed:
    """What ``obsnl symmetries`` prints: the rendering.

    Parameters
    ----------
    result : SymmetriesResult

    Returns
    -------
    Printed
    """
    return Printed(result.rendering)
