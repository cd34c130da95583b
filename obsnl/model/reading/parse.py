"""Expressions -> sympy objects, restricted to declared symbols.

Every name in an expression must be declared in the model; sympy's built-in names
(``E``, ``N``, ``S``, ``I``, ``Q``, ``C``, ``beta``, ``gamma``, ...) parse as plain symbols
when declared and are errors when not. Only the functions in :data:`ALLOWED_FUNCTIONS`
are accepted. Float literals are read as exact rationals (``0.1`` -> ``1/10``) so that the
exact engines never see a float.
"""

from __future__ import annotations

import keyword
import tokenize
import unicodedata
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
from obsnl.model.bounds.budget import check_time
from obsnl.model.bounds.regroup import regroup_sums
from obsnl.model.bounds.textsize import (
    MAX_DIGITS,
    MAX_LENGTH,
    check_expression_size,
    quote,
    shorten,
)
from obsnl.model.bounds.work import MAX_EXACT_DIGITS, exact_digits

__all__ = [
    "ALLOWED_FUNCTIONS",
    "FUNCTION_NAMES",
    "PARSER_NAMES",
    "make_symbol",
    "parse_expression",
    "check_expression_size",
    "nfkc_problem",
    "shorten",
    "quote",
]  # the last three are defined in obsnl.model.bounds.textsize

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
_LOGIC: dict[str, Any] = {
    "And": sp.And,
    "Or": sp.Or,
    "Not": sp.Not,
    "Eq": sp.Eq,
    "Ne": sp.Ne,
    "True": sp.true,
    "False": sp.false,
}

#: Every name an expression can call (``exp(x)``, ``Eq(v, 0)`` in a Piecewise condition): a declared symbol of
#: that name would shadow the function, and ``exp(...)`` would then call a symbol.
FUNCTION_NAMES: frozenset[str] = frozenset(ALLOWED_FUNCTIONS) | frozenset(
    k for k, v in _LOGIC.items() if isinstance(v, type)
)

# The names parse_expr's generated code needs; nothing else from sympy is visible.
_PARSER_GLOBALS: dict[str, Any] = {
    "__builtins__": {},
    "Integer": sp.Integer,
    "Float": sp.Float,
    "Rational": sp.Rational,
    "Symbol": sp.Symbol,
    "Function": sp.Function,
}

#: Names the parser's generated code calls (``Integer(2)``): a symbol of that name would replace the class.
PARSER_NAMES: frozenset[str] = frozenset(k for k in _PARSER_GLOBALS if not k.startswith("__"))

_TRANSFORMS = standard_transformations + (convert_xor, rationalize)


def nfkc_problem(name: str) -> str | None:
    """Why ``name`` cannot be a name, if its NFKC form differs from it (Python reads identifiers in NFKC:
    a fullwidth ``ｘ`` is ``x``, ``ℓ`` is ``l``, the micro sign ``µ`` is the Greek ``μ``), else None.

    Examples
    --------
    >>> nfkc_problem("ｘ")
    "'ｘ' is read as 'x' (Unicode NFKC); write 'x'"
    >>> nfkc_problem("x") is None
    True
    """
    try:
        norm = unicodedata.normalize("NFKC", name)
    except (TypeError, ValueError):
        return f"{name!r} is not text"
    if norm != name:
        return f"{name!r} is read as {norm!r} (Unicode NFKC); write {norm!r}"
    return None


def make_symbol(name: str) -> sp.Symbol:
    """The canonical obsnl symbol for ``name`` (real-valued, as every mechanical quantity)."""
    return sp.Symbol(name, real=True)


def _suggest(name: str, candidates: Iterable[str]) -> str:
    import difflib  # only a misspelt name needs it

    close = difflib.get_close_matches(name, list(candidates), n=2, cutoff=0.6)
    if close:
        return " (did you mean " + " or ".join(repr(c) for c in close) + "?)"
    return ""


