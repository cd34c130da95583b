"""Exact model decomposition on the dependency graph (algorithms.md §2.2).

The graph has a node per state, parameter, input, unknown input, known constant and output, and
an edge ``v -> x`` when ``v`` appears in the right-hand side (or the given initial value) of state
``x``, ``v -> y`` when ``v`` appears in output ``y``. Two facts are exact:

- **(F1) output relevance.** A variable with no path to an output does not enter any output
  derivative: its Jacobian column is zero, so it is unobservable. Only the output-reachable
  (ancestor) submodel is analysed.
- **(F3) block split.** Outputs whose ancestor sets share no unknown (and no state) form
  independent blocks: the Jacobian is block diagonal after permutation, so rank, kernel and
  classes are computed per block and joined exactly. Each block is a closed ODE.

The unsafe shortcuts of algorithms.md §2.1 (coupling states frozen into parameters, upstream
states as generic inputs) are not used.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from obsnl.errors import AnalysisError
from obsnl.model.branching.branches import derived_model
from obsnl.model.core import Model

if TYPE_CHECKING:  # networkx loads on first use (fast `import obsnl`)
    import networkx as nx

__all__ = ["dependency_graph", "decompose", "Decomposition", "output_reachable"]


def dependency_graph(model: Model) -> nx.DiGraph:
    """The dependency digraph of ``model`` (node = name, attribute ``role``).

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="m", states=["x", "z"], parameters=["a", "b"],
    ...           equations={"x": "-a*x", "z": "-b*z"}, outputs={"y": "x"})
    >>> g = dependency_graph(m)
    >>> sorted(g.predecessors("y")), sorted(g.predecessors("x"))
    (['x'], ['a', 'x'])
    """
    import networkx as nx

    g = nx.DiGraph()
    for role in ("states", "parameters", "inputs", "unknown_inputs", "known_constants"):
        for s in getattr(model, role):
            g.add_node(s.name, role=role[:-1] if role != "unknown_inputs" else "unknown_input")
    for name in model.outputs:
        g.add_node(name, role="output")
    for s in model.states:
        for v in model.equations[s].free_symbols:
            g.add_edge(v.name, s.name)
        if s in model.initial_condition_values:
            for v in model.initial_condition_values[s].free_symbols:
                g.add_edge(v.name, s.name)
    for name, expr in model.outputs.items():
        for v in expr.free_symbols:
            g.add_edge(v.name, name)
    return g


@dataclass(frozen=True)
class Decomposition:
    """Result of :func:`decompose`.

    Attributes
    ----------
    unreachable
        Unknown states and parameters (and unknown inputs) with no path to any output.
    blocks
        Closed submodels with pairwise disjoint unknowns, one per independent output group.
    report
        What was done, in words (for a result's notes).
    """

    unreachable: tuple[str, ...]
    blocks: tuple[Model, ...]
    report: tuple[str, ...]


def decompose(model: Model) -> Decomposition:
    """Split ``model`` into its output-reachable, independent blocks (exact, see module doc).

    Raises
    ------
    AnalysisError
        When the model has no outputs.

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="m", states=["x", "z"], parameters=["a", "b"],
    ...           equations={"x": "-a*x", "z": "-b*z"}, outputs={"y": "x"})
    >>> d = decompose(m)
    >>> d.unreachable, [list(map(str, b.states)) for b in d.blocks]
    (('z', 'b'), [['x']])
    """
    if not model.outputs:
        raise AnalysisError(f"model {model.name!r} has no outputs; add at least one measured quantity")
    parents, role = _parents(model)
    known = set(model.known_initial_conditions)
    unknowns = [s.name for s in model.states if s not in known] + [s.name for s in model.parameters]
    unknowns += [s.name for s in model.unknown_inputs]
    anc = {y: _ancestors(parents, y) for y in model.outputs}
    relevant = set().union(*anc.values())  # (F1), as output_reachable
    unreachable = tuple(v for v in unknowns if v not in relevant)
    # group outputs whose ancestor sets share a state or an unknown (union-find over outputs)
    shared_roles = {"state", "parameter", "unknown_input"}
    outs = list(model.outputs)
    group = {y: y for y in outs}

    def find(y: str) -> str:
        while group[y] != y:
            group[y] = group[group[y]]
            y = group[y]
        return y

    for i, y1 in enumerate(outs):
        for y2 in outs[i + 1 :]:
            if any(role.get(v) in shared_roles for v in anc[y1] & anc[y2]):
                group[find(y1)] = find(y2)
    by_root: dict[str, list[str]] = {}
    for y in outs:
        by_root.setdefault(find(y), []).append(y)
    comps = list(by_root.values())
    comps.sort(key=lambda c: outs.index(c[0]))
    # an output group that reaches no state (it measures parameters only) joins another group
    states = {s.name for s in model.states}
    with_states = [c for c in comps if any(v in states for y in c for v in anc[y])]
    if not with_states:
        raise AnalysisError(f"no output of model {model.name!r} depends on a state; measure at least one state")
    for c in comps:
        if c not in with_states:
            with_states[0].extend(c)
    comps = with_states
    report: list[str] = []
    if unreachable:
        report.append("no path to any output (unobservable, not analysed): " + ", ".join(unreachable))
    blocks: list[Model] = []
    if len(comps) == 1 and not unreachable:
        return Decomposition(unreachable=(), blocks=(model,), report=())
    for comp in comps:
        names = set().union(*(anc[y] for y in comp))
        blocks.append(_submodel(model, comp, names, len(blocks) if len(comps) > 1 else None))
    if len(comps) > 1:
        report.append(
            f"{len(comps)} independent blocks analysed separately: "
            + "; ".join(
                f"[{', '.join(c)}] <- {', '.join(s.name for s in b.states + b.parameters)}"
                for c, b in zip(comps, blocks)
            )
        )
    return Decomposition(unreachable=unreachable, blocks=tuple(blocks), report=tuple(report))


def output_reachable(model: Model) -> set[str]:
    """Names with a path to an output in the dependency graph (F1: the others are unobservable).

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="m", states=["x", "z"], parameters=["a", "b"],
    ...           equations={"x": "-a*x", "z": "-b*z"}, outputs={"y": "x"})
    >>> sorted(output_reachable(m))
    ['a', 'x']
    """
    parents, _ = _parents(model)
    return set().union(*(_ancestors(parents, y) for y in model.outputs))


def _parents(model: Model) -> tuple[dict[str, set[str]], dict[str, str]]:
    """The dependency graph of :func:`dependency_graph` as parent sets, and each name's role."""
    role: dict[str, str] = {}
    for r in ("states", "parameters", "inputs", "unknown_inputs", "known_constants"):
        for s in getattr(model, r):
            role[s.name] = r[:-1] if r != "unknown_inputs" else "unknown_input"
    parents: dict[str, set[str]] = {}
    for s in model.states:
        ps = {v.name for v in model.equations[s].free_symbols}
        if s in model.initial_condition_values:
            ps |= {v.name for v in model.initial_condition_values[s].free_symbols}
        parents[s.name] = ps
    for name, expr in model.outputs.items():
        parents[name] = {v.name for v in expr.free_symbols}
    return parents, role


