"""Expressions -> sympy objects, restricted to declared symbols.

Every name in an expression must be declared in the model; sympy's built-in names
(``E``, ``N``, ``S``, ``I``, ``Q``, ``C``, ``beta``, ``gamma``, ...) parse as plain symbols
when declared and are errors when not. Only the functions in :data:`ALLOWED_FUNCTIONS`
are accepted. Float literals are read as exact rationals (``0.1`` -> ``1/10``) so that the
exact engines never see a float.
"""

from __future__ import annotations

import difflib
import keyword
import tokenize
from collections.abc import Iterable, Mapping
from io import StringIO
from typing import Any

import sympy as sp
from sympy.parsing.sympy_parser import (
    convert_xor,
    parse_expr,
    rationalize,
    standard_transformations,
)

from obsnl.errors import ParseError

__all__ = ["ALLOWED_FUNCTIONS", "make_symbol", "parse_expression"]

#: Functions a model expression may use, by the name written in the file.
ALLOWED_FUNCTIONS: dict[str, Any] = {
    "sign": sp.sign,
    "sgn": sp.sign,
    "Abs": sp.Abs,
    "abs": sp.Abs,
    "Heaviside": sp.Heaviside,
    "Piecewise": sp.Piecewise,
    "Max": sp.Max,
    "Min": sp.Min,
    "exp": sp.exp,
    "log": sp.log,
    "sqrt": sp.sqrt,
    "sin": sp.sin,
    "cos": sp.cos,
    "tan": sp.tan,
    "tanh": sp.tanh,
    "sinh": sp.sinh,
    "cosh": sp.cosh,
    "atan": sp.atan,
}

#: Constants an expression may use without declaring them.
_CONSTANTS: dict[str, Any] = {"pi": sp.pi}

#: Logical helpers for Piecewise conditions.
_LOGIC: dict[str, Any] = {"And": sp.And, "Or": sp.Or, "Not": sp.Not, "Eq": sp.Eq, "Ne": sp.Ne, "True": sp.true, "False": sp.false}

# The names parse_expr's generated code needs; nothing else from sympy is visible.
_PARSER_GLOBALS: dict[str, Any] = {
    "__builtins__": {},
    "Integer": sp.Integer,
    "Float": sp.Float,
    "Rational": sp.Rational,
    "Symbol": sp.Symbol,
    "Function": sp.Function,
}

_TRANSFORMS = standard_transformations + (convert_xor, rationalize)

_MAX_EXPRESSION_LENGTH = 20_000


def make_symbol(name: str) -> sp.Symbol:
    """The canonical obsnl symbol for ``name`` (real-valued, as every mechanical quantity)."""
    return sp.Symbol(name, real=True)


def _suggest(name: str, candidates: Iterable[str]) -> str:
    close = difflib.get_close_matches(name, list(candidates), n=2, cutoff=0.6)
    if close:
        return " (did you mean " + " or ".join(repr(c) for c in close) + "?)"
    return ""


def _check_names_token_level(text: str, where: str) -> None:
    """Reject Python keywords used as names and dunder tricks before anything is evaluated."""
    try:
        tokens = list(tokenize.generate_tokens(StringIO(text).readline))
    except (tokenize.TokenError, IndentationError, SyntaxError) as exc:
        raise ParseError(f"{where}: syntax error in {text!r} ({exc}); check brackets and operators") from None
    for tok in tokens:
        if tok.type == tokenize.NAME:
            if keyword.iskeyword(tok.string) and tok.string not in ("True", "False"):
                raise ParseError(
                    f"{where}: {tok.string!r} in {text!r} is a Python keyword and cannot be a name; "
                    f"rename it (e.g. {tok.string + '_'!r})"
                )
            if tok.string.startswith("__"):
                raise ParseError(f"{where}: the name {tok.string!r} in {text!r} is not allowed; rename it")
        elif tok.type == tokenize.OP and tok.string in ("=", ":=", ";", "[", "]", "{", "}", "@", "."):
            raise ParseError(f"{where}: unexpected {tok.string!r} in {text!r}; write a single sympy expression")
        elif tok.type == tokenize.STRING:
            raise ParseError(f"{where}: string literal in {text!r}; write a sympy expression, not a string")