def _check_names_token_level(text: str, where: str) -> set[str]:
    """Reject Python keywords used as names and dunder tricks before anything is evaluated; the names used."""
    try:
        tokens = list(tokenize.generate_tokens(StringIO(text).readline))
    except (tokenize.TokenError, IndentationError, SyntaxError) as exc:
        raise ParseError(f"{where}: syntax error in {shorten(text)!r} ({exc}); check brackets and operators") from None
    names: set[str] = set()
    for tok in tokens:
        if tok.type == tokenize.COMMENT:
            raise ParseError(f"{where}: '#' in {shorten(text)!r} would cut the expression; remove it")
        if tok.type == tokenize.NUMBER and sum(c.isdigit() for c in tok.string) > MAX_DIGITS:
            raise ParseError(
                f"{where}: a number with more than {MAX_DIGITS} digits in {shorten(text)!r}; "
                f"write it with an exponent or scale the model"
            )
        if tok.type == tokenize.NUMBER and "e" in tok.string.lower() and not tok.string.lower().startswith("0x"):
            mantissa, _, exponent = tok.string.lower().rstrip("j").partition("e")
            if exponent.lstrip("+-").replace("_", "").isdigit() and abs(int(exponent.replace("_", ""))) > MAX_DIGITS:
                raise ParseError(
                    f"{where}: the number {shorten(tok.string, 30)!r} is beyond 1e{MAX_DIGITS} or below "
                    f"1e-{MAX_DIGITS}; rescale the model"
                )
        if tok.type == tokenize.NAME:
            names.add(tok.string)
            problem = nfkc_problem(tok.string)
            if problem:
                raise ParseError(f"{where}: {problem} (in {shorten(text)!r})")
            if keyword.iskeyword(tok.string) and tok.string not in ("True", "False"):
                raise ParseError(
                    f"{where}: {tok.string!r} in {shorten(text)!r} is a Python keyword and cannot be a name; "
                    f"rename it (e.g. {tok.string + '_'!r})"
                )
            if tok.string.startswith("__"):
                raise ParseError(f"{where}: the name {tok.string!r} in {shorten(text)!r} is not allowed; rename it")
        elif tok.type == tokenize.OP and tok.string in ("=", ":=", ";", "[", "]", "{", "}", "@", "."):
            raise ParseError(
                f"{where}: unexpected {tok.string!r} in {shorten(text)!r}; write a single sympy expression"
            )
        elif tok.type == tokenize.STRING:
            raise ParseError(f"{where}: string literal in {shorten(text)!r}; write a sympy expression, not a string")
    return names


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
    text : str or int or float or sympy.Basic
        Expression in sympy syntax (``^`` is accepted for powers), a number, or a sympy
        expression (whose symbols are matched to the declared ones by name).
    symbols : mapping of str to sympy.Symbol
        Declared names -> symbols. Every name used must be one of them.
    where : str
        Where the expression comes from, for error messages (e.g. ``"equation of x2"``).
    allow_relations : bool
        Accept a relation such as ``x > 0`` (for guards).
    reserved : mapping of str to str or None
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
    >>> from obsnl.model.reading.parse import make_symbol, parse_expression
    >>> syms = {n: make_symbol(n) for n in ("E", "N", "x")}
    >>> parse_expression("E*x^N + 0.5", syms)
    E*x**N + 1/2
    """
    if isinstance(text, bool):
        raise ParseError(f"{where}: got a boolean {text!r}; write an expression")
    if isinstance(text, (int, float)):
        if isinstance(text, float) and not (text == text and abs(text) != float("inf")):
            raise ParseError(f"{where}: the number {text!r} is not finite")
        if isinstance(text, int) and text.bit_length() > MAX_DIGITS * 3.33:
            raise ParseError(
                f"{where}: a number with more than {MAX_DIGITS} digits; write it with an exponent or scale the model"
            )
        return sp.nsimplify(text, rational=True) if isinstance(text, float) else sp.Integer(text)
    if isinstance(text, sp.Basic):
        return _adopt_sympy(text, symbols, where=where, allow_relations=allow_relations, reserved=reserved)
    if not isinstance(text, str):
        raise ParseError(f"{where}: expected an expression string, got {type(text).__name__}")
    stripped = " ".join(text.split())  # a line break inside an expression is plain white space
    if not stripped:
        raise ParseError(f"{where}: the expression is empty")
    if len(stripped) > MAX_LENGTH:
        raise ParseError(
            f"{where}: the expression is longer than {MAX_LENGTH} characters; split it with intermediate states"
        )
    check_time(f"reading the {where} ({shorten(stripped, 40)!r})", "raise max_seconds=")
    used = _check_names_token_level(stripped, where)
    grouped = regroup_sums(stripped)  # a long sum as a balanced tree: linear parsing, no recursion limit
    check_expression_size(stripped, where, grouped=grouped)
    # only the names the expression uses (copying every declared name for every expression made loading
    # a model quadratic in its size); declared names win over function and constant names
    local: dict[str, Any] = {}
    for name in used:
        for table in (symbols, _LOGIC, _CONSTANTS, ALLOWED_FUNCTIONS):
            if name in table:
                local[name] = table[name]
                break
    try:
        expr = parse_expr(grouped, local_dict=local, global_dict=dict(_PARSER_GLOBALS), transformations=_TRANSFORMS)
    except ParseError:
        raise
    except (SyntaxError, tokenize.TokenError):
        raise ParseError(f"{where}: syntax error in {shorten(stripped)!r}; check brackets and operators") from None
    except RecursionError:
        raise ParseError(f"{where}: {shorten(stripped)!r} is nested too deeply; simplify it") from None
    except Exception as exc:  # noqa: BLE001 - the door: anything sympy raises becomes our error
        raise ParseError(
            f"{where}: cannot read {shorten(stripped)!r}: {type(exc).__name__}: {shorten(str(exc))}"
        ) from None
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
        return shorten(text if text is not None else str(expr))

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
        hint = (
            "a log, sqrt or fractional power of a negative constant"
            if "I" in symbols
            else "a log, sqrt or fractional power of a negative constant, or the imaginary unit I; declare a "
            "symbol 'I' if you meant a variable"
        )
        raise ParseError(f"{where}: {shown()!r} is complex-valued ({hint}); obsnl models are real")
    problem = _folded_constant_problem(expr) or _never_real_problem(expr)
    if problem:
        raise ParseError(f"{where}: {shown()!r} {problem}")
    # Symbols: declared ones only, matched by name.
    replace: dict[sp.Symbol, sp.Symbol] = {}
    for s in expr.free_symbols:
        name = s.name
        if reserved and name in reserved:
            raise ParseError(f"{where}: {reserved[name]}")
        if name not in symbols:
            raise ParseError(
                f"{where}: undeclared symbol {quote(name, 40)} in {shown()!r}{_suggest(name, symbols)}; "
                f"declare it as a state, parameter, input or known constant"
            )
        if s is not symbols[name]:
            replace[s] = symbols[name]
    if replace:
        expr = expr.xreplace(replace)
    return expr


#: Largest size (nodes) of an argument whose sign is asked of sympy: the question costs about 1 ms per
#: node (a sum of 1000 squares takes a second), so bigger arguments are not decided.
_SIGN_NODES = 200


def _folded_constant_problem(expr: sp.Basic) -> str | None:
    """Why a number of ``expr`` *after* sympy folded it is out of bounds (``x*10.0**100*x*10.0**100``
    holds 10**200 although each literal is within the bound), or None."""
    for n in expr.atoms(sp.Number):
        if n == 0 or not n.is_finite:
            continue
        if exact_digits(n) > MAX_EXACT_DIGITS:  # counted on the bits: printing it may be refused by Python
            return (
                f"holds an exact constant of {exact_digits(n):.0f} digits (after multiplying its numbers out), "
                f"over {MAX_EXACT_DIGITS}; obsnl computes exactly, with rationals: round the constants, e.g. "
                f"write the value as a decimal of at most {MAX_DIGITS} digits"
            )
        p, q = (abs(int(n.p)), int(n.q)) if n.is_Rational else sp.Rational(abs(n)).as_numer_denom()
        if p > q * 10**MAX_DIGITS or p * 10**MAX_DIGITS < q:
            size = len(str(p)) - len(str(q))
            return (
                f"holds the constant 1e{size:+d} (after multiplying its numbers out), beyond 1e{MAX_DIGITS} or "
                f"below 1e-{MAX_DIGITS}; rescale the model"
            )
    return None


def _never_real_problem(expr: sp.Basic) -> str | None:
    """Why ``expr`` is not real for any real value of its symbols, where sympy proves it cheaply (a root or
    fractional power of an argument it proves negative, the log of one it proves never positive), or None."""

    def small(e: sp.Basic) -> bool:
        return sum(1 for _ in zip(range(_SIGN_NODES + 1), sp.preorder_traversal(e))) <= _SIGN_NODES

    for pw in expr.atoms(sp.Pow):
        b, e = pw.base, pw.exp
        if e.is_Number and not e.is_integer and small(b) and b.is_negative:
            return (
                f"is not real for any real value of its symbols: {shorten(str(pw), 40)!r} takes a root of "
                f"{shorten(str(b), 40)!r}, which is negative everywhere; obsnl models are real"
            )
    for lg in expr.atoms(sp.log):
        a = lg.args[0]
        if small(a) and a.is_nonpositive:
            return (
                f"is not real for any real value of its symbols: {shorten(str(lg), 40)!r} takes the log of "
                f"{shorten(str(a), 40)!r}, which is never positive; obsnl models are real"
            )
    return None
