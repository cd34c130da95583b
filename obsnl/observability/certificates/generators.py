"""Found symmetries as values: one verified generator (:class:`Symmetry`) and the set of them with the
parameters they leave unidentifiable (:class:`Symmetries`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import sympy as sp

from obsnl._text import block, names, one_line
from obsnl.errors import NotSupportedError
from obsnl.observability.engines.jacobian import ModularJacobian

__all__ = ["Symmetry", "Symmetries"]


@dataclass(frozen=True)
class Symmetry:
    """One generator ``X = sum xi_j d/dz_j`` (only nonzero components are stored).

    Attributes
    ----------
    kind
        ``"translation"``, ``"scaling"``, ``"affine"``, ``"quadratic"``, or ``"decoupled"`` (a unit
        direction along a variable with no path to any output; its flow changes the decoupled part of
        the vector field but never the outputs).
    components
        ``{variable name: xi_j}`` as sympy expressions; for a scaling ``xi_j = w_j z_j``.
    verification
        ``"symbolic"`` (the determining equations reduce to 0 with sympy) or ``"dependency graph"``
        (a decoupled variable).
    """

    kind: str
    components: Mapping[str, sp.Expr]
    verification: str = "symbolic"

    @property
    def weights(self) -> dict[str, sp.Expr]:
        """The weights ``w_j`` of a scaling (``xi_j = w_j z_j``)."""
        if self.kind != "scaling":
            raise NotSupportedError(f"a {self.kind} has no weights")
        return {k: sp.simplify(v / sp.Symbol(k, real=True)) for k, v in self.components.items()}

    def __str__(self) -> str:
        out = ""
        for k, v in self.components.items():
            neg = not isinstance(v, sp.Add) and v.could_extract_minus_sign()
            a = -v if neg else v
            body = (
                f"d/d{k}" if a == 1 else (f"({sp.sstr(a)})*d/d{k}" if isinstance(a, sp.Add) else f"{sp.sstr(a)}*d/d{k}")
            )
            out += (" - " if neg else " + ") + body if out else ("-" if neg else "") + body
        return out or "0"

    def __repr__(self) -> str:
        return one_line("Symmetry", repr(self.kind), repr(str(self)), f"verification={self.verification!r}")

    def summary(self) -> str:
        """The generator in one line of plain text, with its kind and how it was verified."""
        return block(f"{self.kind} {self} (verified: {self.verification})")

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "components": {k: sp.sstr(v) for k, v in self.components.items()},
            "verification": self.verification,
        }


@dataclass(frozen=True)
class Symmetries:
    """The generators found for one smooth model, and how much of the unobservable space they span.

    Attributes
    ----------
    model
        Name of the model.
    generators
        Verified generators, pointwise independent (translations, then scalings, then others).
    dimension
        Dimension ``d`` of the unobservable directions (unknowns minus the Jacobian rank).
    missing
        Directions with no closed form found (``d`` minus the rank of the generators); never dropped.
    unobservable
        Unknowns that move along some unobservable direction.
    exponents
        Parameters allowed in scaling weights (observable exponents of symbolic powers).
    seconds, seed, notes
    """

    model: str
    generators: tuple[Symmetry, ...]
    dimension: int
    missing: int
    unobservable: tuple[str, ...]
    exponents: tuple[str, ...] = ()
    seconds: float = 0.0
    seed: int = 0
    notes: tuple[str, ...] = ()
    jacobian: ModularJacobian | None = field(default=None, compare=False, repr=False)

    @property
    def complete(self) -> bool:
        """True when the generators span every unobservable direction."""
        return self.missing == 0

    def __repr__(self) -> str:
        kinds = {g.kind: len(self.of_kind(g.kind)) for g in self.generators}
        return one_line(
            "Symmetries",
            f"model={self.model!r}",
            f"dimension={self.dimension}",
            f"generators={len(self.generators)}"
            + (f" ({', '.join(f'{n} {k}' for k, n in kinds.items())})" if kinds else ""),
            f"missing={self.missing}",
            f"unobservable={names(self.unobservable, 6)!r}",
        )

    def summary(self) -> str:
        """A few lines of plain text: how many unobservable directions, how many have a closed form, which.

        Examples
        --------
        >>> from obsnl import Model, symmetries
        >>> m = Model(name="m", states=["x"], parameters=["a", "b"], equations={"x": "-a*b*x"}, outputs={"y": "x"})
        >>> print(symmetries(m, seed=0).summary(), end="")
        m: 1 unobservable direction, every one generated (complete)
        unobservable: a, b
        scaling a*d/da - b*d/db
        """
        n = self.dimension
        found = "every one generated (complete)" if self.complete else f"{self.missing} without a closed form"
        return block(
            f"{self.model}: {n} unobservable direction{'s' if n != 1 else ''}, {found}",
            f"unobservable: {names(self.unobservable, 12)}",
            *(f"{g.kind} {g}" for g in self.generators[:8]),
            f"... and {len(self.generators) - 8} more generators" if len(self.generators) > 8 else "",
        )

    def of_kind(self, kind: str) -> tuple[Symmetry, ...]:
        return tuple(g for g in self.generators if g.kind == kind)

    def to_dict(self) -> dict[str, Any]:
        return {
            "model": self.model,
            "dimension": self.dimension,
            "missing": self.missing,
            "complete": self.complete,
            "unobservable": list(self.unobservable),
            "exponents": list(self.exponents),
            "generators": [g.to_dict() for g in self.generators],
            "seconds": self.seconds,
            "seed": self.seed,
            "notes": list(self.notes),
        }
