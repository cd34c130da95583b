"""The value of a reparametrization: the new model, the combinations that replace the old parameters and
how to read the new parameters back.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import sympy as sp

from obsnl._text import block, names, one_line
from obsnl.model.core import Model
from obsnl.model.files import model_to_toml
from obsnl.observability.certificates.symmetry import Symmetries

__all__ = ["Reparametrization"]


@dataclass(frozen=True)
class Reparametrization:
    """A proposed identifiable reparametrization.

    Attributes
    ----------
    model
        The new model (states and parameters are the new coordinates; ``definitions`` holds each
        new symbol in the old ones).
    mapping
        ``{new name: expression in the old symbols}``.
    section
        ``{old name: expression in the new symbols}`` on the section (pivots 1, translation pivots 0).
    pivots
        Old parameters normalised away (scaling pivots set to 1, translation pivots to 0).
    functions
        Identifiable functions of the old symbols that generate the field of identifiable functions
        (smooth models; for a non-smooth model the coordinates identifiable in at least one branch).
    complete
        True when ``functions`` generate the whole field of identifiable functions (checked again at
        an independent random point for a smooth model; for a non-smooth model: every unobservable
        direction of every branch got a closed form and the new model is observable).
    observable
        Every coordinate of the new model is observable in at least one of its branches.
    method
        How ``functions`` were obtained: ``"symmetries"`` or ``"symmetries+..."`` (see
        :func:`obsnl.recombination.identifiable.identifiable_functions`).
    branches
        The :class:`obsnl.observability.Symmetries` of each branch of the original model.
    unobservable
        Per branch of the new model, its unobservable coordinates.
    verified
        The new model's equations and outputs were checked symbolically against the old ones.
    divided
        The group divided out, one generator per pivot (scalings in rref form over the pivots, e.g.
        the seed model's ``L``-scaling ``L d/dL - sigma d/dsigma - ...``), as text.
    identifiable
        True only when the joint verdict of the new model (:func:`obsnl.analyze`, its branches together) finds
        every one of its states and parameters identifiable; the file is then headed as identifiable, never
        otherwise.
    remaining
        The new model's coordinates that the joint verdict finds not identifiable (what is left to resolve).
    undecided
        Those it leaves inconclusive (the model is then not shown identifiable either).
    """

    model: Model
    original: str
    mapping: Mapping[str, sp.Expr]
    section: Mapping[str, sp.Expr]
    pivots: tuple[str, ...]
    functions: tuple[sp.Expr, ...]
    complete: bool
    observable: bool
    method: str
    branches: tuple[Symmetries, ...]
    unobservable: Mapping[str, tuple[str, ...]]
    verified: bool
    notes: tuple[str, ...] = ()
    seconds: float = 0.0
    divided: tuple[str, ...] = ()
    identifiable: bool = False
    remaining: tuple[str, ...] = ()
    undecided: tuple[str, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        return {
            "original": self.original,
            "model": self.model.name,
            "identifiable": self.identifiable,
            "remaining": list(self.remaining),
            "undecided": list(self.undecided),
            "mapping": {k: sp.sstr(v) for k, v in self.mapping.items()},
            "section": {k: sp.sstr(v) for k, v in self.section.items()},
            "pivots": list(self.pivots),
            "functions": [sp.sstr(f) for f in self.functions],
            "complete": self.complete,
            "observable": self.observable,
            "method": self.method,
            "verified": self.verified,
            "unobservable": {k: list(v) for k, v in self.unobservable.items()},
            "branches": [b.to_dict() for b in self.branches],
            "notes": list(self.notes),
            "divided": list(self.divided),
            "seconds": self.seconds,
        }

    def __repr__(self) -> str:
        return one_line(
            "Reparametrization",
            f"original={self.original!r}",
            f"model={self.model.name!r}",
            f"new={names(self.mapping, 6)!r}",
            f"pivots={names(self.pivots, 4)!r}",
            f"complete={self.complete}",
            f"observable={self.observable}",
        )

    def summary(self) -> str:
        """A few lines of plain text: is the new model observable, the group divided out, the new symbols."""
        seen = (
            "every new coordinate observable in some branch"
            if self.observable
            else "NOT every new coordinate observable"
        )
        return block(
            f"{self.original} -> {self.model.name}: {seen}, {'complete' if self.complete else 'incomplete'}, "
            f"{'verified' if self.verified else 'not verified'} symbolically",
            f"normalised away: {names(self.pivots, 8)}",
            *(f"{k} = {sp.sstr(v)}" for k, v in list(self.mapping.items())[:8]),
            f"... and {len(self.mapping) - 8} more symbols" if len(self.mapping) > 8 else "",
        )

    def to_toml(self) -> str:
        """The new model as a model file (loads with :func:`obsnl.read_model`), headed by what it is: an
        identifiable reparametrization only when :attr:`identifiable`, else one that is NOT, with what remains."""
        tail = "New symbols are defined in [definitions]."
        if self.identifiable:
            head = f"Identifiable reparametrization of '{self.original}' (obsnl.reparametrize). {tail}"
        else:
            left = [
                f"{', '.join(names)} {what}"
                for names, what in ((self.remaining, "not identifiable"), (self.undecided, "undecided"))
                if names
            ]
            head = (
                f"Reparametrization of '{self.original}' (obsnl.reparametrize), NOT identifiable: "
                f"{'; '.join(left)} (the joint verdict over its branches). {tail}"
            )
        return model_to_toml(self.model, header=head)
