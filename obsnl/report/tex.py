"""LaTeX primitives of the renderings: escaping text, a variable's LaTeX name, an expression and a
switching function in LaTeX.
"""

from __future__ import annotations

import sympy as sp

from obsnl.observability.results import AnalysisResult

__all__ = ["tex_escape"]


# --------------------------------------------------------------------------- latex
_TEX_SPECIAL = {
    "_": r"\_",
    "%": r"\%",
    "&": r"\&",
    "#": r"\#",
    "$": r"\$",
    "{": r"\{",
    "}": r"\}",
    "~": r"\textasciitilde{}",
    "^": r"\textasciicircum{}",
    "\\": r"\textbackslash{}",
}


def tex_escape(text: str) -> str:
    return "".join(_TEX_SPECIAL.get(c, c) for c in text)


def _latex_name(name: str, result: AnalysisResult) -> str:
    from obsnl.model.reading.latex import default_latex, latex_problem

    given = result.latex.get(name)
    if isinstance(given, str) and latex_problem(given) is None:  # only a whitelisted name reaches the .tex
        return given
    return default_latex(name)


def _latex_factor(f: sp.Expr, result: AnalysisResult, *, wrap: bool) -> str:
    """LaTeX of a switching function with positive terms first (``r - \\eta'``, not ``-\\eta' + r``)."""
    if not isinstance(f, sp.Add):
        return _latex_expr(f, result)
    terms = sorted(f.args, key=lambda t: (t.could_extract_minus_sign(), sp.default_sort_key(t)))
    out = ""
    for i, t in enumerate(terms):
        neg = t.could_extract_minus_sign()
        body = _latex_expr(-t if neg else t, result)
        out += (" - " if neg else " + ") + body if i else ("-" if neg else "") + body
    return f"\\left({out}\\right)" if wrap else out


def _latex_expr(expr: sp.Basic, result: AnalysisResult) -> str:
    names = {s: _latex_name(s.name, result) for s in expr.free_symbols}
    return sp.latex(expr, symbol_names=names)