def parse_expression(
    text: str | int | float | sp.Basic,
    symbols: Mapping[str, sp.Symbol],
    *,
    where: str = "expression",
    allow_relations: bool = False,
    reserved: Mapping[str, str] | None = None,
) -> sp.Expr:
    """Parse one expression over the declared ``symbols``.

    Parameters
    ----------
    text
        Expression in sympy syntax (``^`` is accepted for powers), a number, or a sympy
        expression (whose symbols are matched to the declared ones by name).
    symbols
        Declared names -> symbols. Every name used must be one of them.
    where
        Where the expression comes from, for error messages (e.g. ``"equation of x2"``).
    allow_relations
        Accept a relation such as ``x > 0`` (for guards).
    reserved
        Names that are not allowed here, each with the message to give (e.g. output names
        used on a right-hand side).

    Returns
    -------
    sympy.Expr
        The expression with obsnl's canonical symbols.

    Raises
    ------
    ParseError
        Syntax error (the expression is quoted), undeclared or misspelled name (with a
        suggestion), unsupported function.

    Examples
    --------
    >>> from obsnl.model.parse import make_symbol, parse_expression
    >>> syms = {n: make_symbol(n) for n in ("E", "N", "x")}
    >>> parse_expression("E*x^N + 0.5", syms)
    E*x**N + 1/2
    """
    if isinstance(text, bool):
        raise ParseError(f"{where}: got a boolean {text!r}; write an expression")
    if isinstance(text, (int, float)):
        if isinstance(text, float) and not (text == text and abs(text) != float("inf")):
            raise ParseError(f"{where}: the number {text!r} is not finite")
        return sp.nsimplify(text, rational=True) if isinstance(text, float) else sp.Integer(text)
    if isinstance(text, sp.Basic):
        return _adopt_sympy(text, symbols, where=where, allow_relations=allow_relations, reserved=reserved)
    if not isinstance(text, str):
        raise ParseError(f"{where}: expected an expression string, got {type(text).__name__}")
    stripped = " ".join(text.split())  # a line break inside an expression is plain white space
    if not stripped:
        raise ParseError(f"{where}: the expression is empty")
    if len(stripped) > _MAX_EXPRESSION_LENGTH:
        raise ParseError(f"{where}: the expression is longer than {_MAX_EXPRESSION_LENGTH} characters")
    _check_names_token_level(stripped, where)
    local: dict[str, Any] = {}
    local.update(ALLOWED_FUNCTIONS)
    local.update(_CONSTANTS)
    local.update(_LOGIC)
    local.update(symbols)  # declared names win over function and constant names
    try:
        expr = parse_expr(stripped, local_dict=local, global_dict=dict(_PARSER_GLOBALS), transformations=_TRANSFORMS)
    except ParseError:
        raise
    except (SyntaxError, tokenize.TokenError):
        raise ParseError(f"{where}: syntax error in {stripped!r}; check brackets and operators") from None
    except Exception as exc:  # noqa: BLE001 - the door: anything sympy raises becomes our error
        raise ParseError(f"{where}: cannot read {stripped!r}: {type(exc).__name__}: {exc}") from None
    return _adopt_sympy(expr, symbols, where=where, allow_relations=allow_relations, text=stripped, reserved=reserved)


def _adopt_sympy(
    expr: Any,
    symbols: Mapping[str, sp.Symbol],
    *,
    where: str,
    allow_relations: bool,
    text: str | None = None,
    reserved: Mapping[str, str] | None = None,
) -> sp.Expr:

    def shown() -> str:  # built only when an error is raised: printing every expression is costly
        return text if text is not None else str(expr)

    if not isinstance(expr, sp.Basic):
        try:
            expr = sp.sympify(expr, strict=True)
        except (sp.SympifyError, TypeError, ValueError):
            raise ParseError(f"{where}: {shown()!r} is not an expression") from None
    if isinstance(expr, sp.logic.boolalg.BooleanAtom) or isinstance(expr, (sp.Rel, sp.logic.boolalg.BooleanFunction)):
        if not allow_relations:
            raise ParseError(f"{where}: {shown()!r} is a condition, not an expression")
    elif not isinstance(expr, sp.Expr):
        raise ParseError(f"{where}: {shown()!r} is not a scalar expression ({type(expr).__name__})")
    # Functions: only the allowed ones.
    allowed_classes = tuple({type(f) if not isinstance(f, type) else f for f in ALLOWED_FUNCTIONS.values()})
    for f in expr.atoms(sp.Function):
        if isinstance(f, sp.core.function.AppliedUndef):
            name = type(f).__name__
            raise ParseError(
                f"{where}: unknown function {name!r} in {shown()!r}{_suggest(name, ALLOWED_FUNCTIONS)}; "
                f"supported functions are {', '.join(sorted(set(ALLOWED_FUNCTIONS)))}"
            )
        if not isinstance(f, allowed_classes):
            raise ParseError(
                f"{where}: the function {type(f).__name__!r} in {shown()!r} is not supported; "
                f"supported functions are {', '.join(sorted(set(ALLOWED_FUNCTIONS)))}"
            )
    for bad in (sp.zoo, sp.nan, sp.oo, -sp.oo):
        if expr.has(bad):
            raise ParseError(f"{where}: {shown()!r} evaluates to {bad} (a division by zero or an infinity)")
    if expr.has(sp.I):
        raise ParseError(f"{where}: {shown()!r} contains the imaginary unit; declare a symbol 'I' if you meant a variable")
    # Symbols: declared ones only, matched by name.
    replace: dict[sp.Symbol, sp.Symbol] = {}
    for s in expr.free_symbols:
        name = s.name
        if reserved and name in reserved:
            raise ParseError(f"{where}: {reserved[name]}")
        if name not in symbols:
            raise ParseError(
                f"{where}: undeclared symbol {name!r} in {shown()!r}{_suggest(name, symbols)}; "
                f"declare it as a state, parameter, input or known constant"
            )
        if s is not symbols[name]:
            replace[s] = symbols[name]
    if replace:
        expr = expr.xreplace(replace)
    return expr
