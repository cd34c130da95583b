"""The frozen model value every analysis and estimator starts from.

A :class:`Model` is an explicit ODE ``x' = f(x, theta, u, w)``, ``y = h(x, theta, u, w)``
with declared states ``x``, unknown constant parameters ``theta``, known inputs ``u``,
unknown inputs ``w`` and known constants. It is validated once, when built; afterwards it
cannot change: transformations return a new model.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import sympy as sp

from obsnl._text import json_end
from obsnl._types import FileValue
from obsnl.errors import ModelError, ParseError
from obsnl.model.reading.fields import ROLE_NAMES, ROLES, read_fields
from obsnl.model.reading.names import close_name as _close
from obsnl.model.reading.parse import quote

__all__ = ["Model", "NONSMOOTH_FUNCTIONS"]

#: sympy classes that make a vector field non-smooth (handled by :func:`obsnl.model.split_branches`).
NONSMOOTH_FUNCTIONS: tuple[type, ...] = (sp.sign, sp.Abs, sp.Heaviside, sp.Piecewise, sp.Max, sp.Min)

#: Keys of a model file/dict, in the order they are written.
MODEL_KEYS: tuple[str, ...] = (
    "name",
    "description",
    "source",
    "states",
    "parameters",
    "inputs",
    "unknown_inputs",
    "known_constants",
    "outputs",
    "equations",
    "known_initial_conditions",
    "initial_condition_values",
    "switching",
    "latex",
    "values",
    "guess",
    "definitions",
    "unknown_input_derivatives",
    "intersample",
    "bounds",
)
#: Keys kept as metadata without interpretation (the published answers of a peer case, notes).
METADATA_KEYS: tuple[str, ...] = (
    "answer_source",
    "answer_kind",
    "expected",
    "expected_global",
    "expected_identifiable_functions",
    "expected_unknown_inputs",
    "notes",
    "metadata",
    "citation",
    "units",
)


@dataclass(frozen=True, eq=False, repr=False)
class Model:
    """An ODE model with declared roles for every symbol.

    Build it from strings (or sympy expressions) directly, or with
    :func:`obsnl.read_model` from a TOML/JSON file. Every symbol must be declared;
    mistakes raise :class:`~obsnl.errors.ModelError` naming the culprit and the fix.

    Parameters
    ----------
    name : str
        Short identifier of the model.
    states : tuple of sympy.Symbol
        State names, in order.
    parameters : tuple of sympy.Symbol
        Unknown constant parameters (to be identified), in order.
    equations : mapping of sympy.Symbol to sympy.Expr
        ``{state: right-hand side}``, one per state.
    outputs : mapping of str to sympy.Expr
        ``{output name: expression}`` (the measurements).
    inputs : tuple of sympy.Symbol
        Known inputs (measured excitation).
    unknown_inputs : tuple of sympy.Symbol
        Unmeasured inputs ``w(t)``.
    known_constants : tuple of sympy.Symbol
        Symbols whose value is known (not estimated).
    known_initial_conditions : tuple of sympy.Symbol
        States whose initial value is known.
    initial_condition_values : mapping of sympy.Symbol to sympy.Expr
        ``{state: value}`` for known initial conditions with a specific value (number,
        known constant or expression in the parameters); a known-IC state without a value
        has a known but generic initial value.
    description, source : str
        Free text; ``source`` should cite the paper the model comes from.
    switching : tuple of sympy.Expr
        Optional order (and sign convention) of the switching functions of a non-smooth
        model, e.g. ``["sigma - eta", "x2"]``; branch labels follow it.
    latex : mapping of str to str
        ``{name: LaTeX}`` for reports, e.g. ``{"Delta1": "\\\\Delta_1"}``.
    values : mapping of str to float
        Nominal numbers ``{name: value}`` for parameters and initial states (simulation,
        true values of an identification experiment).
    guess : mapping of str to float
        Initial guesses ``{parameter: value}`` of an identification (``obsnl identify``; ``--guess``
        overrides them).
    definitions : mapping of str to str
        ``{name: expression}`` defining symbols of this model in terms of another model's
        symbols (written by :func:`obsnl.reparametrize`).
    metadata : mapping of str to FileValue
        Anything else a file carried (published answers of a peer case, notes): free data as the file held it,
        hence the recursive :data:`~obsnl._types.FileValue` (text, numbers, booleans, TOML dates, lists and
        tables of them); a model built in Python is expected to pass such plain data too (it is not checked).
    unknown_input_derivatives : int or str or None
        What the unknown inputs are assumed to be: ``"arbitrary"`` (any analytic function of time) or
        ``K``, a polynomial in t with K non-zero derivatives (STRIKE-GOLDD's ``nnzDerW``; 0 = a
        constant). None (not stated): the analyses assume ``"arbitrary"``.
    intersample : mapping of str to str
        How each input behaves between its samples, ``{input: kind}`` with kind ``zoh``, ``linear`` or
        ``bandlimited`` (:mod:`obsnl.estimation.intersample`; the ``[intersample]`` table of a model file); an
        input not named is linear. ``--intersample`` (``intersample=``) overrides it.
    bounds : mapping of str to (float, float)
        Declared bounds of parameters and known constants, ``{name: (lo, hi)}`` with ``lo < hi`` and either end
        possibly infinite (``"-inf"``/``"inf"`` in a file, a float infinity once read), or the words
        ``"positive"`` (``(0, inf)``) and ``"negative"``; the ``[bounds]`` table of a model file
        (``fy = "positive"``, ``gap = [0, 0.01]``). The field holds the read pairs of floats.
        ``[values]`` and ``[guess]`` must lie within them. Whether an end is included does not matter: the
        branch split keeps a sign pattern only where it holds inside the bounds (``sign(fy)`` with ``fy``
        positive has one branch, :func:`obsnl.model.split_branches`), and the fit keeps every parameter on the
        sign of its guess.

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="msd", states=["x", "v"], parameters=["k", "c"], inputs=["u"],
    ...           equations={"x": "v", "v": "u - k*x - c*v"}, outputs={"y": "x"})
    >>> print(m)
    model msd
      d/dt x = v
      d/dt v = -c*v - k*x + u
      y = x
    """

    name: str
    states: tuple[sp.Symbol, ...]
    parameters: tuple[sp.Symbol, ...]
    equations: Mapping[sp.Symbol, sp.Expr]
    outputs: Mapping[str, sp.Expr]
    inputs: tuple[sp.Symbol, ...] = ()
    unknown_inputs: tuple[sp.Symbol, ...] = ()
    known_constants: tuple[sp.Symbol, ...] = ()
    known_initial_conditions: tuple[sp.Symbol, ...] = ()
    initial_condition_values: Mapping[sp.Symbol, sp.Expr] = field(default_factory=dict)
    description: str = ""
    source: str = ""
    switching: tuple[sp.Expr, ...] = ()
    latex: Mapping[str, str] = field(default_factory=dict)
    values: Mapping[str, float] = field(default_factory=dict)
    guess: Mapping[str, float] = field(default_factory=dict)
    definitions: Mapping[str, str] = field(default_factory=dict)
    metadata: Mapping[str, FileValue] = field(default_factory=dict)
    unknown_input_derivatives: int | str | None = None
    intersample: Mapping[str, str] = field(default_factory=dict)
    bounds: Mapping[str, tuple[float, float]] = field(default_factory=dict)

    if TYPE_CHECKING:
        # What the constructor takes, for type checkers: names and expressions as text or sympy objects, in any
        # iterable or mapping; the fields above hold them read (tuples of symbols, read-only tables). At run time
        # the dataclass writes __init__ from the fields, in this order (tests/test_typing_surface.py checks it).
        def __init__(
            self,
            name: str,
            states: Iterable[str | sp.Symbol],
            parameters: Iterable[str | sp.Symbol],
            equations: Mapping[str | sp.Symbol, str | float | sp.Expr],
            outputs: Mapping[str, str | float | sp.Expr],
            inputs: Iterable[str | sp.Symbol] = (),
            unknown_inputs: Iterable[str | sp.Symbol] = (),
            known_constants: Iterable[str | sp.Symbol] = (),
            known_initial_conditions: Iterable[str | sp.Symbol] = (),
            initial_condition_values: Mapping[str | sp.Symbol, str | float | sp.Expr] = ...,
            description: str = "",
            source: str = "",
            switching: Iterable[str | sp.Expr] = (),
            latex: Mapping[str, str] = ...,
            values: Mapping[str, float] = ...,
            guess: Mapping[str, float] = ...,
            definitions: Mapping[str, str] = ...,
            metadata: Mapping[str, FileValue] = ...,
            unknown_input_derivatives: int | str | None = None,
            intersample: Mapping[str, str] = ...,
            bounds: Mapping[str, Sequence[float | str] | str] = ...,
        ) -> None: ...

    # ------------------------------------------------------------------ validation
    def __post_init__(self) -> None:
        """Read and check every field once (:func:`~obsnl.model.reading.fields.read_fields`)."""
        read = read_fields({f.name: getattr(self, f.name) for f in dataclasses.fields(self)})
        for key, value in read.items():
            object.__setattr__(self, key, value)  # a frozen dataclass: set while it is built, never after

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Model:
        """Build a model from the keys of a model file (see :func:`obsnl.read_model`).

        Unknown keys are errors (a misspelled ``ouputs`` would otherwise be lost).
        """
        if not isinstance(data, Mapping):
            raise ParseError("a model must be a table/object of keys")
        unknown = [k for k in data if k not in MODEL_KEYS and k not in METADATA_KEYS]
        if {"structure", "crack", "bank"} <= set(data):  # the packaged cantilever_link.toml and its copies
            raise ParseError(
                "this is an observer-bank study file (a cracked cantilever link), not a model: run it "
                "with the bank study (obsnl bank, its model option), or give a model file"
            )
        if unknown:
            k = unknown[0]
            raise ParseError(
                f"unknown key {quote(k, 40)}{_close(k, MODEL_KEYS)}; model keys are {', '.join(MODEL_KEYS)}"
            )
        for req in ("name", "states", "equations"):
            if req not in data:
                raise ParseError(f"the model has no {req!r}; add it")
        meta = {k: data[k] for k in METADATA_KEYS if k in data}
        kwargs = {k: data[k] for k in MODEL_KEYS if k in data}
        kwargs.setdefault("parameters", ())
        kwargs.setdefault("outputs", {})
        return cls(metadata=meta, **kwargs)

    def __copy__(self) -> Model:
        """A shallow copy of the validated fields (no parse; :func:`obsnl.model.branching.branches.derived_model`)."""
        new = object.__new__(type(self))
        new.__dict__.update(self.__dict__)
        return new

    def __reduce__(self) -> tuple[Any, tuple[dict[str, Any]]]:
        """Pickled as its model-file dictionary (plain data; parsed again on loading): how a model travels to
        worker processes and Dask workers."""
        return (type(self).from_dict, (self.to_dict(),))

    def to_dict(self) -> dict[str, Any]:
        """The model as a model-file dictionary (expressions as strings); inverse of :meth:`from_dict`."""
        d: dict[str, Any] = {"name": self.name}
        if self.description:
            d["description"] = self.description
        if self.source:
            d["source"] = self.source
        for role in ROLES:
            d[role] = [s.name for s in getattr(self, role)]
        d["outputs"] = {k: _expr_text(v) for k, v in self.outputs.items()}
        d["equations"] = {s.name: _expr_text(self.equations[s]) for s in self.states}
        if self.known_initial_conditions:
            d["known_initial_conditions"] = [s.name for s in self.known_initial_conditions]
        if self.initial_condition_values:
            d["initial_condition_values"] = {s.name: _expr_text(v) for s, v in self.initial_condition_values.items()}
        if self.switching:
            d["switching"] = [_expr_text(e) for e in self.switching]
        if self.latex:
            d["latex"] = dict(self.latex)
        if self.values:
            d["values"] = dict(self.values)
        if self.guess:
            d["guess"] = dict(self.guess)
        if self.definitions:
            d["definitions"] = dict(self.definitions)
        if self.unknown_input_derivatives is not None:
            d["unknown_input_derivatives"] = self.unknown_input_derivatives
        if self.intersample:
            d["intersample"] = dict(self.intersample)
        if self.bounds:  # an infinite end as text: JSON has no infinity
            d["bounds"] = {k: [json_end(lo), json_end(hi)] for k, (lo, hi) in self.bounds.items()}
        return d

    def replace(self, **changes: Any) -> Model:
        """A new model with some fields changed (validated again).

        Parameters
        ----------
        **changes : Any
            New values of fields, by name: the keywords are the fields of :class:`Model` (as its constructor takes
            them), so the call keeps the dataclass's own contract; a name that is not a field is refused.

        Returns
        -------
        Model

        Raises
        ------
        ModelError
            A keyword that is not a field of :class:`Model` (the closest field named), or what validation refuses.

        Examples
        --------
        >>> m = Model(name="m", states=["x"], parameters=["a"], equations={"x": "-a*x"}, outputs={"y": "x"})
        >>> dict(m.replace(outputs={"y": "2*x"}).outputs)
        {'y': 2*x}
        >>> m.replace(ouputs={"y": "2*x"})
        Traceback (most recent call last):
        ...
        obsnl.errors.ModelError: Model.replace takes fields of a Model; 'ouputs' is none (did you mean 'outputs'?)
        """
        fields = [f.name for f in dataclasses.fields(self)]
        unknown = [k for k in changes if k not in fields]
        if unknown:  # Model(**d) would raise a TypeError
            k = unknown[0]
            raise ModelError(f"Model.replace takes fields of a Model; {quote(k, 40)} is none{_close(k, fields)}")
        d = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        d["equations"] = {s.name: e for s, e in self.equations.items()}
        d["initial_condition_values"] = {s.name: e for s, e in self.initial_condition_values.items()}
        d.update(changes)
        return Model(**d)

    def with_outputs(self, extra: Mapping[str, Any]) -> Model:
        """A new model with additional outputs ``{name: expression}``."""
        outs = dict(self.outputs)
        for k in extra:
            if k in outs:
                raise ModelError(f"output {k!r} exists already; choose another name")
        outs.update(extra)
        return self.replace(outputs=outs)

    # ------------------------------------------------------------------ views
    @property
    def symbols(self) -> dict[str, sp.Symbol]:
        """Every declared name -> its symbol."""
        out: dict[str, sp.Symbol] = {}
        for role in ROLES:
            for s in getattr(self, role):
                out[s.name] = s
        return out

    def symbol(self, name: str) -> sp.Symbol:
        """The declared symbol called ``name`` (error with a suggestion otherwise)."""
        syms = self.symbols
        if name not in syms:
            raise ModelError(f"{quote(name, 40)} is not declared in model {self.name!r}{_close(name, syms)}")
        return syms[name]

    def role(self, name: str) -> str:
        """``'state'``, ``'parameter'``, ``'input'``, ``'unknown input'`` or ``'known constant'``."""
        for role in ROLES:
            if any(s.name == name for s in getattr(self, role)):
                return ROLE_NAMES[role]
        raise ModelError(f"{name!r} is not declared in model {self.name!r}")

    @property
    def variables(self) -> tuple[sp.Symbol, ...]:
        """The unknowns of an observability analysis: states, then parameters."""
        return self.states + self.parameters

    @property
    def rhs(self) -> tuple[sp.Expr, ...]:
        """Right-hand sides in state order."""
        return tuple(self.equations[s] for s in self.states)

    @property
    def output_names(self) -> tuple[str, ...]:
        return tuple(self.outputs)

    @property
    def output_exprs(self) -> tuple[sp.Expr, ...]:
        return tuple(self.outputs.values())

    @property
    def fingerprint(self) -> str:
        """A hash of the roles and equations (not of name, text or values).

        Tables and compiled functions derived from a model carry it, so that a table made for
        another model is refused.
        """
        import hashlib
        import json

        d = self.to_dict()
        core = {
            k: d.get(k)
            for k in (
                "states",
                "parameters",
                "inputs",
                "unknown_inputs",
                "known_constants",
                "outputs",
                "equations",
                "known_initial_conditions",
                "initial_condition_values",
            )
        }
        if self.bounds:  # a table made under bounds has fewer branches (and no key without them: hashes unchanged)
            core["bounds"] = d["bounds"]
        return hashlib.sha256(json.dumps(core, sort_keys=True).encode()).hexdigest()[:32]

    @property
    def is_smooth(self) -> bool:
        """True when no sign/Abs/Heaviside/Piecewise/Max/Min is left in equations or outputs."""
        return not any(e.has(*NONSMOOTH_FUNCTIONS) for e in self.rhs + self.output_exprs)

    def __str__(self) -> str:
        lines = [f"model {self.name}"]
        for s in self.states:
            lines.append(f"  d/dt {s} = {self.equations[s]}")
        for k, v in self.outputs.items():
            lines.append(f"  {k} = {v}")
        return "\n".join(lines)

    def __repr__(self) -> str:
        return (
            f"Model(name={self.name!r}, states={[s.name for s in self.states]}, "
            f"parameters={[s.name for s in self.parameters]}, inputs={[s.name for s in self.inputs]}, "
            f"outputs={list(self.outputs)})"
        )

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Model):
            return NotImplemented
        return self._key() == other._key()

    def __hash__(self) -> int:
        return hash(self._key())

    def _key(self) -> tuple:
        return (
            self.name,
            self.states,
            self.parameters,
            self.inputs,
            self.unknown_inputs,
            self.known_constants,
            tuple(self.equations[s] for s in self.states),
            tuple(self.outputs.items()),
            self.known_initial_conditions,
            tuple(self.initial_condition_values.items()),
            tuple(self.bounds.items()),
        )


def _expr_text(e: sp.Basic) -> str:
    """Expression as text that :func:`obsnl.model.reading.parse.parse_expression` reads back exactly."""
    return sp.sstr(e, full_prec=True)
