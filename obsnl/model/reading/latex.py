"""The LaTeX names a model may give its symbols: a safe subset of math-mode LaTeX.

A model file's ``latex`` map goes into the ``.tex`` tables obsnl writes, and model files come from
other people, so the names are restricted to a whitelist (a blacklist of ``\\input``, ``\\write``,
``\\catcode``, ... would always miss one): letters, digits, spaces and ``_ ^ { } ' , . + - ( ) | /``,
balanced braces, and only the control words in :data:`ALLOWED_COMMANDS` (Greek letters, accents,
font switches). Anything else is refused with the offending part named.

Two symbols of one model must not render alike (:func:`latex_clash`): a ``latex`` name equal to another
symbol's rendering (``k = "c"`` next to a parameter ``c``), or two default renderings that coincide
(``x1`` and ``x_1`` are both ``x_{1}``), would show two unknowns as one in every table.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping

import sympy as sp

__all__ = ["ALLOWED_COMMANDS", "latex_problem", "latex_clash", "rendering"]

_GREEK = (
    "alpha beta gamma delta epsilon varepsilon zeta eta theta vartheta iota kappa lambda mu nu xi pi varpi "
    "rho varrho sigma varsigma tau upsilon phi varphi chi psi omega Gamma Delta Theta Lambda Xi Pi Sigma "
    "Upsilon Phi Psi Omega"
)
#: Control words a LaTeX name may use.
ALLOWED_COMMANDS: frozenset[str] = frozenset(
    _GREEK.split()
    + "mathrm mathit mathbf mathsf mathcal mathbb boldsymbol bar hat tilde dot ddot vec check breve widehat "
    "widetilde overline underline prime ell infty partial nabla star ast dagger circ cdot operatorname".split()
)
_ALLOWED_SYMBOLS = {",", ";", "!", " ", "_", "|"}  # \, \; \! \  \_ \| (spacing and escapes)
_PLAIN = re.compile(r"[A-Za-z0-9 _^{}',.+\-()|/*\\]*")
_MAX_LENGTH = 200


def latex_problem(text: str) -> str | None:
    """Why ``text`` is not a safe LaTeX name, or None if it is.

    Parameters
    ----------
    text : str
        A LaTeX name such as ``\\Delta_1`` or ``c'_{\\eta}``.

    Returns
    -------
    str or None
        The problem and the fix, for an error message.

    Examples
    --------
    >>> latex_problem(r"\\Delta_1") is None
    True
    >>> print(latex_problem(r"\\input{/etc/passwd}"))
    the control word \\input is not allowed in a LaTeX name; use Greek letters, accents and \\mathrm{...} only
    """
    if len(text) > _MAX_LENGTH:
        return f"longer than {_MAX_LENGTH} characters"
    if not _PLAIN.fullmatch(text):
        bad = next(c for c in text if not _PLAIN.fullmatch(c))
        return (
            f"the character {bad!r} is not allowed in a LaTeX name (letters, digits, spaces and "
            f"_ ^ {{ }} ' , . + - ( ) | / * and allowed control words only)"
        )
    depth = 0
    for c in text:
        depth += {"{": 1, "}": -1}.get(c, 0)
        if depth < 0:
            return "unbalanced braces ('}' before its '{')"
    if depth:
        return "unbalanced braces (a '{' is not closed)"
    for m in re.finditer(r"\\([A-Za-z]+|.?)", text):
        word = m.group(1)
        if word.isalpha() and word in ALLOWED_COMMANDS:
            continue
        if len(word) == 1 and word in _ALLOWED_SYMBOLS:
            continue
        return (
            f"the control word \\{word} is not allowed in a LaTeX name; use Greek letters, accents and "
            f"\\mathrm{{...}} only"
        )
    return None


def rendering(name: str, latex: Mapping[str, str]) -> str:
    """How a report writes the symbol ``name``: its ``latex`` entry, else sympy's LaTeX of the name.

    Parameters
    ----------
    name : str
        A symbol or output of the model.
    latex : mapping of str to str
        The model's ``latex`` table.

    Returns
    -------
    str

    Examples
    --------
    >>> print(rendering("Delta1", {}), rendering("k", {"k": "c"}), rendering("kh_2", {}))
    \\Delta_{1} c \\mathit{kh}_{2}
    """
    given = latex.get(name)
    return given if isinstance(given, str) else default_latex(name)


_BASE = re.compile(r"[A-Za-z]{2,}(?=$|[_^{])")


def default_latex(name: str) -> str:
    """sympy's LaTeX of the symbol ``name``, with a base of several letters that is no Greek letter set as
    one italic word: ``kh`` is ``\\mathit{kh}``, not ``k h`` (k times h) in math mode.

    Examples
    --------
    >>> print(default_latex("kh"), default_latex("beta"), default_latex("c_eta_p"), default_latex("k1"))
    \\mathit{kh} \\beta c_{\\eta p} k_{1}
    """
    tex = sp.latex(sp.Symbol(name))
    m = _BASE.match(tex)
    return f"\\mathit{{{m.group(0)}}}{tex[m.end() :]}" if m else tex


def _shape(tex: str) -> str:
    """``tex`` without what does not change how it looks (white space, braces around one character)."""
    tex = re.sub(r"\s+", "", tex)
    return re.sub(r"([_^]){(\\[A-Za-z]+|\w)}", r"\1\2", tex)


def latex_clash(latex: Mapping[str, str], names: Iterable[str]) -> str | None:
    """Why two of ``names`` render alike (:func:`rendering`), or None.

    Parameters
    ----------
    latex : mapping of str to str
        The model's ``latex`` table (checked by :func:`latex_problem`).
    names : iterable of str
        Every symbol and output of the model.

    Returns
    -------
    str or None
        The two names, the shared rendering and the fix, for an error message.

    Examples
    --------
    >>> print(latex_clash({"k": "c"}, ["k", "c"]))
    latex.k renders as 'c', like the symbol 'c'; give each symbol its own LaTeX name
    >>> latex_clash({"k": "\\\\kappa"}, ["k", "c"]) is None
    True
    """
    seen: dict[str, str] = {}
    for n in names:
        shape = _shape(rendering(n, latex))
        if shape in seen:
            first, second = (n, seen[shape]) if n in latex else (seen[shape], n)
            what = f"latex.{first} renders as" if first in latex else f"the symbol {first!r} renders as"
            fix = "its own LaTeX name" if first in latex or second in latex else "a LaTeX name in [latex]"
            return f"{what} '{rendering(first, latex).strip()}', like the symbol {second!r}; give each symbol {fix}"
        seen[shape] = n
    return None
