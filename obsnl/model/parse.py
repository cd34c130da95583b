"""Expressions -> sympy objects, restricted to declared symbols.

Every name in an expression must be declared in the model; sympy's built-in names
(``E``, ``N``, ``S``, ``I``, ``Q``, ``C``, ``beta``, ``gamma``, ...) parse as plain symbols
when declared and are errors when not. Only the functions in :data:`ALLOWED_FUNCTIONS`
are accepted. Float literals are read as exact rationals (``0.1`` -> ``1/10``) so that the
exact engines never see a float.
"""

from __future__ import annotations

import ast
import difflib
import keyword
import math
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

__all__ = ["ALLOWED_FUNCTIONS", "PARSER_NAMES", "make_symbol", "parse_expression", "check_expression_size",
           "nfkc_problem", "shorten", "quote"]

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

#: Names the parser's generated code calls (``Integer(2)``): a symbol of that name would replace the class.
PARSER_NAMES: frozenset[str] = frozenset(k for k in _PARSER_GLOBALS if not k.startswith("__"))

_TRANSFORMS = standard_transformations + (convert_xor, rationalize)

_MAX_EXPRESSION_LENGTH = 20_000
#: Bounds checked on the text before sympy sees it (sympy would evaluate ``9**9**9`` while parsing).
MAX_NODES = 4000  # operations and names in one expression
MAX_DEPTH = 200  # nesting of operations (a sum of n terms nests n deep)
MAX_DIGITS = 100  # digits of a number literal, and of any constant the expression computes
MAX_EXPONENT = 100  # |exponent| of a power with a constant exponent
_SHOWN = 80  # characters of an expression quoted in a message


def shorten(text: str, limit: int = _SHOWN) -> str:
    """``text`` cut to ``limit`` characters (with ``...``) for an error message.

    Parameters
    ----------
    text : str
        The text to show.
    limit : int
        Largest length of the result.

    Returns
    -------
    str

    Examples
    --------
    >>> shorten("x + " * 30, 20)
    'x + x + x + x + x...'
    """
    text = text.strip()
    return text if len(text) <= limit else text[: limit - 3].rstrip() + "..."


def quote(value: object, limit: int = _SHOWN) -> str:
    """``repr(value)`` cut to ``limit`` characters: how a message echoes what the user wrote.

    Parameters
    ----------
    value : object
        What the user wrote (a name, a value of a table).
    limit : int
        Largest length of the result.

    Returns
    -------
    str

    Examples
    --------
    >>> quote("z" * 100, 12)
    "'zzzzzzzz..."
    """
    return shorten(repr(value), limit)


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
    close = difflib.get_close_matches(name, list(candidates), n=2, cutoff=0.6)
    if close:
        return " (did you mean " + " or ".join(repr(c) for c in close) + "?)"
    return ""


def _check_names_token_level(text: str, where: str) -> None:
    """Reject Python keywords used as names and dunder tricks before anything is evaluated."""
    try:
        tokens = list(tokenize.generate_tokens(StringIO(text).readline))
    except (tokenize.TokenError, IndentationError, SyntaxError) as exc:
        raise ParseError(f"{where}: syntax error in {shorten(text)!r} ({exc}); check brackets and operators") from None
    for tok in tokens:
        if tok.type == tokenize.COMMENT:
            raise ParseError(f"{where}: '#' in {shorten(text)!r} would cut the expression; remove it")
        if tok.type == tokenize.NUMBER and sum(c.isdigit() for c in tok.string) > MAX_DIGITS:
            raise ParseError(f"{where}: a number with more than {MAX_DIGITS} digits in {shorten(text)!r}; "
                             f"write it with an exponent or scale the model")
        if tok.type == tokenize.NUMBER and "e" in tok.string.lower() and not tok.string.lower().startswith("0x"):
            mantissa, _, exponent = tok.string.lower().rstrip("j").partition("e")
            if exponent.lstrip("+-").replace("_", "").isdigit() and abs(int(exponent.replace("_", ""))) > MAX_DIGITS:
                raise ParseError(f"{where}: the number {shorten(tok.string, 30)!r} is beyond 1e{MAX_DIGITS} or below "
                                 f"1e-{MAX_DIGITS}; rescale the model")
        if tok.type == tokenize.NAME:
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
            raise ParseError(f"{where}: unexpected {tok.string!r} in {shorten(text)!r}; write a single sympy expression")
        elif tok.type == tokenize.STRING:
            raise ParseError(f"{where}: string literal in {shorten(text)!r}; write a sympy expression, not a string")


def _const_log10(node: ast.AST, where: str, text: str) -> float | None:
    """An upper bound of log10|value| of a constant sub-expression (None: not constant); refuses a power
    with a huge exponent and a constant with more than MAX_DIGITS digits, without computing either."""

    def refuse(what: str) -> ParseError:
        return ParseError(f"{where}: {what} in {shorten(text)!r}; obsnl refuses exponents above {MAX_EXPONENT} "
                          f"and constants over {MAX_DIGITS} digits (rescale the model)")

    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            return None
        v = abs(node.value)
        return math.log10(v) if v > 0 else -math.inf
    if isinstance(node, ast.UnaryOp):
        return _const_log10(node.operand, where, text)
    if isinstance(node, ast.BinOp):
        left = _const_log10(node.left, where, text)
        right = _const_log10(node.right, where, text)
        if isinstance(node.op, ast.Pow):
            if right is not None:
                if right > math.log10(MAX_EXPONENT):
                    raise refuse("a power with an exponent over " + str(MAX_EXPONENT))
                if left is None:
                    return None
                bound = left * 10 ** right if left > 0 else 0.0
                if bound > MAX_DIGITS:
                    raise refuse(f"a constant power with more than {MAX_DIGITS} digits")
                return bound
            return None
        if left is None or right is None:
            return None
        if isinstance(node.op, ast.Mult):
            bound = left + right
        elif isinstance(node.op, (ast.Div, ast.FloorDiv, ast.Mod)):
            bound = left
        else:
            bound = max(left, right) + 1
        if bound > MAX_DIGITS:
            raise refuse(f"a constant with more than {MAX_DIGITS} digits")
        return bound
    return None


