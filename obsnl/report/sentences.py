"""Sentences shared by the renderings of an analysis: the probability bound, the joint verdict (said
first), the union, the assumptions and the verdict lines (text, Markdown and LaTeX captions use them)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

from obsnl._text import probability_text
from obsnl.observability.results import AnalysisResult

__all__ = [
    "probability_text",
    "assumption_texts",
    "bounds_text",
    "joint_text",
    "union_text",
    "names_text",
    "verdict_lines",
    "opening_lines",
]


def names_text(names: Sequence[str]) -> str:
    """Names as a comma-separated list, ``none`` for no name.

    Parameters
    ----------
    names : sequence of str
        The names, in the order they are said.

    Returns
    -------
    str

    Examples
    --------
    >>> names_text(["x", "k"]), names_text([])
    ('x, k', 'none')
    """
    return ", ".join(names) if names else "none"


def assumption_texts(result: AnalysisResult) -> list[str]:
    """The assumptions of ``result`` (:attr:`AnalysisResult.assumptions`) as short sentences.

    Examples
    --------
    >>> from obsnl import Model, analyze
    >>> m = Model(name="m", states=["x"], parameters=["a"], unknown_inputs=["w"],
    ...           equations={"x": "-a*x + w"}, outputs={"y": "x"})
    >>> assumption_texts(analyze(m, seed=1, unknown_input_derivatives=0))
    ['unknown inputs constant (K = 0, STRIKE-GOLDD nnzDerW)', 'initial conditions unknown and generic']
    """
    a = result.assumptions
    out: list[str] = []
    if a is None:
        return out
    k = a.unknown_input_derivatives
    if k == "arbitrary":
        out.append("unknown inputs arbitrary functions of time")
    elif k is not None:
        shape = "constant" if k == 0 else f"polynomials in t with {k} non-zero derivative(s)"
        out.append(f"unknown inputs {shape} (K = {k}, STRIKE-GOLDD nnzDerW)")
    if a.known_inputs:
        out.append(f"known inputs {a.known_inputs}")
    ic = a.initial_conditions
    parts = []
    if ic.unknown:
        parts.append(
            "unknown and generic"
            if not (ic.known_generic or ic.known_values)
            else f"unknown for {names_text(ic.unknown)}"
        )
    if ic.known_generic:
        parts.append(f"known and generic for {names_text(ic.known_generic)}")
    if ic.known_values:
        parts.append("given: " + ", ".join(f"{k}(0) = {v}" for k, v in ic.known_values.items()))
    out.append("initial conditions " + "; ".join(parts))
    if a.bounds:
        out.append(bounds_text(a.bounds))
    return out


def bounds_text(bounds: Mapping[str, tuple[float, float]]) -> str:
    """The declared bounds of an analysis' assumptions (``{name: (lo, hi)}``, an open end infinite) in words; whether
    an end is included does not matter to the branches (a sign pattern holds on an open set).

    Examples
    --------
    >>> inf = float("inf")
    >>> bounds_text({"fy": (0.0, inf), "gap": (0.0, 0.01), "c": (-inf, 5.0)})
    'declared bounds fy > 0, gap in [0, 0.01], c < 5'
    """

    def one(name: str, lo: float, hi: float) -> str:
        if hi == math.inf:
            return f"{name} > {lo:g}"
        if lo == -math.inf:
            return f"{name} < {hi:g}"
        return f"{name} in [{lo:g}, {hi:g}]"

    return "declared bounds " + ", ".join(one(k, lo, hi) for k, (lo, hi) in bounds.items())


def verdict_lines(result: AnalysisResult) -> list[str]:
    """The verdict overall, of the unknown inputs and the assumptions, one sentence each.

    The Markdown and LaTeX captions end with them.

    Parameters
    ----------
    result : AnalysisResult
        The analysis.

    Returns
    -------
    list of str
        The verdict (joint and union when the joint verdict was computed), then the unknown inputs' verdict
        when the model has unknown inputs, then the assumptions when ``result`` records them.

    Examples
    --------
    >>> from obsnl import Model, analyze
    >>> m = Model(name="m", states=["x"], parameters=["a"], unknown_inputs=["w"],
    ...           equations={"x": "-a*x + w"}, outputs={"y": "x"})
    >>> for line in verdict_lines(analyze(m, seed=1, unknown_input_derivatives=0)):
    ...     print(line)
    Verdict: observable (joint); observable (union over branches).
    Unknown inputs observable: w; unobservable: none.
    Assumptions: unknown inputs constant (K = 0, STRIKE-GOLDD nnzDerW); initial conditions unknown and generic.
    """
    lines = [
        f"Verdict: {result.verdict.value}."
        if result.joint is None
        else f"Verdict: {result.overall_verdict.value} (joint); {result.verdict.value} (union over branches)."
    ]
    ui = result.unknown_inputs
    if ui:
        lines.append(
            f"Unknown inputs observable: {names_text(ui['observable'])}; "
            f"unobservable: {names_text(ui['unobservable'])}."
        )
    if result.assumptions:
        lines.append("Assumptions: " + "; ".join(assumption_texts(result)) + ".")
    return lines


def joint_text(result: AnalysisResult) -> str:
    """The joint verdict in words, what every rendering says first (:meth:`AnalysisResult.joint_words`).

    Examples
    --------
    >>> from obsnl import Model, analyze
    >>> m = Model(name="m", states=["x"], parameters=["a", "b"], equations={"x": "-(a + b)*x"}, outputs={"y": "x"})
    >>> joint_text(analyze(m, seed=1))
    'jointly identifiable: x; not identifiable: a, b'
    """
    return result.joint_words()


def union_text(result: AnalysisResult) -> str:
    """The per-branch union in words, said after the joint verdict (:meth:`AnalysisResult.union_words`)."""
    return result.union_words()


#: What the joint verdict and the union are, said after their words.
JOINT_RULE = "the visited branches and visible switching surfaces together, parameters shared"
UNION_RULE = "Union over branches (each branch on its own, the seed paper's rule)"


def opening_lines(
    result: AnalysisResult,
    *,
    suffix: str = "",
    name: Callable[[str], str] = str,
    escape: Callable[[str], str] = str,
    strong: Callable[[str], str] = str,
    union: bool = True,
) -> list[str]:
    """What a rendering says first: the joint verdict in words, why some of it is undecided, then the union.

    Parameters
    ----------
    result : AnalysisResult
        The analysis.
    suffix : str
        Appended to every line (``"."`` to end them as sentences).
    name : callable
        Renders a variable's name (e.g. as LaTeX math); the names as they are by default.
    escape : callable
        Escapes the reason why the joint verdict is undecided (e.g. for LaTeX); unchanged by default.
    strong : callable
        Marks up the joint verdict's words (e.g. bold in Markdown); unchanged by default.
    union : bool
        Whether to end with the union over branches.

    Returns
    -------
    list of str
        The joint verdict (its rule said after it when it was computed), the reason it is undecided when
        it is, and the union when ``union``.

    Examples
    --------
    >>> from obsnl import Model, analyze
    >>> m = Model(name="m", states=["x"], parameters=["a", "b"], equations={"x": "-(a + b)*x"}, outputs={"y": "x"})
    >>> for line in opening_lines(analyze(m, seed=1), suffix="."):
    ...     print(line)
    jointly identifiable: x; not identifiable: a, b (the visited branches and visible switching surfaces together, parameters shared).
    Union over branches (each branch on its own, the seed paper's rule): unobservable in every branch: a, b.
    """
    words = strong(result.joint_words(name))
    lines = [f"{words} ({JOINT_RULE}){suffix}" if result.joint is not None else f"{words}{suffix}"]
    if result.joint is not None and result.joint.inconclusive:
        lines.append(f"undecided because: {escape(result.joint.reason)}{suffix}")
    if union:
        lines.append(f"{UNION_RULE}: {result.union_words(name)}{suffix}")
    return lines