def _ancestors(parents: dict[str, set[str]], node: str) -> set[str]:
    seen: set[str] = set()
    stack = list(parents.get(node, ()))
    while stack:
        v = stack.pop()
        if v not in seen:
            seen.add(v)
            stack.extend(parents.get(v, ()))
    return seen


def _submodel(model: Model, outputs: list[str], names: set[str], index: int | None) -> Model:
    """The block of ``model`` on ``names`` (built from the model's validated parts, no re-parsing)."""
    keep = lambda syms: tuple(s for s in syms if s.name in names)  # noqa: E731
    states = keep(model.states)
    if not states:
        raise AnalysisError(
            f"output {outputs[0]!r} of model {model.name!r} does not depend on any state; an output must "
            f"measure at least one state"
        )
    sset = set(states)
    return derived_model(
        model,
        name=model.name if index is None else f"{model.name}[{index}]",
        states=states,
        parameters=keep(model.parameters),
        equations={s: model.equations[s] for s in states},
        outputs={y: model.outputs[y] for y in outputs},
        inputs=keep(model.inputs),
        unknown_inputs=keep(model.unknown_inputs),
        known_constants=keep(model.known_constants),
        known_initial_conditions=tuple(s for s in model.known_initial_conditions if s in sset),
        initial_condition_values={s: v for s, v in model.initial_condition_values.items() if s in sset},
        description="",
        source="",
        switching=(),
        latex={},
        values={},
        definitions={},
        metadata={},
    )