def check_expression_size(text: str, where: str = "expression") -> None:
    """Refuse an expression whose evaluation could run away, before anything evaluates it.

    The text is read by Python's ``ast`` (``^`` as a power, as obsnl reads it): at most
    :data:`MAX_NODES` nodes nested at most :data:`MAX_DEPTH` deep, number literals of at most
    :data:`MAX_DIGITS` digits, constant exponents of at most :data:`MAX_EXPONENT` and constants
    of at most :data:`MAX_DIGITS` digits (``9**9**9``, ``x**(10**10)``, power towers).

    Parameters
    ----------
    text : str
        The expression as written by the user.
    where : str
        What the expression is (a key or equation name), used in the message.

    Raises
    ------
    ParseError
        Naming the bound and the expression (shortened).

    Examples
    --------
    >>> check_expression_size("x**2 + 3*y")
    >>> check_expression_size("9**9**9")
    Traceback (most recent call last):
    ...
    obsnl.errors.ParseError: expression: a power with an exponent over 100 in '9**9**9'; obsnl refuses exponents above 100 and constants over 100 digits (rescale the model)
    """
    try:
        tree = ast.parse(text.replace("^", "**"), mode="eval")
    except RecursionError:
        raise ParseError(f"{where}: {shorten(text)!r} is nested too deeply; split it") from None
    except SyntaxError as exc:
        if "too many nested" in str(exc):  # Python's own limit (200 brackets), not a typo
            raise ParseError(f"{where}: {shorten(text)!r} nests brackets more than 200 deep; split it with "
                             f"intermediate states") from None
        return  # the parser below reports the syntax error with its own message
    except ValueError:
        return
    count = 0
    stack: list[tuple[ast.AST, int]] = [(tree.body, 1)]
    while stack:
        node, depth = stack.pop()
        count += 1
        if count > MAX_NODES:
            raise ParseError(f"{where}: {shorten(text)!r} has more than {MAX_NODES} operations and names; "
                             f"split it with intermediate states or simplify it")
        if depth > MAX_DEPTH:
            raise ParseError(f"{where}: {shorten(text)!r} nests more than {MAX_DEPTH} operations (a sum of n terms "
                             f"nests n deep); simplify it")
        stack.extend((child, depth + 1) for child in ast.iter_child_nodes(node))
    # constant growth: bottom-up bound without evaluating (raises on the first runaway power)
    for node in ast.walk(tree.body):
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow):
            _const_log10(node, where, text)


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
        if isinstance(text, int) and text.bit_length() > MAX_DIGITS * 3.33:
            raise ParseError(f"{where}: a number with more than {MAX_DIGITS} digits; write it with an exponent "
                             f"or scale the model")
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
    check_expression_size(stripped, where)
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
        raise ParseError(f"{where}: syntax error in {shorten(stripped)!r}; check brackets and operators") from None
    except RecursionError:
        raise ParseError(f"{where}: {shorten(stripped)!r} is nested too deeply; simplify it") from None
    except Exception as exc:  # noqa: BLE001 - the door: anything sympy raises becomes our error
        raise ParseError(f"{where}: cannot read {shorten(stripped)!r}: {type(exc).__name__}: "
                         f"{shorten(str(exc))}") from None
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
        hint = ("a log, sqrt or fractional power of a negative constant" if "I" in symbols
                else "a log, sqrt or fractional power of a negative constant, or the imaginary unit I; declare a "
                     "symbol 'I' if you meant a variable")
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
        p, q = (abs(int(n.p)), int(n.q)) if n.is_Rational else sp.Rational(abs(n)).as_numer_denom()
        if p > q * 10 ** MAX_DIGITS or p * 10 ** MAX_DIGITS < q:
            size = len(str(p)) - len(str(q))
            return (f"holds the constant 1e{size:+d} (after multiplying its numbers out), beyond 1e{MAX_DIGITS} or "
                    f"below 1e-{MAX_DIGITS}; rescale the model")
    return None


def _never_real_problem(expr: sp.Basic) -> str | None:
    """Why ``expr`` is not real for any real value of its symbols, where sympy proves it cheaply (a root or
    fractional power of an argument it proves negative, the log of one it proves never positive), or None."""

    def small(e: sp.Basic) -> bool:
        return sum(1 for _ in zip(range(_SIGN_NODES + 1), sp.preorder_traversal(e))) <= _SIGN_NODES

    for pw in expr.atoms(sp.Pow):
        b, e = pw.base, pw.exp
        if e.is_Number and not e.is_integer and small(b) and b.is_negative:
            return (f"is not real for any real value of its symbols: {shorten(str(pw), 40)!r} takes a root of "
                    f"{shorten(str(b), 40)!r}, which is negative everywhere; obsnl models are real")
    for lg in expr.atoms(sp.log):
        a = lg.args[0]
        if small(a) and a.is_nonpositive:
            return (f"is not real for any real value of its symbols: {shorten(str(lg), 40)!r} takes the log of "
                    f"{shorten(str(a), 40)!r}, which is never positive; obsnl models are real")
    return None
