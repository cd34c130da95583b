"""Regrouping of long sums in a shown expression, so that a shortened text stays readable."""

from __future__ import annotations

import io
import keyword
import tokenize

__all__ = ["regroup_sums"]

_WIDTH = 16  # terms per bracket of a regrouped sum
_OPEN, _CLOSE = "([{", ")]}"
#: Operators binding more loosely than + and -: a stretch holding one is not regrouped.
_LOOSE = {"<", ">", "<=", ">=", "==", "!=", "&", "|", "~", ":", "=", ":=", "<<", ">>"}


# --------------------------------------------------------------------------- regrouping long sums
def _operand_end(tok: str, kind: int) -> bool:
    """Whether a + or - after this token is binary (the token ends an operand)."""
    if kind == tokenize.NUMBER:
        return True
    if kind == tokenize.NAME:
        return not keyword.iskeyword(tok) or tok in ("True", "False", "None")
    return tok in _CLOSE


def _balanced(terms: list[list[str]]) -> list[str]:
    if len(terms) <= _WIDTH:
        return [t for term in terms for t in term]
    size = -(-len(terms) // _WIDTH)
    out: list[str] = []
    for k in range(0, len(terms), size):
        if k:
            out.append("+")  # each later bracket starts with its first term's own sign (unary there)
        out += ["(", *_balanced(terms[k : k + size]), ")"]
    return out


def _stretch(items: list[tuple[list[str], bool, bool]]) -> list[str]:
    """One stretch between commas at one bracket level: its sum regrouped when nothing binds looser."""
    if any(loose for _, _, loose in items):
        return [t for toks, _, _ in items for t in toks]
    terms: list[list[str]] = []
    for toks, binary, _ in items:
        if binary and terms:
            terms.append(list(toks))
        elif terms:
            terms[-1].extend(toks)
        else:
            terms.append(list(toks))
    return _balanced(terms)


def regroup_sums(text: str) -> str:
    """``text`` with every sum of more than 16 terms written as a balanced tree of bracketed partial sums.

    The value is unchanged (a later bracket starts with its first term's sign, read as unary), only the
    nesting: ``t1 + t2 + ... + tn`` nests ``log n`` deep instead of ``n``. Stretches holding an operator
    that binds more loosely than ``+`` (comparisons, ``&``, ``|``) are left as they are, and so is text
    whose brackets nest over 150 deep or that does not tokenize (the parser then names the problem).

    Parameters
    ----------
    text : str
        An expression (``^`` may stand for a power).

    Returns
    -------
    str

    Examples
    --------
    >>> regroup_sums("x - y")
    'x - y'
    >>> regroup_sums(" + ".join(f"x^{i}" for i in range(20)))[:39]
    '( x ^ 0 + x ^ 1 ) + ( + x ^ 2 + x ^ 3 )'

    """
    try:
        toks = [
            (t.string, t.type)
            for t in tokenize.generate_tokens(io.StringIO(text).readline)
            if t.type in (tokenize.NAME, tokenize.NUMBER, tokenize.OP, tokenize.STRING, tokenize.ERRORTOKEN)
        ]
    except (tokenize.TokenError, IndentationError, SyntaxError):
        return text
    depth = deepest = plus = 0
    for s, _ in toks:
        depth += (s in _OPEN) - (s in _CLOSE)
        deepest = max(deepest, depth)
        plus += s in "+-"
    if deepest > 150 or plus <= _WIDTH:
        return text
    pos = 0

    def level() -> list[str]:
        nonlocal pos
        out: list[str] = []
        items: list[tuple[list[str], bool, bool]] = []
        ends = False
        while pos < len(toks):
            s, kind = toks[pos]
            if s in _CLOSE:
                break
            pos += 1
            if s in _OPEN:
                group = [s, *level()]
                if pos < len(toks):
                    group.append(toks[pos][0])
                    pos += 1
                items.append((group, False, False))
                ends = True
            elif s == ",":
                out += [*_stretch(items), ","]
                items, ends = [], False
            else:
                loose = s in _LOOSE or (
                    kind == tokenize.NAME and keyword.iskeyword(s) and s not in ("True", "False", "None")
                )
                items.append(([s], s in ("+", "-") and ends, loose))
                ends = _operand_end(s, kind)
        return out + _stretch(items)

    out = level()
    while pos < len(toks):  # an unmatched closing bracket: kept for the parser's message
        out.append(toks[pos][0])
        pos += 1
        out += level()
    return " ".join(out)
