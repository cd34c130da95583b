"""Bounds checked on an expression's text before sympy sees it, and the rewriting that keeps parsing linear.

sympy evaluates while it parses: ``9**9**9`` would be computed, ``(1 + 1e-100)**100`` becomes an exact
rational of 10 001 digits. Python's parser nests a sum of n terms n deep (``((a + b) + c) + ...``), so a
published equation of a few thousand terms (the QY benchmark of StructuralIdentifiability.jl, about
12 000 operations and names) ran into Python's recursion limit, and sympy rebuilt the growing sum at each
``+`` (quadratic work). :func:`regroup_sums` writes every long sum as a balanced tree of bracketed partial
sums (same value, depth ``log n``), after which parsing is linear in the size of the expression; the
bounds below are then bounds on work: :data:`MAX_NODES` operations and names parse in about 2 s.
"""

from __future__ import annotations

import ast
import math
from collections.abc import Sized
from decimal import Decimal
from typing import cast

from obsnl._text import quote, shorten  # one place that cuts what a message echoes
from obsnl.errors import ParseError
from obsnl.model.bounds.regroup import regroup_sums
from obsnl.model.bounds.work import MAX_EXACT_DIGITS

__all__ = [
    "MAX_NODES",
    "MAX_DEPTH",
    "MAX_DIGITS",
    "MAX_EXPONENT",
    "MAX_LENGTH",
    "shorten",
    "quote",
    "check_expression_size",
]

#: Characters of one expression.
MAX_LENGTH = 200_000
#: Operations and names in one expression (parsing is linear in them once sums are regrouped: about 2 s).
MAX_NODES = 50_000
#: Nesting of operations once sums are regrouped (a product of n factors still nests n deep).
MAX_DEPTH = 200
#: Digits of a number literal, and of any constant the expression computes.
MAX_DIGITS = 100
#: |exponent| of a power with a constant exponent.
MAX_EXPONENT = 100


# --------------------------------------------------------------------------- bounds on the text
def _refuse(where: str, text: str, what: str) -> ParseError:
    return ParseError(
        f"{where}: {what} in {shorten(text)!r}; obsnl refuses exponents above {MAX_EXPONENT} "
        f"and constants over {MAX_DIGITS} digits (rescale the model)"
    )


def _const_log10(node: ast.AST, where: str, text: str) -> float | None:
    """An upper bound of log10|value| of a constant sub-expression (None: not constant); refuses a power
    with a huge exponent and a constant with more than MAX_DIGITS digits, without computing either."""
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
                    raise _refuse(where, text, "a power with an exponent over " + str(MAX_EXPONENT))
                if left is None:
                    return None
                bound = left * 10**right if left > 0 else 0.0
                if bound > MAX_DIGITS:
                    raise _refuse(where, text, f"a constant power with more than {MAX_DIGITS} digits")
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
            raise _refuse(where, text, f"a constant with more than {MAX_DIGITS} digits")
        return bound
    return None


def _literal_digits(value: int | float) -> float:
    """Digits of the larger of the numerator and denominator of a literal read exactly (``1e-100``: 101)."""
    if isinstance(value, int):
        return float(len(str(abs(value))))
    sign, digits, exponent = Decimal(repr(float(value))).as_tuple()
    if not isinstance(exponent, int):  # inf or nan: refused elsewhere
        return 0.0
    return float(max(len(digits) + max(exponent, 0), 1 - exponent if exponent < 0 else 1))


