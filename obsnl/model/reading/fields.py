"""The fields of a model, read once: what :class:`~obsnl.model.core.Model` keeps of what it was given.

:func:`read_fields` takes the raw values of a model's fields (strings, lists, tables or sympy objects, as
a model file or a caller wrote them) and returns each field read and checked: the names of every role as
declared symbols (one role per name, no two names that look alike), outputs, equations, initial values
and the switching order as expressions in those symbols only, the LaTeX names, numbers and definitions
as frozen tables. The size of the model is checked first, on the raw values, before any expression is
read. Any mistake raises :class:`~obsnl.errors.ModelError` (or ParseError for an expression) naming the
culprit and the fix.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import Any

import sympy as sp

from obsnl._text import plain_float
from obsnl.errors import ModelError
from obsnl.model.bounds.textsize import MAX_DIGITS, check_model_size
from obsnl.model.reading.latex import latex_clash, latex_problem
from obsnl.model.reading.names import check_distinct, check_name, check_text, close_name, name_list
from obsnl.model.reading.parse import make_symbol, parse_expression, quote, shorten
from obsnl.model.reading.unknown_inputs import check_unknown_input_derivatives

__all__ = ["ROLES", "ROLE_NAMES", "read_fields"]

#: The fields that declare names, in the order of a model file; a name has one of these roles only.
ROLES: tuple[str, ...] = ("states", "parameters", "inputs", "unknown_inputs", "known_constants")
#: Each role (and ``outputs``) in words, singular.
ROLE_NAMES: dict[str, str] = {
    "states": "state",
    "parameters": "parameter",
    "inputs": "input",
    "unknown_inputs": "unknown input",
    "known_constants": "known constant",
    "outputs": "output",
}
_TABLES = (
    "outputs",
    "initial_condition_values",
    "latex",
    "values",
    "guess",
    "definitions",
    "metadata",
    "intersample",
    "bounds",
)
#: How an input may behave between samples (:mod:`obsnl.estimation.intersample`).
INTERSAMPLE_KINDS = ("zoh", "linear", "bandlimited")


def _frozen(d: Mapping) -> Mapping:
    return MappingProxyType(dict(d))


def _key_name(key: Any) -> Any:
    return key.name if isinstance(key, sp.Symbol) else key


def read_fields(raw: Mapping[str, Any]) -> dict[str, Any]:
    """Every field of a model read and checked from its raw value.

    Parameters
    ----------
    raw : mapping of str to Any
        ``{field: value}`` for every field of :class:`~obsnl.model.core.Model`, as its constructor got them.

    Returns
    -------
    dict of str to Any
        ``{field: read value}``: names as sympy symbols, expressions parsed over the declared symbols,
        tables frozen (read-only mappings).

    Raises
    ------
    ModelError
        For the first mistake found, naming it and the fix.

    Examples
    --------
    >>> raw = {"name": " msd ", "description": None, "source": "", "states": ["x", "v"], "parameters": ["k"],
    ...        "inputs": (), "unknown_inputs": (), "known_constants": (), "outputs": {"y": "x"},
    ...        "equations": {"x": "v", "v": "-k*x"}, "known_initial_conditions": (),
    ...        "initial_condition_values": {}, "switching": (), "latex": {}, "values": {"k": 2},
    ...        "guess": {}, "definitions": {}, "metadata": {}, "unknown_input_derivatives": None,
    ...        "intersample": {}, "bounds": {}}
    >>> fields = read_fields(raw)
    >>> fields["name"], fields["states"], dict(fields["equations"]), dict(fields["values"])
    ('msd', (x, v), {x: v, v: -k*x}, {'k': 2.0})
    >>> read_fields({**raw, "known_constants": ["k"]})
    Traceback (most recent call last):
    ...
    obsnl.errors.ModelError: 'k' is declared both as a parameter and as a known constant; a name can have one role only
    """
    out: dict[str, Any] = _read_text(raw)
    for key in _TABLES:
        val = raw[key]
        if val is not None and not isinstance(val, Mapping):
            raise ModelError(
                f"'{key}' must be a table {{name = value}}, got {type(val).__name__} {shorten(repr(val), 40)}"
            )
    switching = raw["switching"]
    if switching is not None and not isinstance(switching, (str, sp.Basic, list, tuple)):
        raise ModelError(
            f"'switching' must be a list of expressions, got {type(switching).__name__} {shorten(repr(switching), 40)}"
        )

    # the size first, on the raw values: reading costs about 1 ms per expression (20 000 states took 13 s)
    check_model_size(out["name"], {r: raw[r] for r in ROLES}, raw["outputs"], raw["equations"])
    names, seen = _read_names(raw)
    symbols = {n: make_symbol(n) for n in seen}
    for role in ROLES:
        out[role] = tuple(symbols[n] for n in names[role])

    outs, reserved = _read_outputs(raw["outputs"], seen, symbols)
    out["outputs"] = _frozen(outs)
    check_distinct([*seen, *outs])  # Latin 'a' and Cyrillic 'а' would be two symbols shown as one
    out["equations"] = _frozen(_read_equations(raw["equations"], names["states"], seen, symbols, reserved))
    out.update(_read_initial_conditions(raw, names["states"], symbols))
    sw = switching or ()
    if isinstance(sw, (str, sp.Basic)):
        sw = [sw]
    out["switching"] = tuple(parse_expression(e, symbols, where="switching") for e in sw)
    out.update(_read_tables(raw, seen, outs, names["parameters"]))
    out["unknown_input_derivatives"] = check_unknown_input_derivatives(
        raw["unknown_input_derivatives"], allow_none=True
    )
    out["intersample"] = _read_intersample(raw.get("intersample"), names["inputs"])
    out["bounds"] = _read_bounds(raw.get("bounds"), seen, out)
    return out


#: The words a ``[bounds]`` entry may be instead of ``[lo, hi]``, and the interval each stands for.
BOUND_WORDS = {"positive": (0.0, float("inf")), "negative": (float("-inf"), 0.0)}


def _bound_end(value: Any, where: str) -> float:
    """One end of a bound: a number, or ``"inf"``/``"-inf"`` (JSON has no infinity)."""
    if isinstance(value, bool) or getattr(getattr(value, "dtype", None), "kind", "") == "b":
        raise ModelError(f'{where} is a boolean ({str(value).lower()}); write a number, "-inf" or "inf"')
    try:
        end = plain_float(value) if isinstance(value, str) else float(value)
    except (TypeError, ValueError, OverflowError):
        raise ModelError(f'{where} must be a number, "-inf" or "inf", got {quote(value)}') from None
    if end != end:
        raise ModelError(f'{where} is not a number ({quote(value)}); write a number, "-inf" or "inf"')
    return end


def _read_bounds(table: Any, seen: Mapping[str, str], read: Mapping[str, Any]) -> Mapping[str, tuple[float, float]]:
    """The ``[bounds]`` table: ``{name: (lo, hi)}`` for parameters and known constants, ``lo < hi``, each end a
    number or an infinity, or the words ``"positive"``/``"negative"``; ``[values]`` and ``[guess]`` must lie
    within (ends included)."""
    if not table:
        return _frozen({})
    if not isinstance(table, Mapping):
        raise ModelError(f"'bounds' must be a table {{name = [lo, hi]}}, got {type(table).__name__}")
    out: dict[str, tuple[float, float]] = {}
    for key, value in table.items():
        k = _key_name(key)
        if not isinstance(k, str) or k not in seen:
            raise ModelError(
                f"bounds.{shorten(str(k), 40)}: not a declared symbol"
                f"{close_name(str(k), list(seen))}; name a parameter or a known constant"
            )
        if seen[k] not in ("parameters", "known_constants"):
            raise ModelError(
                f"bounds.{k}: {k!r} is a {ROLE_NAMES[seen[k]]}; bounds are declared for parameters "
                f"and known constants only"
            )
        if isinstance(value, str) and value.strip().lower() in BOUND_WORDS:
            lo, hi = BOUND_WORDS[value.strip().lower()]
        elif isinstance(value, (list, tuple)) and len(value) == 2:
            lo, hi = _bound_end(value[0], f"bounds.{k}[0]"), _bound_end(value[1], f"bounds.{k}[1]")
        else:
            raise ModelError(
                f'bounds.{k} is {quote(value)}; write [lo, hi] (an end may be "-inf" or "inf"), '
                f'"positive" or "negative"'
            )
        if not lo < hi:
            raise ModelError(
                f"bounds.{k} is [{lo:g}, {hi:g}]: the lower end must be below the upper one (a value "
                f"known exactly is a known constant)"
            )
        for table_name in ("values", "guess"):
            v = read[table_name].get(k)
            if v is not None and not lo <= v <= hi:
                raise ModelError(
                    f"{table_name}.{k} = {v:g} is outside bounds.{k} = [{lo:g}, {hi:g}]; correct the "
                    f"value or the bounds"
                )
        out[k] = (lo, hi)
    return _frozen(out)


def _read_intersample(table: Any, inputs: Sequence[str]) -> Mapping[str, str]:
    """The ``[intersample]`` table: ``{input: kind}``, every key an input, every kind one of
    :data:`INTERSAMPLE_KINDS`."""
    if not table:
        return _frozen({})
    if not isinstance(table, Mapping):
        raise ModelError(f"'intersample' must be a table {{input: kind}}, got {type(table).__name__}")
    for k, v in table.items():
        if k not in inputs:
            raise ModelError(
                f"intersample.{k}: {quote(k, 40)} is not an input of this model"
                f"{close_name(str(k), list(inputs))}; name an input"
            )
        if v not in INTERSAMPLE_KINDS:
            raise ModelError(f"intersample.{k} is {quote(v)}; use one of {', '.join(INTERSAMPLE_KINDS)}")
    return _frozen(dict(table))


def _read_text(raw: Mapping[str, Any]) -> dict[str, str]:
    """The name (stripped, no control characters) and the free text of description and source."""
    name = raw["name"]
    if not isinstance(name, str) or not name.strip():
        raise ModelError("the model needs a non-empty 'name'")
    out = {"name": name.strip()}
    check_text(out["name"], "name")
    for key in ("description", "source"):
        val = raw[key]
        if val is None:
            val = ""
        if not isinstance(val, str):
            raise ModelError(f"'{key}' must be text, got {type(val).__name__}")
        val = val.replace("\r\n", "\n")  # a file written on Windows
        check_text(val, key, multiline=True)
        out[key] = val
    return out


def _read_names(raw: Mapping[str, Any]) -> tuple[dict[str, tuple[str, ...]], dict[str, str]]:
    """The names of each role, and each declared name's role (a name declared twice is refused)."""
    names = {role: name_list(raw[role], role) for role in ROLES}
    if not names["states"]:
        raise ModelError("the model has no states; declare at least one in 'states'")
    seen: dict[str, str] = {}
    for role in ROLES:
        for n in names[role]:
            if n in seen:
                if seen[n] == role:
                    raise ModelError(f"{ROLE_NAMES[role]} {n!r} is declared twice in '{role}'; remove the duplicate")
                raise ModelError(
                    f"{n!r} is declared both as a {ROLE_NAMES[seen[n]]} and as a {ROLE_NAMES[role]}; "
                    f"a name can have one role only"
                )
            seen[n] = role
    return names, seen


