"""Sentences shared by the renderings of an analysis: the probability bound, the union, the joint
verdict, the assumptions and the verdict lines (text, Markdown and LaTeX captions use them)."""

from __future__ import annotations

from collections.abc import Sequence

from obsnl.observability.results import AnalysisResult, Verdict

__all__ = ["probability_text", "assumption_texts", "joint_text", "union_text"]


def _names(names: Sequence[str]) -> str:
    return ", ".join(names) if names else "none"


def probability_text(p: float | None) -> str:
    """A probability bound as text that does not round a near-certainty up to 1."""
    if p is None:
        return "deterministic"
    if p >= 1.0:
        return "1 (certified)"
    if p > 0.999:
        return f"1 - {1.0 - p:.1e}"
    return f"{p:.4g}"


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
    k = a.get("unknown_input_derivatives")
    if k == "arbitrary":
        out.append("unknown inputs arbitrary functions of time")
    elif k is not None:
        shape = "constant" if k == 0 else f"polynomials in t with {k} non-zero derivative(s)"
        out.append(f"unknown inputs {shape} (K = {k}, STRIKE-GOLDD nnzDerW)")
    if a.get("known_inputs"):
        out.append(f"known inputs {a['known_inputs']}")
    ic = a.get("initial_conditions")
    if ic:
        parts = []
        if ic.get("unknown"):
            parts.append("unknown and generic" if not (ic.get("known_generic") or ic.get("known_values"))
                         else f"unknown for {_names(ic['unknown'])}")
        if ic.get("known_generic"):
            parts.append(f"known and generic for {_names(ic['known_generic'])}")
        if ic.get("known_values"):
            parts.append("given: " + ", ".join(f"{k}(0) = {v}" for k, v in ic["known_values"].items()))
        out.append("initial conditions " + "; ".join(parts))
    return out


def _verdict_lines(result: AnalysisResult) -> list[str]:
    """Verdict overall and of the unknown inputs (Markdown/LaTeX captions share it)."""
    lines = [f"Verdict: {result.verdict.value}." if result.joint is None else
             f"Verdict: {result.overall_verdict.value} (joint); {result.verdict.value} (union over branches)."]
    ui = result.unknown_inputs
    if ui:
        lines.append(f"Unknown inputs observable: {_names(ui['observable'])}; "
                     f"unobservable: {_names(ui['unobservable'])}.")
    if result.assumptions:
        lines.append("Assumptions: " + "; ".join(assumption_texts(result)) + ".")
    return lines


def joint_text(result: AnalysisResult) -> str:
    """The joint verdict in one sentence (``""`` when it was not computed)."""
    j = result.joint
    if j is None:
        return ""
    parts = []
    if not j.unobservable and not j.inconclusive:
        parts.append("every state and parameter is observable")
    else:
        if j.unobservable:
            parts.append(f"unobservable: {_names(j.unobservable)}")
        if j.inconclusive:
            parts.append(f"not decided: {_names(j.inconclusive)} ({j.reason})")
    extra = [v for v in j.observable if v not in result.overall_observable]
    if extra:
        parts.append(f"observable only jointly: {_names(extra)}")
    return "; ".join(parts)


def union_text(result: AnalysisResult) -> str:
    unobs = result.overall_unobservable
    if not unobs and result.verdict is Verdict.OBSERVABLE:
        return "every state and parameter is observable"
    return f"unobservable in every branch: {_names(unobs)}"
