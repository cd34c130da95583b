"""The frozen model value every analysis and estimator starts from.

A :class:`Model` is an explicit ODE ``x' = f(x, theta, u, w)``, ``y = h(x, theta, u, w)``
with declared states ``x``, unknown constant parameters ``theta``, known inputs ``u``,
unknown inputs ``w`` and known constants. It is validated once, when built; afterwards it
cannot change: transformations return a new model.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import sympy as sp

from obsnl.errors import ModelError, ParseError
from obsnl.model.reading.unknown_inputs import check_unknown_input_derivatives
from obsnl.model.reading.latex import latex_clash, latex_problem
from obsnl.model.reading.names import check_distinct, check_name as _check_identifier, check_text as _check_text
from obsnl.model.reading.names import close_name as _close, name_list as _name_list
from obsnl.model.reading.parse import make_symbol, parse_expression, quote, shorten
from obsnl.model.bounds.textsize import check_model_size

__all__ = ["Model", "NONSMOOTH_FUNCTIONS"]

#: sympy classes that make a vector field non-smooth (handled by :func:`obsnl.model.split_branches`).
NONSMOOTH_FUNCTIONS: tuple[type, ...] = (sp.sign, sp.Abs, sp.Heaviside, sp.Piecewise, sp.Max, sp.Min)

#: Keys of a model file/dict, in the order they are written.
MODEL_KEYS: tuple[str, ...] = (
    "name", "description", "source", "states", "parameters", "inputs", "unknown_inputs",
    "known_constants", "outputs", "equations", "known_initial_conditions",
    "initial_condition_values", "switching", "latex", "values", "guess", "definitions",
    "unknown_input_derivatives",
)
#: Keys kept as metadata without interpretation (the published answers of a peer case, notes).
METADATA_KEYS: tuple[str, ...] = (
    "answer_source", "answer_kind", "expected", "expected_global", "expected_identifiable_functions",
    "expected_unknown_inputs", "notes", "metadata", "citation", "units",
)

_ROLES = ("states", "parameters", "inputs", "unknown_inputs", "known_constants")
_ROLE_NAMES = {
    "states": "state", "parameters": "parameter", "inputs": "input",
    "unknown_inputs": "unknown input", "known_constants": "known constant", "outputs": "output",
}


def _frozen(d: Mapping) -> Mapping:
    return MappingProxyType(dict(d))


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
    metadata : mapping of str to Any
        Anything else a file carried (published answers of a peer case, notes).
    unknown_input_derivatives : int or str or None
        What the unknown inputs are assumed to be: ``"arbitrary"`` (any analytic function of time) or
        ``K``, a polynomial in t with K non-zero derivatives (STRIKE-GOLDD's ``nnzDerW``; 0 = a
        constant). None (not stated): the analyses assume ``"arbitrary"``.

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
    metadata: Mapping[str, Any] = field(default_factory=dict)
    unknown_input_derivatives: int | str | None = None

    # ------------------------------------------------------------------ validation
    def __post_init__(self) -> None:
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731 - frozen dataclass
        if not isinstance(self.name, str) or not self.name.strip():
            raise ModelError("the model needs a non-empty 'name'")
        set_("name", self.name.strip())
        _check_text(self.name, "name")
        for key in ("description", "source"):
            val = getattr(self, key)
            if val is None:
                val = ""
            if not isinstance(val, str):
                raise ModelError(f"'{key}' must be text, got {type(val).__name__}")
            val = val.replace("\r\n", "\n")  # a file written on Windows
            _check_text(val, key, multiline=True)
            set_(key, val)
        for key in ("outputs", "initial_condition_values", "latex", "values", "guess", "definitions", "metadata"):
            val = getattr(self, key)
            if val is not None and not isinstance(val, Mapping):
                raise ModelError(f"'{key}' must be a table {{name = value}}, got {type(val).__name__} "
                                 f"{shorten(repr(val), 40)}")
        if self.switching is not None and not isinstance(self.switching, (str, sp.Basic, list, tuple)):
            raise ModelError(f"'switching' must be a list of expressions, got {type(self.switching).__name__} "
                             f"{shorten(repr(self.switching), 40)}")

        # the size first, on the raw values: reading costs about 1 ms per expression (20 000 states took 13 s)
        check_model_size(self.name, {r: getattr(self, r) for r in _ROLES}, self.outputs, self.equations)
        names: dict[str, tuple[str, ...]] = {role: _name_list(getattr(self, role), role) for role in _ROLES}
        if not names["states"]:
            raise ModelError("the model has no states; declare at least one in 'states'")
        seen: dict[str, str] = {}
        for role in _ROLES:
            for n in names[role]:
                if n in seen:
                    if seen[n] == role:
                        raise ModelError(f"{_ROLE_NAMES[role]} {n!r} is declared twice in '{role}'; remove the duplicate")
                    raise ModelError(
                        f"{n!r} is declared both as a {_ROLE_NAMES[seen[n]]} and as a {_ROLE_NAMES[role]}; "
                        f"a name can have one role only"
                    )
                seen[n] = role
        symbols = {n: make_symbol(n) for n in seen}
        for role in _ROLES:
            set_(role, tuple(symbols[n] for n in names[role]))

        # outputs
        outputs_in = self.outputs
        if outputs_in is None:
            outputs_in = {}
        if not isinstance(outputs_in, Mapping):
            raise ModelError("'outputs' must map output names to expressions, e.g. {y = \"x1\"}")
        reserved: dict[str, str] = {}
        for oname in outputs_in:
            oname_s = oname.name if isinstance(oname, sp.Symbol) else oname
            if not isinstance(oname_s, str):
                raise ModelError(f"output names must be strings, got {oname!r}")
            _check_identifier(oname_s, "outputs")
            if oname_s in seen:
                raise ModelError(
                    f"output {oname_s!r} has the name of a {_ROLE_NAMES[seen[oname_s]]}; "
                    f"give the output its own name (e.g. 'y_{oname_s}')"
                )
            reserved[oname_s] = (
                f"output {oname_s!r} appears on a right-hand side; outputs may appear only on the left-hand "
                f"side of their own definition (use the expression it stands for)"
            )
        outs: dict[str, sp.Expr] = {}
        for oname, expr in outputs_in.items():
            oname_s = oname.name if isinstance(oname, sp.Symbol) else oname
            outs[oname_s] = parse_expression(expr, symbols, where=f"output {oname_s}", reserved=reserved)
        set_("outputs", _frozen(outs))
        check_distinct([*seen, *outs])  # Latin 'a' and Cyrillic 'а' would be two symbols shown as one

        # equations
        eqs_in = self.equations
        if not isinstance(eqs_in, Mapping):
            raise ModelError("'equations' must map each state to its right-hand side, e.g. {x = \"v\"}")
        eqs_by_name: dict[str, Any] = {}
        for k, v in eqs_in.items():
            kn = k.name if isinstance(k, sp.Symbol) else k
            if not isinstance(kn, str):
                raise ModelError(f"equation keys must be state names, got {k!r}")
            if kn in eqs_by_name:
                raise ModelError(f"two equations for state {kn!r}; keep one")
            eqs_by_name[kn] = v
        state_names = names["states"]
        for kn in eqs_by_name:
            if kn not in state_names:
                if kn in seen:
                    raise ModelError(
                        f"there is an equation for {kn!r}, which is a {_ROLE_NAMES[seen[kn]]}, not a state; "
                        f"declare it in 'states' or remove the equation"
                    )
                raise ModelError(
                    f"equation for undeclared state {quote(kn, 40)}{_close(kn, state_names)}; declare it in 'states' "
                    f"or remove the equation"
                )
        for sn in state_names:
            if sn not in eqs_by_name:
                raise ModelError(f"state {sn!r} has no equation; add equations.{sn} = \"...\" (its time derivative)")
        eqs = {
            symbols[sn]: parse_expression(eqs_by_name[sn], symbols, where=f"equation of {sn}", reserved=reserved)
            for sn in state_names
        }
        set_("equations", _frozen(eqs))

        # initial conditions
        kic = _name_list(self.known_initial_conditions, "known_initial_conditions")
        for n in kic:
            if n not in state_names:
                raise ModelError(f"known initial condition {quote(n, 40)} is not a state; list states only")
        set_("known_initial_conditions", tuple(symbols[n] for n in kic))
        icv_in = self.initial_condition_values or {}
        if not isinstance(icv_in, Mapping):
            raise ModelError("'initial_condition_values' must map states to values")
        not_states = {n: s for n, s in symbols.items() if n not in state_names}
        icv: dict[sp.Symbol, sp.Expr] = {}
        for k, v in icv_in.items():
            kn = k.name if isinstance(k, sp.Symbol) else str(k)
            if kn not in kic:
                raise ModelError(
                    f"initial_condition_values gives {quote(kn, 40)}, which is not in known_initial_conditions; add it "
                    f"there"
                )
            icv[symbols[kn]] = parse_expression(v, not_states, where=f"initial value of {kn}")
        set_("initial_condition_values", _frozen(icv))

        # switching order
        sw = self.switching or ()
        if isinstance(sw, (str, sp.Basic)):
            sw = [sw]
        set_("switching", tuple(parse_expression(e, symbols, where="switching") for e in sw))

        # latex, values, definitions, metadata
        latex = dict(self.latex or {})
        for k, v in latex.items():
            if k not in seen and k not in outs:
                raise ModelError(f"latex name given for undeclared symbol {quote(k, 40)}"
                                 f"{_close(k, list(seen) + list(outs))}")
            problem = latex_problem(v) if isinstance(v, str) else "must be a string"
            if problem:
                raise ModelError(f"latex.{k}: {problem}")
        problem = latex_clash(latex, [*seen, *outs])
        if problem:
            raise ModelError(problem)
        set_("latex", _frozen(latex))
        for key in ("values", "guess"):
            table = getattr(self, key) or {}
            if not isinstance(table, Mapping):
                raise ModelError(f"'{key}' must be a table of numbers {{name: value}}, got {type(table).__name__}")
            numbers: dict[str, float] = {}
            for k, v in dict(table).items():
                if k not in seen:
                    raise ModelError(f"{key} gives a number for undeclared symbol {quote(k, 40)}{_close(k, list(seen))}")
                if key == "guess" and k not in {s.name for s in self.parameters}:
                    raise ModelError(f"guess.{k}: only parameters have guesses; remove it")
                try:
                    fv = float(v)
                except (TypeError, ValueError, OverflowError):
                    raise ModelError(f"{key}.{k} must be a number, got {quote(v)}") from None
                if fv != fv or fv in (float("inf"), float("-inf")):
                    raise ModelError(f"{key}.{k} is not finite ({quote(v)})")
                numbers[k] = fv
            set_(key, _frozen(numbers))
        defs: dict[str, str] = {}
        for k, v in dict(self.definitions or {}).items():
            if k not in seen:
                raise ModelError(f"definitions gives {quote(k, 40)}, which is not declared in this model")
            if isinstance(v, sp.Basic):
                v = str(v)
            if not isinstance(v, str):
                raise ModelError(f"definitions.{k} must be an expression string")
            defs[k] = v
        set_("definitions", _frozen(defs))
        set_("metadata", _frozen(dict(self.metadata or {})))
        set_("unknown_input_derivatives", check_unknown_input_derivatives(self.unknown_input_derivatives,
                                                                          allow_none=True))

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Model:
        """Build a model from the keys of a model file (see :func:`obsnl.read_model`).

        Unknown keys are errors (a misspelled ``ouputs`` would otherwise be lost).
        """
        if not isinstance(data, Mapping):
            raise ParseError("a model must be a table/object of keys")
        unknown = [k for k in data if k not in MODEL_KEYS and k not in METADATA_KEYS]
        if unknown:
            k = unknown[0]
            raise ParseError(f"unknown key {quote(k, 40)}{_close(k, MODEL_KEYS)}; model keys are {', '.join(MODEL_KEYS)}")
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
        for role in _ROLES:
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
        return d

    def replace(self, **changes: Any) -> Model:
        """A new model with some fields changed (validated again)."""
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
        for role in _ROLES:
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
        for role in _ROLES:
            if any(s.name == name for s in getattr(self, role)):
                return _ROLE_NAMES[role]
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
        core = {k: d.get(k) for k in ("states", "parameters", "inputs", "unknown_inputs", "known_constants",
                                      "outputs", "equations", "known_initial_conditions",
                                      "initial_condition_values")}
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
            self.name, self.states, self.parameters, self.inputs, self.unknown_inputs, self.known_constants,
            tuple(self.equations[s] for s in self.states), tuple(self.outputs.items()),
            self.known_initial_conditions, tuple(self.initial_condition_values.items()),
        )


def _expr_text(e: sp.Basic) -> str:
    """Expression as text that :func:`obsnl.model.reading.parse.parse_expression` reads back exactly."""
    return sp.sstr(e, full_prec=True)