def _exact_digits(node: ast.AST, memo: dict[int, float | None]) -> float | None:
    """An upper bound of the digits of the exact rational a constant sub-expression folds to (None: not
    constant); long products and sums fold their constant members together, so those are added up."""
    key = id(node)
    if key in memo:
        return memo[key]
    out: float | None = None
    if isinstance(node, ast.Constant):
        if isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
            out = _literal_digits(node.value)
    elif isinstance(node, ast.UnaryOp):
        out = _exact_digits(node.operand, memo)
    elif isinstance(node, ast.BinOp):
        left, right = _exact_digits(node.left, memo), _exact_digits(node.right, memo)
        if isinstance(node.op, ast.Pow):
            power = node.right.value if isinstance(node.right, ast.Constant) else None
            if left is not None and isinstance(power, int) and not isinstance(power, bool):
                out = left * abs(power)
            elif left is not None and right is not None:
                out = left + right
        elif left is not None and right is not None:
            out = left + right + 1
    memo[key] = out
    return out


def _members(node: ast.AST, ops: tuple[type, ...]) -> list[ast.AST]:
    """The operands of a chain of ``ops`` (``a*b/c*d``: a, b, c, d), whatever the bracketing."""
    out, stack = [], [node]
    while stack:
        n = stack.pop()
        if isinstance(n, ast.BinOp) and isinstance(n.op, ops):
            stack += [n.left, n.right]
        elif isinstance(n, ast.UnaryOp) and ast.Add in ops:
            stack.append(n.operand)
        else:
            out.append(n)
    return out


def _check_exact_digits(tree: ast.AST, where: str, text: str) -> None:
    """Refuse a constant whose exact value would have over ``10 * MAX_EXACT_DIGITS`` digits before sympy
    computes it (after parsing, :func:`obsnl.model.reading.parse` refuses any over :data:`MAX_EXACT_DIGITS`)."""
    memo: dict[int, float | None] = {}
    limit = 10 * MAX_EXACT_DIGITS
    products, sums = (ast.Mult, ast.Div), (ast.Add, ast.Sub)
    stack: list[tuple[ast.AST, tuple[type, ...]]] = [(tree, ())]
    while stack:  # each chain once, at its root
        node, chain = stack.pop()
        ops: tuple[type, ...] = ()
        if isinstance(node, ast.BinOp):
            ops = products if isinstance(node.op, products) else sums if isinstance(node.op, sums) else ()
            if ops and ops != chain:
                total = sum(d for d in (_exact_digits(m, memo) for m in _members(node, ops)) if d is not None)
            else:
                total = _exact_digits(node, memo) or 0.0
            if total > limit:
                raise ParseError(
                    f"{where}: {shorten(text)!r} computes an exact constant of about {total:.0f} "
                    f"digits (over {MAX_EXACT_DIGITS}; obsnl computes exactly, with rationals); round "
                    f"the constants, e.g. write its value as a decimal of at most {MAX_DIGITS} digits"
                )
        stack.extend((child, ops) for child in ast.iter_child_nodes(node))