def _read_outputs(
    outputs_in: Any,
    seen: Mapping[str, str],
    symbols: Mapping[str, sp.Symbol],
) -> tuple[dict[str, sp.Expr], dict[str, str]]:
    """The outputs parsed, and the output names no right-hand side may use (name -> the refusal)."""
    if outputs_in is None:
        outputs_in = {}
    if not isinstance(outputs_in, Mapping):
        raise ModelError("'outputs' must map output names to expressions, e.g. {y = \"x1\"}")
    reserved: dict[str, str] = {}
    for oname in outputs_in:
        oname_s = _key_name(oname)
        if not isinstance(oname_s, str):
            raise ModelError(f"output names must be strings, got {oname!r}")
        check_name(oname_s, "outputs")
        if oname_s in seen:
            raise ModelError(
                f"output {oname_s!r} has the name of a {ROLE_NAMES[seen[oname_s]]}; "
                f"give the output its own name (e.g. 'y_{oname_s}')"
            )
        reserved[oname_s] = (
            f"output {oname_s!r} appears on a right-hand side; outputs may appear only on the left-hand "
            f"side of their own definition (use the expression it stands for)"
        )
    outs = {
        _key_name(oname): parse_expression(expr, symbols, where=f"output {_key_name(oname)}", reserved=reserved)
        for oname, expr in outputs_in.items()
    }
    return outs, reserved


