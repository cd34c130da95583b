"""Result values of the observability analyses: frozen, JSON-ready, rendered only in ``report``.

A :class:`~obsnl.observability.verdicts.BranchResult` is the verdict for one smooth branch; an
:class:`AnalysisResult` gathers the branches of one model and their union (a variable is observable
for the non-smooth system when it is observable in at least one branch, Chatzis et al. 2015).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from obsnl._display import render
from obsnl._text import block, bound, names, one_line, probability_text, verdict_words
from obsnl.model.branching.signature import ModelSignature
from obsnl.observability.assumptions import Assumptions
from obsnl.observability.joint.result import JointResult
from obsnl.observability.joint.selection import Visited
from obsnl.observability.verdicts import BranchResult, Verdict

__all__ = ["AnalysisResult"]


@dataclass(frozen=True)
class AnalysisResult:
    """Observability of a model, branch by branch, and the union over branches.

    Attributes
    ----------
    model
        Model name.
    method
        ``"orc"``, ``"sedoglavic"`` (or ``"auto"`` resolved to one of them per branch).
    seed
        Seed of the random point (randomized methods), else None.
    probability
        Guaranteed lower bound of the probability that every verdict is right (randomized
        methods), None for deterministic ones.
    seconds
        Wall time of the whole analysis.
    branches
        One :class:`BranchResult` per branch.
    variables
        All unknowns in model order (states, then parameters).
    switching
        The model's switching functions as text (empty for a smooth model).
    parameters
        The model's parameters (to tell them from states in reports and branch tables).
    latex
        LaTeX names of symbols (from the model file), for reports.
    signature
        The analysed model's :class:`~obsnl.model.branching.signature.ModelSignature` (names, order,
        fingerprint, switching functions): a branch table is written from the result alone.
    joint
        The joint verdict (:class:`~obsnl.observability.joint.result.JointResult`): what the visited
        branches and visible switching surfaces reveal together, parameters shared. None when not
        computed.
    visited
        How the analysed branches were chosen (:class:`~obsnl.observability.joint.selection.Visited`).

    The per-branch union is :attr:`overall_observable` / :attr:`overall_unobservable` (also named
    :attr:`union_observable` / :attr:`union_unobservable`: the seed paper's rule); the joint verdict is
    :attr:`joint`. In ``obsnl analyze --format json``, ``overall`` is the joint verdict and ``union``
    the per-branch union.
    assumptions
        What the verdicts assume (:class:`~obsnl.observability.assumptions.Assumptions`):
        ``unknown_input_derivatives`` (``"arbitrary"``, a number ``K`` or None without unknown inputs),
        ``known_inputs`` (``"generic"``, ``"polynomial of degree d"`` or None without known inputs),
        ``initial_conditions`` (unknown, known and generic, known with a value) and the declared ``bounds``;
        None when not stated (``to_dict`` then writes ``{}``).
    """

    model: str
    method: str
    seed: int | None
    probability: float | None
    seconds: float
    branches: tuple[BranchResult, ...]
    variables: tuple[str, ...] = ()
    switching: tuple[str, ...] = ()
    parameters: tuple[str, ...] = ()
    latex: Mapping[str, str] = field(default_factory=dict)
    signature: ModelSignature | None = field(default=None, compare=False)
    joint: JointResult | None = field(default=None, compare=False)
    visited: Visited | None = field(default=None, compare=False)

    @property
    def union_observable(self) -> tuple[str, ...]:
        """Observable in at least one visited branch (the per-branch union), in model order."""
        return self.overall_observable

    @property
    def union_unobservable(self) -> tuple[str, ...]:
        """Unobservable in every visited branch, in model order."""
        return self.overall_unobservable

    assumptions: Assumptions | None = None

    @property
    def overall_observable(self) -> tuple[str, ...]:
        """Observable in at least one branch, in model order."""
        obs = set().union(*(b.observable for b in self.branches)) if self.branches else set()
        order = self.variables or tuple(sorted(obs))
        return tuple(v for v in order if v in obs)

    @property
    def overall_unobservable(self) -> tuple[str, ...]:
        """Unobservable in every branch, in model order."""
        obs = set(self.overall_observable)
        und = set().union(*(b.undecided for b in self.branches)) if self.branches else set()
        order = self.variables or tuple(sorted(set().union(*(b.unobservable for b in self.branches))))
        return tuple(v for v in order if v not in obs and v not in und)

    @property
    def verdict(self) -> Verdict:
        """OBSERVABLE when the union is everything, INCONCLUSIVE when a branch could not decide."""
        if any(b.verdict is Verdict.INCONCLUSIVE for b in self.branches) and not (
            set(self.variables) <= set(self.overall_observable)
        ):
            return Verdict.INCONCLUSIVE
        return Verdict.OBSERVABLE if not self.overall_unobservable else Verdict.UNOBSERVABLE

    @property
    def overall_verdict(self) -> Verdict:
        """The joint verdict's class when it was computed (INCONCLUSIVE when some variable is not
        decided), else the union's :attr:`verdict`."""
        j = self.joint
        if j is None:
            return self.verdict
        if j.inconclusive:
            return Verdict.INCONCLUSIVE
        return Verdict.UNOBSERVABLE if j.unobservable else Verdict.OBSERVABLE

    @property
    def unknown_inputs(self) -> dict[str, tuple[str, ...]]:
        """Classes of the unknown inputs over the branches (observable in at least one branch;
        unobservable in every branch that decided; undecided ones in neither); empty without any."""
        names: list[str] = []
        for b in self.branches:
            for v in b.unknown_inputs.values():
                names += [n for n in v if n not in names]
        if not names and not any(b.unknown_inputs for b in self.branches):
            return {}
        obs = {n for b in self.branches for n in b.unknown_inputs.get("observable", ())}
        unobs = {n for b in self.branches for n in b.unknown_inputs.get("unobservable", ())}
        stuck = any(b.verdict is Verdict.INCONCLUSIVE for b in self.branches)
        return {
            "observable": tuple(n for n in names if n in obs),
            "unobservable": tuple(n for n in names if n in unobs and n not in obs and not stuck),
        }

    @property
    def only_jointly(self) -> tuple[str, ...]:
        """Identifiable jointly but in no single branch on its own (the joint observable minus the
        per-branch union), in model order; empty without a joint verdict or without per-branch results."""
        if self.joint is None or not any(b.observable or b.unobservable for b in self.branches):
            return ()
        union = set(self.union_observable)
        return tuple(v for v in self.joint.observable if v not in union)

    def joint_words(self, name: Callable[[str], str] = str, most: int | None = None) -> str:
        """The joint verdict in words, what a rendering says first.

        Parameters
        ----------
        name : callable
            How one name is written (e.g. as LaTeX).
        most : int or None
            Names shown per list at most (None: all).

        Returns
        -------
        str
            ``"jointly identifiable: all"`` or ``"jointly identifiable: x, v; not identifiable: beta;
            undecided: w"``, then ``"; only jointly: ..."`` (:attr:`only_jointly`) when some variable is
            identifiable only jointly; ``"joint verdict not computed"`` without one.

        Examples
        --------
        >>> from obsnl import Model, analyze
        >>> m = Model(name="bilinear", states=["x", "v"], parameters=["c", "k", "alpha", "x_y"], inputs=["u"],
        ...           equations={"x": "v", "v": "u - c*v - k*x + (1 - alpha)*k*Max(x - x_y, 0)"},
        ...           outputs={"y": "x"})
        >>> analyze(m, seed=0).joint_words()
        'jointly identifiable: all; only jointly: alpha, x_y'
        """
        j = self.joint
        if j is None:
            return "joint verdict not computed"
        words = verdict_words(j.observable, j.unobservable, j.inconclusive, most=most, name=name)
        extra = self.only_jointly
        return f"{words}; only jointly: {names(extra, most, name=name)}" if extra else words

    def union_words(self, name: Callable[[str], str] = str, most: int | None = None) -> str:
        """The per-branch union in words (the seed paper's rule: observable in at least one branch).

        Parameters
        ----------
        name : callable
            How one name is written (e.g. as LaTeX).
        most : int or None
            Names shown at most (None: all).

        Returns
        -------
        str
            ``"every state and parameter is observable"`` or ``"unobservable in every branch: ..."``.
        """
        if not self.branches:
            return "no branch analysed on its own"
        unobs = self.overall_unobservable
        if not unobs and self.verdict is Verdict.OBSERVABLE:
            return "every state and parameter is observable"
        return f"unobservable in every branch: {names(unobs, most, name=name)}"

    def __repr__(self) -> str:
        p = "" if self.overall_verdict is Verdict.INCONCLUSIVE else bound(self.probability)
        return one_line(
            "AnalysisResult",
            f"model={self.model!r}",
            f"joint={self.joint_words(most=6)!r}",
            f"branches={len(self.branches)}",
            p,
        )

    def summary(self) -> str:
        """A few lines of plain text: the joint verdict first, then the union over branches, then the
        branches (``obsnl.report.to_text`` gives everything).

        Examples
        --------
        >>> from obsnl import Model, analyze
        >>> m = Model(name="decay", states=["x"], parameters=["a"], equations={"x": "-a*x"}, outputs={"y": "x"})
        >>> print(analyze(m, seed=0).summary(), end="")  # doctest: +ELLIPSIS
        decay: 1 branch, method auto, seed 0, P >= 1 (certified), ... s
        jointly identifiable: all
        union over branches (each branch on its own, the seed paper's rule): every state and parameter is observable
        """
        prob = (
            "no probability bound (not every verdict decided)"
            if self.overall_verdict is Verdict.INCONCLUSIVE
            else f"P >= {probability_text(self.probability)}"
        )
        n = len(self.branches)
        j = self.joint
        shown = (
            [
                f"({b.label}) {b.guard}: unobservable: {names(b.unobservable, 6)}"
                if b.unobservable
                else f"({b.label}) {b.guard}: {b.verdict.value}"
                for b in self.branches[:4]
            ]
            if n > 1
            else []
        )
        return block(
            f"{self.model}: {n} branch{'es' if n != 1 else ''}, method {self.method}, seed {self.seed}, "
            f"{prob}, {self.seconds:.3g} s",
            self.joint_words(most=12),
            f"undecided because: {j.reason}" if j is not None and j.inconclusive else "",
            f"union over branches (each branch on its own, the seed paper's rule): {self.union_words(most=12)}",
            *shown,
            f"... and {n - 4} more branches" if n > 4 and len(shown) == 4 else "",
        )

    def branch(self, label: str) -> BranchResult:
        """The result of the branch labelled ``label``."""
        for b in self.branches:
            if b.label == label:
                return b
        raise KeyError(f"no branch {label!r}; branches are {[b.label for b in self.branches]}")

    def _repr_markdown_(self) -> str | None:
        """Notebook display: the Markdown table, drawn by :mod:`obsnl.report` (:mod:`obsnl._display`)."""
        return render("md", self)

    def _repr_html_(self) -> str | None:
        """Notebook display: the verdicts and the branch table as HTML, drawn by :mod:`obsnl.report`."""
        return render("html", self)

    def _repr_latex_(self) -> str | None:
        """Notebook display: the LaTeX table (without its environment), drawn by :mod:`obsnl.report`."""
        return render("tex", self)

    def to_dict(self, *, extended: bool = False) -> dict[str, Any]:
        """JSON-ready data with the keys of ``obsnl analyze --format json``: ``model, method, seed,
        probability, seconds, branches, union, overall, verdict, assumptions, joint, visited``.

        ``union`` is the per-branch union (``observable, unobservable``, with ``unknown_inputs`` when
        the model has some, and its ``verdict``); ``overall`` is the joint verdict when it was computed
        (``rule: "joint"``, with ``inconclusive``, the ``reason`` and ``only_jointly``: identifiable jointly but
        in no single branch), else the union (``rule: "union"``);
        ``verdict`` is the overall one; ``joint`` holds the joint verdict's visits, probability and
        assumptions. ``probability`` is None when the verdict is inconclusive (no bound is claimed for
        what was not decided).
        """
        union: dict[str, Any] = {
            "observable": list(self.overall_observable),
            "unobservable": list(self.overall_unobservable),
        }
        ui = self.unknown_inputs
        if ui:
            union["unknown_inputs"] = {k: list(v) for k, v in ui.items()}
        union["verdict"] = self.verdict.value
        verdict = self.overall_verdict
        out: dict[str, Any] = {
            "model": self.model,
            "method": self.method,
            "seed": self.seed,
            "probability": None if verdict is Verdict.INCONCLUSIVE else self.probability,
            "seconds": self.seconds,
            "branches": [b.to_dict(extended=extended) for b in self.branches],
            "union": union,
            "verdict": verdict.value,
            "assumptions": {} if self.assumptions is None else self.assumptions.to_dict(),
        }
        j = self.joint
        if j is None:
            out["overall"] = {**union, "rule": "union"}
        else:
            out["overall"] = {
                "rule": "joint",
                "observable": list(j.observable),
                "unobservable": list(j.unobservable),
                "inconclusive": list(j.inconclusive),
                "reason": j.reason,
                "only_jointly": list(self.only_jointly),
                "unknown_inputs": {k: list(v) for k, v in j.unknown_inputs.items()},
            }
            out["joint"] = j.to_dict()
        if self.visited is not None:
            out["visited"] = self.visited.to_dict()
        return out