def check_expression_size(text: str, where: str = "expression", *, grouped: str | None = None) -> None:
    """Refuse an expression whose evaluation could run away, before anything evaluates it.

    The text is read by Python's ``ast`` (``^`` as a power, as obsnl reads it; long sums regrouped by
    :func:`regroup_sums`): at most :data:`MAX_LENGTH` characters and :data:`MAX_NODES` operations and names
    nested at most :data:`MAX_DEPTH` deep, number literals of at most :data:`MAX_DIGITS` digits, constant
    exponents of at most :data:`MAX_EXPONENT`, constants of magnitude within ``1e±100`` (``9**9**9``,
    ``x**(10**10)``, power towers) and exact constants of at most about ten times
    :data:`obsnl.model.bounds.work.MAX_EXACT_DIGITS` digits.

    Parameters
    ----------
    text : str
        The expression as written by the user.
    where : str
        What the expression is (a key or equation name), used in the message.
    grouped : str or None
        ``regroup_sums(text)`` when the caller has it already.

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
    if len(text) > MAX_LENGTH:
        raise ParseError(
            f"{where}: the expression is longer than {MAX_LENGTH} characters; split it with intermediate states"
        )
    grouped = regroup_sums(text) if grouped is None else grouped
    try:
        tree = ast.parse(grouped.replace("^", "**"), mode="eval")
    except RecursionError:
        raise ParseError(f"{where}: {shorten(text)!r} is nested too deeply; split it") from None
    except SyntaxError as exc:
        if "too many nested" in str(exc):  # Python's own limit (200 brackets), not a typo
            raise ParseError(
                f"{where}: {shorten(text)!r} nests brackets more than 200 deep; split it with intermediate states"
            ) from None
        return  # the parser below reports the syntax error with its own message
    except ValueError:
        return
    count = 0
    skip = (ast.expr_context, ast.operator, ast.unaryop, ast.cmpop, ast.boolop)
    stack: list[tuple[ast.AST, int]] = [(tree.body, 1)]
    while stack:
        node, depth = stack.pop()
        count += 1
        if count > MAX_NODES:
            raise ParseError(
                f"{where}: {shorten(text)!r} has more than {MAX_NODES} operations and names; "
                f"split it with intermediate states or simplify it"
            )
        if depth > MAX_DEPTH:
            raise ParseError(
                f"{where}: {shorten(text)!r} nests more than {MAX_DEPTH} operations (a product of n "
                f"factors nests n deep); simplify it"
            )
        stack.extend((child, depth + 1) for child in ast.iter_child_nodes(node) if not isinstance(child, skip))
    # constant growth: bottom-up bound without evaluating (raises on the first runaway power)
    for node in ast.walk(tree.body):
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow):
            _const_log10(node, where, text)
    _check_exact_digits(tree.body, where, text)


# --------------------------------------------------------------------------- bounds on a whole model
#: Declared names and outputs of one model (reading costs about 0.7 ms each: 5000 take 3.5 s).
MAX_MODEL_NAMES = 5000
#: Characters of all the expressions of one model together (about 2 s per 100 000).
MAX_MODEL_TEXT = 300_000


def check_model_size(name: object, roles: dict[str, object], *tables: object) -> None:
    """Refuse a model too large to read, on the raw values before any expression is parsed.

    Parameters
    ----------
    name : object
        The model's name (for the message).
    roles : dict
        ``{role: the raw list of names}`` (states, parameters, ...).
    *tables : object
        The raw tables of expressions, outputs first (counted as names too), whose texts are counted.

    Raises
    ------
    ModelError
        More than :data:`MAX_MODEL_NAMES` names and outputs, or more than :data:`MAX_MODEL_TEXT`
        characters of expressions.

    Examples
    --------
    >>> check_model_size("m", {"states": ["x"] * 6000})
    Traceback (most recent call last):
    ...
    obsnl.errors.ModelError: model 'm' declares 6000 names and outputs (6000 states), more than the 5000 obsnl reads (and the analyses accept at most 300 states and parameters); reduce the model
    """
    from obsnl.errors import ModelError

    def size(v: object) -> int:
        return len(cast(Sized, v)) if isinstance(v, (list, tuple, dict)) or hasattr(v, "keys") else 0

    counts = {role: size(v) for role, v in roles.items()}
    counts["outputs"] = sum(size(t) for t in tables[:1])
    n = sum(counts.values())
    if n > MAX_MODEL_NAMES:
        parts = ", ".join(
            f"{c} {role.replace('_', ' ') if c != 1 else role.rstrip('s').replace('_', ' ')}"
            for role, c in counts.items()
            if c
        )
        raise ModelError(
            f"model {quote(name, 40)} declares {n} names and outputs ({parts}), more than the "
            f"{MAX_MODEL_NAMES} obsnl reads (and the analyses accept at most 300 states and "
            f"parameters); reduce the model"
        )
    text = sum(len(v) for t in tables if hasattr(t, "values") for v in t.values() if isinstance(v, str))
    if text > MAX_MODEL_TEXT:
        raise ModelError(
            f"model {quote(name, 40)} has {text} characters of expressions, more than the "
            f"{MAX_MODEL_TEXT} obsnl reads (about 2 s per 100 000); split long expressions with "
            f"intermediate states or reduce the model"
        )