def _read_equations(
    eqs_in: Any,
    state_names: tuple[str, ...],
    seen: Mapping[str, str],
    symbols: Mapping[str, sp.Symbol],
    reserved: Mapping[str, str],
) -> dict[sp.Symbol, sp.Expr]:
    """One right-hand side per state, parsed, in state order."""
    if not isinstance(eqs_in, Mapping):
        raise ModelError("'equations' must map each state to its right-hand side, e.g. {x = \"v\"}")
    eqs_by_name: dict[str, Any] = {}
    for k, v in eqs_in.items():
        kn = _key_name(k)
        if not isinstance(kn, str):
            raise ModelError(f"equation keys must be state names, got {k!r}")
        if kn in eqs_by_name:
            raise ModelError(f"two equations for state {kn!r}; keep one")
        eqs_by_name[kn] = v
    for kn in eqs_by_name:
        if kn not in state_names:
            if kn in seen:
                raise ModelError(
                    f"there is an equation for {kn!r}, which is a {ROLE_NAMES[seen[kn]]}, not a state; "
                    f"declare it in 'states' or remove the equation"
                )
            raise ModelError(
                f"equation for undeclared state {quote(kn, 40)}{close_name(kn, state_names)}; declare it in "
                f"'states' or remove the equation"
            )
    for sn in state_names:
        if sn not in eqs_by_name:
            raise ModelError(f'state {sn!r} has no equation; add equations.{sn} = "..." (its time derivative)')
    return {
        symbols[sn]: parse_expression(eqs_by_name[sn], symbols, where=f"equation of {sn}", reserved=reserved)
        for sn in state_names
    }


