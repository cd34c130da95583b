"""``obsnl show``: a model's equations and roles, as one request.

:class:`ShowRequest` reads the model once when it is made; :func:`run_show` renders it
(:func:`obsnl.report.structure.render_model`); :func:`show_printed` is what the command prints.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from obsnl.report.printed import STRUCTURE_FORMATS, Printed, check_format

if TYPE_CHECKING:
    from obsnl.model.core import Model

__all__ = ["ShowRequest", "ShowResult", "run_show", "show_printed"]


@dataclass(frozen=True, kw_only=True)
class ShowRequest:
    """A model to show, read when the request is made.

    Parameters
    ----------
    model : Model, str or Path
        The model, its file or ``obsnl:NAME``.
    fmt : {"text", "json"}
        The format.
    """

    model: Model | str | Path
    fmt: str = "text"
    #: The model read: what :func:`run_show` uses.
    resolved: Model = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        check_format(self.fmt, STRUCTURE_FORMATS)  # before the model is read
        from obsnl.model.files import as_model

        object.__setattr__(self, "resolved", as_model(self.model))


@dataclass(frozen=True)
class ShowResult:
    """What :func:`run_show` returns: the model and its rendering."""

    model: Model
    rendering: str

    def to_dict(self) -> dict[str, Any]:
        """The model's name and the rendering."""
        return {"model": self.model.name, "rendering": self.rendering}


def run_show(request: ShowRequest) -> ShowResult:
    """Render the request's model (:func:`obsnl.report.structure.render_model`).

    Parameters
    ----------
    request : ShowRequest

    Returns
    -------
    ShowResult

    Examples
    --------
    >>> run_show(ShowRequest(model="obsnl:coulomb_friction")).rendering.splitlines()[:3]
    ['model coulomb_friction', '  d/dt x = v', '  d/dt v = (-F_c*sign(v) - c*v - k*x + u)/m']
    """
    from obsnl.report.structure import render_model

    return ShowResult(request.resolved, render_model(request.resolved, request.fmt))


def show_printed(result: ShowResult) -> Printed:
    """What ``obsnl show`` prints: the rendering.

    Parameters
    ----------
    result : ShowResult

    Returns
    -------
    Printed
    """
    return Printed(result.rendering)
