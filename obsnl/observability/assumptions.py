"""What an observability analysis assumes, as a typed value (:attr:`AnalysisResult.assumptions`).

:func:`obsnl.observability.analyze.assumptions` makes it from the model and the options in force; a branch table
carries it (``obsnl.branch-table/1``, key ``assumptions``) and :meth:`Assumptions.from_dict` reads it back. This
module imports no sympy: the estimators read branch tables.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from obsnl._text import json_end, quote
from obsnl._types import JSONValue
from obsnl.errors import DataError

__all__ = ["Assumptions", "InitialConditions", "JointAssumptions"]


@dataclass(frozen=True)
class InitialConditions:
    """What the analysis assumes of the initial states.

    Attributes
    ----------
    unknown
        States whose initial value is unknown (and generic).
    known_generic
        States whose initial value is known but generic (a known initial condition without a value).
    known_values
        ``{state: value}`` for known initial conditions with a given value, the value as text.
    """

    unknown: tuple[str, ...] = ()
    known_generic: tuple[str, ...] = ()
    known_values: Mapping[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict[str, JSONValue]:
        """JSON-ready: ``unknown``, ``known_generic`` (lists) and ``known_values`` (an object)."""
        return {
            "unknown": list(self.unknown),
            "known_generic": list(self.known_generic),
            "known_values": dict(self.known_values),
        }


@dataclass(frozen=True)
class Assumptions:
    """What the verdicts of an analysis assume.

    Attributes
    ----------
    unknown_input_derivatives
        ``"arbitrary"``, a number ``K`` (polynomial unknown inputs with K non-zero derivatives), or None without
        unknown inputs.
    known_inputs
        ``"generic"``, ``"polynomial of degree d"``, or None without known inputs.
    initial_conditions
        What is assumed of the initial states (:class:`InitialConditions`).
    bounds
        The model's declared bounds, ``{name: (lo, hi)}``, an end infinite where the model leaves it open (written
        ``"inf"``/``"-inf"`` by :meth:`to_dict`: JSON has no infinity); empty when none are declared (then
        ``bounds`` is not written). Only the sign patterns that can hold within them are branches.

    Examples
    --------
    >>> a = Assumptions("arbitrary", None, InitialConditions(unknown=("x",)))
    >>> a.to_dict()
    {'unknown_input_derivatives': 'arbitrary', 'known_inputs': None, 'initial_conditions': {'unknown': ['x'], \
'known_generic': [], 'known_values': {}}}
    >>> Assumptions.from_dict(a.to_dict()) == a
    True
    """

    unknown_input_derivatives: int | str | None
    known_inputs: str | None
    initial_conditions: InitialConditions
    bounds: Mapping[str, tuple[float, float]] = field(default_factory=dict)

    def to_dict(self) -> dict[str, JSONValue]:
        """JSON-ready, the keys of ``obsnl analyze --format json``'s ``assumptions``: ``unknown_input_derivatives``,
        ``known_inputs``, ``initial_conditions``, and ``bounds`` (``{name: [lo, hi]}``) when some are declared."""
        out: dict[str, JSONValue] = {
            "unknown_input_derivatives": self.unknown_input_derivatives,
            "known_inputs": self.known_inputs,
            "initial_conditions": self.initial_conditions.to_dict(),
        }
        if self.bounds:
            out["bounds"] = {k: [json_end(lo), json_end(hi)] for k, (lo, hi) in self.bounds.items()}
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, JSONValue]) -> Assumptions:
        """Read :meth:`to_dict`'s data back (from a branch table).

        Raises
        ------
        DataError
            A key missing or unknown, or a value of the wrong kind, named.
        """
        keys = ("unknown_input_derivatives", "known_inputs", "initial_conditions", "bounds")
        _keys(data, keys, required=keys[:3], where="assumptions")
        k = data["unknown_input_derivatives"]
        if not (k is None or k == "arbitrary" or (isinstance(k, int) and not isinstance(k, bool) and k >= 0)):
            raise DataError(f'assumptions.unknown_input_derivatives is {quote(k)}; it is "arbitrary", K >= 0 or null')
        known = data["known_inputs"]
        if not (known is None or isinstance(known, str)):
            raise DataError(f"assumptions.known_inputs is {quote(known)}; it is text or null")
        ic = data["initial_conditions"]
        if not isinstance(ic, Mapping):
            raise DataError(f"assumptions.initial_conditions is {quote(ic)}; it is an object")
        parts = ("unknown", "known_generic", "known_values")
        _keys(ic, parts, required=parts, where="assumptions.initial_conditions")
        values = ic["known_values"]
        if not (isinstance(values, Mapping) and all(isinstance(v, str) for v in values.values())):
            raise DataError(f"assumptions.initial_conditions.known_values is {quote(values)}; it is {{state: text}}")
        bounds = data.get("bounds", {})
        if not isinstance(bounds, Mapping):
            raise DataError(f"assumptions.bounds is {quote(bounds)}; it is {{name: [lo, hi]}}")
        return cls(
            unknown_input_derivatives=k,
            known_inputs=known,
            initial_conditions=InitialConditions(
                unknown=_names(ic["unknown"], "unknown"),
                known_generic=_names(ic["known_generic"], "known_generic"),
                known_values={str(s): str(v) for s, v in values.items()},
            ),
            bounds={str(name): _bound(name, pair) for name, pair in bounds.items()},
        )


@dataclass(frozen=True)
class JointAssumptions:
    """What a joint verdict assumes (:attr:`~obsnl.observability.joint.result.JointResult.assumptions`).

    Attributes
    ----------
    unknown_input_derivatives
        The unknown-input assumption in force (``"arbitrary"`` or ``K``).
    visited_branches
        Labels of the branches visited.
    surfaces_used, surfaces_invisible, surfaces_skipped
        The switching surfaces visited and visible (``"g (a/b)"``), visited but invisible, and skipped (with why).
    known_initial_conditions
        How known initial conditions were applied, in words (``"none"`` without any).
    union_over
        The branch visits the per-branch union is taken over.
    symmetry_certificates
        The symmetries that certified variables unobservable, as text, when some did
        (:func:`~obsnl.observability.certificates.certify.certify_by_symmetry`); else None (not written).
    known_inputs, parameters
        The fixed sentences on the known inputs (a generic random series per visit) and on the parameters (shared
        by every visit).

    Examples
    --------
    >>> a = JointAssumptions("arbitrary", ("a",), (), (), (), "none", ("a",))
    >>> a.to_dict()["visited_branches"], "symmetry_certificates" in a.to_dict()
    (['a'], False)
    """

    unknown_input_derivatives: int | str
    visited_branches: tuple[str, ...]
    surfaces_used: tuple[str, ...]
    surfaces_invisible: tuple[str, ...]
    surfaces_skipped: tuple[str, ...]
    known_initial_conditions: str
    union_over: tuple[str, ...]
    symmetry_certificates: tuple[str, ...] | None = None
    known_inputs: str = "generic (random series, independent per visit; shared by both sides of a surface)"
    parameters: str = "shared by every visit, at one generic value per run"

    def to_dict(self) -> dict[str, JSONValue]:
        """JSON-ready (lists for tuples), in the order ``obsnl analyze --format json`` writes ``joint.assumptions``."""
        out: dict[str, JSONValue] = {
            "unknown_input_derivatives": self.unknown_input_derivatives,
            "known_inputs": self.known_inputs,
            "visited_branches": list(self.visited_branches),
            "surfaces_used": list(self.surfaces_used),
            "surfaces_invisible": list(self.surfaces_invisible),
            "surfaces_skipped": list(self.surfaces_skipped),
            "known_initial_conditions": self.known_initial_conditions,
            "union_over": list(self.union_over),
            "parameters": self.parameters,
        }
        if self.symmetry_certificates is not None:
            out["symmetry_certificates"] = list(self.symmetry_certificates)
        return out


def _keys(data: Mapping[str, JSONValue], known: tuple[str, ...], *, required: tuple[str, ...] = (), where: str) -> None:
    """Refuse a key not in ``known`` (it would be lost when written again) and a ``required`` one missing."""
    extra = [k for k in data if k not in known]
    if extra:
        raise DataError(f"{where} has the unknown key {quote(extra[0], 40)}; its keys are {', '.join(known)}")
    missing = [k for k in required if k not in data]
    if missing:
        raise DataError(f"{where} has no {missing[0]!r}; its keys are {', '.join(known)}")


def _names(value: JSONValue, key: str) -> tuple[str, ...]:
    if not (isinstance(value, list) and all(isinstance(v, str) for v in value)):
        raise DataError(f"assumptions.initial_conditions.{key} is {quote(value)}; it is a list of state names")
    return tuple(str(v) for v in value)


def _bound(name: str, pair: JSONValue) -> tuple[float, float]:
    if not (isinstance(pair, list) and len(pair) == 2):
        raise DataError(f'assumptions.bounds.{name} is {quote(pair)}; it is [lo, hi], an end a number, "-inf" or "inf"')
    return _end(name, pair[0]), _end(name, pair[1])


def _end(name: str, end: JSONValue) -> float:
    """An end read back from JSON: a number, or ``"inf"``/``"-inf"`` for an open end."""
    if isinstance(end, (int, float)) and not isinstance(end, bool) or end in ("inf", "-inf"):
        return float(end)  # a number, or "inf"/"-inf" (float reads them)
    raise DataError(f'assumptions.bounds.{name} has the end {quote(end)}; an end is a number, "-inf" or "inf"')