def _read_initial_conditions(
    raw: Mapping[str, Any], state_names: tuple[str, ...], symbols: Mapping[str, sp.Symbol]
) -> dict[str, Any]:
    """The states with a known initial value, and the values given (over the symbols that are not states)."""
    kic = name_list(raw["known_initial_conditions"], "known_initial_conditions")
    for n in kic:
        if n not in state_names:
            raise ModelError(f"known initial condition {quote(n, 40)} is not a state; list states only")
    icv_in = raw["initial_condition_values"] or {}
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
    return {"known_initial_conditions": tuple(symbols[n] for n in kic), "initial_condition_values": _frozen(icv)}


def _read_tables(
    raw: Mapping[str, Any], seen: Mapping[str, str], outs: Mapping[str, sp.Expr], parameters: tuple[str, ...]
) -> dict[str, Mapping]:
    """The LaTeX names, the numbers (values, guesses), the definitions and the metadata, frozen."""
    latex = dict(raw["latex"] or {})
    for k, v in latex.items():
        if k not in seen and k not in outs:
            raise ModelError(
                f"latex name given for undeclared symbol {quote(k, 40)}{close_name(k, list(seen) + list(outs))}"
            )
        problem = latex_problem(v) if isinstance(v, str) else "must be a string"
        if problem:
            raise ModelError(f"latex.{k}: {problem}")
    problem = latex_clash(latex, [*seen, *outs])
    if problem:
        raise ModelError(problem)
    out: dict[str, Mapping] = {"latex": _frozen(latex)}
    for key in ("values", "guess"):
        table = raw[key] or {}
        if not isinstance(table, Mapping):
            raise ModelError(f"'{key}' must be a table of numbers {{name: value}}, got {type(table).__name__}")
        numbers: dict[str, float] = {}
        for k, v in dict(table).items():
            if k not in seen:
                raise ModelError(
                    f"{key} gives a number for undeclared symbol {quote(k, 40)}{close_name(k, list(seen))}"
                )
            if key == "guess" and k not in parameters:
                raise ModelError(f"guess.{k}: only parameters have guesses; remove it")
            if isinstance(v, bool) or getattr(getattr(v, "dtype", None), "kind", "") == "b":  # float(True) is 1.0
                raise ModelError(
                    f"{key}.{k} is a boolean ({str(v).lower()}), not a number; write a number (e.g. {k} = 1.0)"
                )
            if isinstance(v, int) and abs(v) >= 10**MAX_DIGITS:  # as a literal in an expression (and unprintable)
                raise ModelError(
                    f"{key}.{k} is a number with more than {MAX_DIGITS} digits; write it with an "
                    f"exponent (e.g. 1.5e20) or scale the model"
                )
            try:
                fv = plain_float(v) if isinstance(v, str) else float(v)  # a quoted "1_0" is not 10
            except (TypeError, ValueError, OverflowError):
                raise ModelError(f"{key}.{k} must be a number, got {quote(v)}") from None
            if fv != fv or fv in (float("inf"), float("-inf")):
                raise ModelError(f"{key}.{k} is not finite ({quote(v)})")
            numbers[k] = fv
        out[key] = _frozen(numbers)
    defs: dict[str, str] = {}
    for k, v in dict(raw["definitions"] or {}).items():
        if k not in seen:
            raise ModelError(f"definitions gives {quote(k, 40)}, which is not declared in this model")
        if isinstance(v, sp.Basic):
            v = str(v)
        if not isinstance(v, str):
            raise ModelError(f"definitions.{k} must be an expression string")
        defs[k] = v
    out["definitions"] = _frozen(defs)
    out["metadata"] = _frozen(dict(raw["metadata"] or {}))
    return out
