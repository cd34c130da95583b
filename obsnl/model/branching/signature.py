"""The model signature: what identifies a model to the tables and filters made for it.

One frozen value (name, fingerprint, states, parameters, inputs, outputs, switching functions),
carried by an analysis result, the branch table written from it and the compiled numeric model;
:meth:`ModelSignature.check` is the one place where two of them are compared.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from obsnl._text import quote, quoted
from obsnl.errors import TableError

if TYPE_CHECKING:  # pragma: no cover
    from obsnl.model.core import Model

__all__ = ["ModelSignature", "TABLE_FIX"]

#: How to make a branch table that fits a model.
TABLE_FIX = "regenerate it with `obsnl analyze MODEL --format json-table -o TABLE.json`"


@dataclass(frozen=True)
class ModelSignature:
    """Names, order and fingerprint of a model, as a table or a compiled model records them.

    Attributes
    ----------
    name, fingerprint
        The model's name and the hash of its roles and equations (:attr:`obsnl.Model.fingerprint`).
    states, parameters, inputs, outputs
        Names in the order the estimators use.
    switching
        The switching functions (sympy syntax over the model's symbols), in branch-label order.

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="relay", states=["x"], parameters=["s"], equations={"x": "-s*sign(x)"},
    ...           outputs={"y": "x"})
    >>> sig = ModelSignature.of(m)
    >>> sig.states, sig.switching
    (('x',), ('x',))
    >>> sig.check(sig)  # the same model: no error
    """

    name: str
    fingerprint: str
    states: tuple[str, ...]
    parameters: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    switching: tuple[str, ...]

    @classmethod
    def of(cls, model: Model, *, switching: Sequence[str] | None = None) -> ModelSignature:
        """The signature of a :class:`~obsnl.model.core.Model`.

        Parameters
        ----------
        model : Model
            Any model, smooth or not.
        switching : sequence of str or None
            The switching functions as text when the caller has them already (the branches' order and
            orientation); default: :func:`obsnl.model.branching.switching.switching_functions`.

        Returns
        -------
        ModelSignature
        """
        from obsnl.model.branching.switching import expr_text, switching_functions

        return cls(
            name=model.name,
            fingerprint=model.fingerprint,
            states=tuple(s.name for s in model.states),
            parameters=tuple(s.name for s in model.parameters),
            inputs=tuple(s.name for s in model.inputs),
            outputs=tuple(model.output_names),
            switching=tuple(switching)
            if switching is not None
            else tuple(expr_text(g) for g in switching_functions(model)),
        )

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ModelSignature:
        """Read the signature keys of a branch table or a compiled model's ``to_dict()``."""
        return cls(
            name=str(data["model"] if "model" in data else data["name"]),
            fingerprint=str(data["fingerprint"]),
            **{k: tuple(str(x) for x in data[k]) for k in ("states", "parameters", "inputs", "outputs", "switching")},
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready keys (``name`` is written as ``model`` by the branch table)."""
        return {
            "name": self.name,
            "fingerprint": self.fingerprint,
            "states": list(self.states),
            "parameters": list(self.parameters),
            "inputs": list(self.inputs),
            "outputs": list(self.outputs),
            "switching": list(self.switching),
        }

    def check(
        self,
        other: ModelSignature,
        *,
        exact_switching: bool = False,
        fix: str = TABLE_FIX,
        what: str = "the branch table",
    ) -> None:
        """Refuse ``other`` unless it describes the same model as this signature, name included.

        Parameters
        ----------
        other : ModelSignature
            The signature of the model at hand.
        exact_switching : bool
            Also require the same switching-function texts (a compiled model compiled for this
            table); otherwise the same number is enough (the orientation of a table's switching
            functions may differ from the model's own, see :func:`obsnl.estimation.to_casadi`).
        fix : str
            What the user should do, appended to the message.
        what : str
            How to name the owner of this signature in the message.

        Raises
        ------
        TableError
            Naming the first difference and the fix: the names and order of each role, the switching functions,
            the model's name (when both signatures carry one: a table made for a model called otherwise is
            refused, although the fingerprint leaves the name out), the fingerprint.
        """
        for key in ("states", "parameters", "inputs", "outputs"):
            mine, theirs = getattr(self, key), getattr(other, key)
            if tuple(mine) != tuple(theirs):
                raise TableError(
                    f"{what} was made for model {quote(self.name)} with {key} {quoted(mine)}, "
                    f"but this model has {quoted(theirs)}; {fix}"
                )
        if len(self.switching) != len(other.switching):
            raise TableError(
                f"{what} has {len(self.switching)} switching functions, the model {len(other.switching)}; {fix}"
            )
        if exact_switching and tuple(self.switching) != tuple(other.switching):
            raise TableError(
                f"{what}'s switching functions {quoted(self.switching)} differ from the compiled "
                f"model's {quoted(other.switching)}; compile with to_casadi(model, "
                f"switching=table.switching)"
            )
        if self.name and other.name and self.name != other.name:  # an empty name: not known, not compared
            raise TableError(f"{what} is for model {quote(self.name)}, not {quote(other.name)}; {fix}")
        if self.fingerprint != other.fingerprint:
            raise TableError(
                f"{what}'s fingerprint {self.fingerprint[:12]}... does not match this model's "
                f"{other.fingerprint[:12]}... (the equations differ); {fix}"
            )
