"""LaTeX primitives of the renderings: escaping text, a variable's LaTeX name, an expression and a
switching function in LaTeX.
"""

from __future__ import annotations

import sympy as sp

from obsnl.observability.results import AnalysisResult

__all__ = ["tex_escape", "latex_name", "latex_factor", "latex_expr"]


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


def latex_name(name: str, result: AnalysisResult) -> str:
    r"""The LaTeX of a variable's name: the one the model gives, when it passes the whitelist, else the default.

    Parameters
    ----------
    name : str
        The variable's name in the model.
    result : AnalysisResult
        The analysis, whose ``latex`` holds the LaTeX names the model gives.

    Returns
    -------
    str
        The model's LaTeX for ``name`` when it gives one that
        :func:`~obsnl.model.reading.latex.latex_problem` accepts, else
        :func:`~obsnl.model.reading.latex.default_latex` of ``name``.

    Examples
    --------
    >>> from obsnl import Model, analyze
    >>> m = Model(name="m", states=["x"], parameters=["kh", "eta"], equations={"x": "-(kh + eta)*x"},
    ...           outputs={"y": "x"}, latex={"eta": r"\eta'"})
    >>> r = analyze(m, seed=1)
    >>> print(latex_name("eta", r), latex_name("kh", r))
    \eta' \mathit{kh}
    """
    from obsnl.model.reading.latex import default_latex, latex_problem

    given = result.latex.get(name)
    if isinstance(given, str) and latex_problem(given) is None:  # only a whitelisted name reaches the .tex
        return given
    return default_latex(name)


def latex_factor(f: sp.Expr, result: AnalysisResult, *, wrap: bool) -> str:
    r"""LaTeX of a switching function with positive terms first (``r - \eta'``, not ``-\eta' + r``).

    Parameters
    ----------
    f : sympy.Expr
        The switching function.
    result : AnalysisResult
        The analysis, whose LaTeX names (:func:`latex_name`) name the variables.
    wrap : bool
        Whether to put a sum in ``\left( ... \right)`` (a factor of a product).

    Returns
    -------
    str
        LaTeX math, without the dollar signs.

    Examples
    --------
    >>> from obsnl import Model, analyze
    >>> m = Model(name="m", states=["x"], parameters=["kh", "eta"], equations={"x": "-(kh + eta)*x"},
    ...           outputs={"y": "x"}, latex={"eta": r"\eta'"})
    >>> r = analyze(m, seed=1)
    >>> print(latex_factor(sp.sympify("-eta + kh"), r, wrap=True), latex_factor(sp.sympify("x"), r, wrap=True))
    \left(\mathit{kh} - \eta'\right) x
    """
    if not isinstance(f, sp.Add):
        return latex_expr(f, result)
    terms = sorted(f.args, key=lambda t: (t.could_extract_minus_sign(), sp.default_sort_key(t)))
    out = ""
    for i, t in enumerate(terms):
        neg = t.could_extract_minus_sign()
        body = latex_expr(-t if neg else t, result)
        out += (" - " if neg else " + ") + body if i else ("-" if neg else "") + body
    return f"\\left({out}\\right)" if wrap else out


def latex_expr(expr: sp.Basic, result: AnalysisResult) -> str:
    r"""LaTeX of an expression or a relation, its variables by their LaTeX names (:func:`latex_name`).

    Parameters
    ----------
    expr : sympy.Basic
        The expression (or relation, such as ``x > 0``).
    result : AnalysisResult
        The analysis, whose LaTeX names name the variables.

    Returns
    -------
    str
        LaTeX math, without the dollar signs.

    Examples
    --------
    >>> from obsnl import Model, analyze
    >>> m = Model(name="m", states=["x"], parameters=["kh", "eta"], equations={"x": "-(kh + eta)*x"},
    ...           outputs={"y": "x"}, latex={"eta": r"\eta'"})
    >>> print(latex_expr(sp.sympify("eta*x > 0"), analyze(m, seed=1)))
    \eta' x > 0
    """
    names = {s: latex_name(s.name, result) for s in expr.free_symbols}
    return sp.latex(expr, symbol_names=names)
