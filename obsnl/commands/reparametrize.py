"""``obsnl reparametrize``: a model written in identifiable combinations, as one request.

:class:`ReparametrizeRequest` checks the renamings (``OLD=NEW`` texts) and the output file, then reads the model
with its size checked, when it is made; :func:`run_reparametrize` calls :func:`obsnl.recombination.reparametrize.reparametrize`
and writes the new model (TOML); :func:`reparametrize_printed` is what the command prints.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from obsnl._text import quote
from obsnl.commands.inputs import check_file_option
from obsnl.errors import OptionError
from obsnl.report.printed import Printed

if TYPE_CHECKING:
    from obsnl.model.core import Model
    from obsnl.recombination.reparametrize import Reparametrization

__all__ = ["ReparametrizeRequest", "ReparametrizeResult", "run_reparametrize", "reparametrize_printed"]


@dataclass(frozen=True)
class _Resolved:
    """What a :class:`ReparametrizeRequest` resolved: the model read and the renamings."""

    model: Model
    names: dict[str, str]


@dataclass(frozen=True, kw_only=True)
class ReparametrizeRequest:
    """One reparametrization, checked and resolved when it is made.

    Parameters
    ----------
    model : Model, str or Path
        The model or its file (read with its size checked before any expression is parsed).
    names : sequence of str
        ``OLD=NEW`` renamings of the proposed symbols.
    keep, eliminate : sequence of str
        Parameters that must not be pivots; parameters to normalise to 1.
    seed, degree : int
        As for :func:`~obsnl.recombination.reparametrize.reparametrize`.
    output : str, Path or None
        A file for the new model (TOML), never written over without ``force``; None or ``"-"``: not written.
    force : bool
        Overwrite ``output``.

    Raises
    ------
    OptionError
        A renaming that is not ``OLD=NEW``.
    OutputError
        An output file that cannot be written.
    """

    model: Model | str | Path
    names: Sequence[str] = ()
    keep: Sequence[str] = ()
    eliminate: Sequence[str] = ()
    seed: int = 0
    degree: int = 1
    output: str | Path | None = None
    force: bool = False
    #: The model read and the renamings: what :func:`run_reparametrize` uses.
    resolved: _Resolved = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        from obsnl.model.files import as_model
        from obsnl.observability.limits import check_file_limits
        from obsnl.report.files import check_target

        check_file_option(self.output, "output=")
        names = list(self.names)
        if bad := [n for n in names if not isinstance(n, str) or n.count("=") != 1 or not all(n.split("="))]:
            raise OptionError(f"names= takes OLD=NEW, got {quote(bad[0])}")
        if self.written is not None:  # refused before any work
            check_target(self.written, force=self.force)
        model = as_model(self.model, check=check_file_limits)  # a Model, or read from its file
        renamings = {old.strip(): new.strip() for old, new in (n.split("=") for n in names)}
        object.__setattr__(self, "resolved", _Resolved(model, renamings))

    @property
    def written(self) -> str | Path | None:
        """The file the new model goes to (None: it is printed)."""
        return None if self.output is None or self.output == "-" else self.output


@dataclass(frozen=True)
class ReparametrizeResult:
    """What :func:`run_reparametrize` returns: the proposal and the file it was written to (None: not written)."""

    reparametrization: Reparametrization
    written: str | Path | None = None

    def to_dict(self) -> dict[str, Any]:
        """The new model (TOML) and the file written."""
        return {
            "toml": self.reparametrization.to_toml(),
            "written": None if self.written is None else str(self.written),
        }


def run_reparametrize(request: ReparametrizeRequest) -> ReparametrizeResult:
    """Propose identifiable combinations (:func:`obsnl.recombination.reparametrize.reparametrize`) and write the
    new model to ``request.output``.

    Parameters
    ----------
    request : ReparametrizeRequest

    Returns
    -------
    ReparametrizeResult
    """
    from obsnl.recombination.reparametrize import reparametrize
    from obsnl.report.files import safe_write

    r = request.resolved
    found = reparametrize(
        r.model,
        names=r.names,
        keep=request.keep,
        eliminate=request.eliminate,
        seed=request.seed,
        degree=request.degree,
    )
    if request.written is not None:
        safe_write(request.written, found.to_toml(), force=request.force)
    return ReparametrizeResult(found, request.written)


def reparametrize_printed(result: ReparametrizeResult) -> Printed:
    """What ``obsnl reparametrize`` prints: the new model (TOML) when it was not written to a file, else what the
    file holds (:func:`obsnl.report.structure.reparametrization_lines`); its undecided line says that the new model
    is not identifiable and what remains (``obsnl`` then exits with code 2).

    Parameters
    ----------
    result : ReparametrizeResult

    Returns
    -------
    Printed
    """
    from obsnl.report.structure import not_identifiable_line, reparametrization_lines

    r = result.reparametrization
    text = r.to_toml() if result.written is None else reparametrization_lines(r, str(result.written))
    return Printed(text, not_identifiable_line(r))
