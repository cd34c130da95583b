"""Does one set of sensors make the targets jointly identifiable? The test every search of
:mod:`obsnl.design` is built on.

A sensor set is a subset of the model's outputs (a model lists every quantity one could measure). The
model restricted to those outputs is tested in two steps:

1. **Reachability** (exact, no random point): a target with no path to any of the chosen outputs in
   the dependency graph (:func:`obsnl.observability.engines.decompose.output_reachable`) is unobservable, so
   the set is insufficient without an analysis.
2. **The joint verdict** (:func:`obsnl.analyze` with ``per_branch=False``): the targets must all be
   jointly observable over the visited branches (every feasible branch, or the ones a record visits),
   with the model's unknown-input assumption. A target the joint verdict leaves inconclusive makes the
   answer inconclusive (``sufficient is None``), never a guess.

Monotonicity, on which the searches rest: adding an output adds rows to every visit's observability
matrix (and can only make more crossings visible), so a superset of a sufficient set is sufficient and a
subset of an insufficient set is insufficient.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from obsnl._text import names as name_list
from obsnl._text import quote
from obsnl.design.arguments import names_argument
from obsnl.errors import OptionError
from obsnl.model.core import Model
from obsnl.observability.analyze import analyze
from obsnl.observability.engines.decompose import output_reachable

__all__ = ["Sufficiency", "resolve_targets", "restrict", "unreached", "check_sensors"]


@dataclass(frozen=True)
class Sufficiency:
    """The answer for one sensor set.

    Attributes
    ----------
    sensors
        The outputs used, in the model's order.
    sufficient
        True: every target jointly identifiable; False: some target is not; None: undecided.
    missing
        Targets proven not jointly identifiable with these sensors.
    undecided
        Targets the analysis could not decide (with ``reason``).
    how
        ``"reachability"`` (decided from the dependency graph alone), ``"analysis"`` (the joint verdict)
        or ``"implied"`` (by monotonicity from another set, named in ``reason``).
    reason
        Why the set is insufficient or undecided, in words.
    probability
        Lower bound on the probability that the analysis' verdicts are right (1.0 for reachability and
        for a full-rank certificate; None when implied).
    seed
        Seed of the analysis (None when none ran).
    seconds
        Wall time of the test.
    visited
        How the analysed branches were chosen (the analysis' note; empty when none ran).
    """

    sensors: tuple[str, ...]
    sufficient: bool | None
    missing: tuple[str, ...] = ()
    undecided: tuple[str, ...] = ()
    how: str = "analysis"
    reason: str = ""
    probability: float | None = None
    seed: int | None = None
    seconds: float = 0.0
    visited: str = field(default="", compare=False)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields."""
        return {
            "sensors": list(self.sensors),
            "sufficient": self.sufficient,
            "missing": list(self.missing),
            "undecided": list(self.undecided),
            "how": self.how,
            "reason": self.reason,
            "probability": self.probability,
            "seed": self.seed,
            "seconds": round(self.seconds, 4),
            "visited": self.visited,
        }


def resolve_targets(model: Model, target: str | Sequence[str] = "all") -> tuple[str, ...]:
    """The names a search must make identifiable.

    Parameters
    ----------
    model : Model
        The model.
    target : str or sequence of str
        ``"all"`` (every state and parameter), ``"parameters"``, or names of states and parameters (a
        sequence, or one comma-separated string).

    Returns
    -------
    tuple of str
        The targets in the model's order (states, then parameters).

    Raises
    ------
    OptionError
        An empty target or a name that is neither a state nor a parameter.

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="m", states=["x"], parameters=["a", "b"], equations={"x": "-a*x + b"},
    ...           outputs={"y": "x"})
    >>> resolve_targets(m), resolve_targets(m, "parameters"), resolve_targets(m, "b, x")
    (('x', 'a', 'b'), ('a', 'b'), ('x', 'b'))
    """
    order = [s.name for s in model.states] + [p.name for p in model.parameters]
    target = names_argument(target, "target")
    if isinstance(target, str) and target.strip() == "all":
        return tuple(order)
    if isinstance(target, str) and target.strip() == "parameters":
        if not model.parameters:  # nothing to make identifiable: every sensor set would trivially suffice
            raise OptionError(
                f"target 'parameters' names nothing: {quote(model.name)} has no parameters; give all "
                f"or names of its states"
            )
        return tuple(p.name for p in model.parameters)
    names = [n.strip() for n in (target.split(",") if isinstance(target, str) else target)]
    names = [n for n in names if n]
    if not names:
        raise OptionError("the target is empty: give all, parameters, or names of states and parameters")
    bad = [n for n in names if n not in order]
    if bad:
        raise OptionError(
            f"target {name_list(map(quote, bad), 3)} is not a state or parameter of {quote(model.name)}; "
            f"choose among {name_list(order, 20)}"
        )
    return tuple(n for n in order if n in names)


def restrict(model: Model, sensors: Sequence[str]) -> Model:
    """``model`` with only the outputs ``sensors`` (in the model's order).

    Parameters
    ----------
    model : Model
        The model with every candidate sensor as an output.
    sensors : sequence of str
        Names of the outputs to keep.

    Returns
    -------
    Model

    Raises
    ------
    OptionError
        No sensor, or a name that is not an output of the model.

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="m", states=["x", "v"], parameters=["k"], equations={"x": "v", "v": "-k*x"},
    ...           outputs={"d": "x", "s": "v"})
    >>> restrict(m, ["s"]).output_names
    ('s',)
    """
    names = list(sensors)
    if not names:
        raise OptionError("a sensor set needs at least one output")
    bad = [n for n in names if n not in model.outputs]
    if bad:
        raise OptionError(
            f"{name_list(map(quote, bad), 3)} is not an output of {quote(model.name)}; "
            f"the candidate sensors are {name_list(model.output_names, 20)}"
        )
    keep = {n: model.outputs[n] for n in model.output_names if n in names}
    return model.replace(outputs=keep)


def unreached(names: Sequence[str], lost: Sequence[str], seconds: float = 0.0) -> Sufficiency:
    """The answer for the outputs ``names`` that the targets ``lost`` have no path to: insufficient, exactly.

    Parameters
    ----------
    names : sequence of str
        The outputs of the set, in the model's order.
    lost : sequence of str
        The targets with no path to any of them in the dependency graph.
    seconds : float
        Wall time of the test.

    Returns
    -------
    Sufficiency
    """
    return Sufficiency(
        tuple(names),
        False,
        missing=tuple(lost),
        how="reachability",
        probability=1.0,
        reason=f"{', '.join(lost)} {'has' if len(lost) == 1 else 'have'} no path to "
        f"{', '.join(names)} in the dependency graph",
        seconds=seconds,
    )


def check_sensors(
    model: Model,
    sensors: Sequence[str],
    targets: Sequence[str],
    *,
    seed: int = 0,
    prob: float = 0.99,
    max_seconds: float | None = None,
    visited: Mapping[tuple[int, ...], float] | None = None,
    crossings: Mapping[str, int] | None = None,
) -> Sufficiency:
    """Whether the outputs ``sensors`` make every name of ``targets`` jointly identifiable.

    Parameters
    ----------
    model : Model
        The model with every candidate sensor as an output.
    sensors : sequence of str
        The outputs used.
    targets : sequence of str
        States and parameters that must be identifiable (:func:`resolve_targets`).
    seed : int
        Passed to :func:`obsnl.analyze`.
    prob : float
        Passed to :func:`obsnl.analyze`.
    max_seconds : float or None
        Passed to :func:`obsnl.analyze`.
    visited : mapping of tuple of int to float or None
        Sign patterns an experiment visits (of the restricted model's switching functions, see
        :class:`obsnl.design.continuous.TrajectoryVisits`); None: every feasible branch; empty: none (insufficient
        for every target: the verdict reads branches only).
    crossings : mapping of str to int or None
        ``{switching function: number of sign changes}`` along the same experiment (passed to
        :func:`obsnl.analyze`).

    Returns
    -------
    Sufficiency

    Examples
    --------
    >>> from obsnl import Model
    >>> m = Model(name="two", states=["x", "z"], parameters=["a", "b"],
    ...           equations={"x": "-a*x", "z": "-b*z"}, outputs={"y1": "x", "y2": "z", "s": "x + z"})
    >>> check_sensors(m, ["y1"], ["a", "b"]).missing
    ('b',)
    >>> check_sensors(m, ["s"], ["a", "b"]).sufficient
    True
    """
    t0 = time.perf_counter()
    sub = restrict(model, sensors)
    names = tuple(sub.output_names)
    reach = output_reachable(sub)
    lost = tuple(n for n in targets if n not in reach)
    if lost:
        return unreached(names, lost, time.perf_counter() - t0)
    if visited is not None and not visited:  # the experiment reveals no branch's dynamics: nothing to analyse
        return Sufficiency(
            names,
            False,
            missing=tuple(targets),
            how="analysis",
            reason="the experiment visits no branch (the state rests on a switching surface throughout, as a mass "
            "that friction holds): no target is revealed by a branch",
            probability=1.0,
            seconds=time.perf_counter() - t0,
            visited="no branch visited",
        )
    res = analyze(
        sub, seed=seed, prob=prob, max_seconds=max_seconds, visited=visited, crossings=crossings, per_branch=False
    )
    joint = res.joint
    note = res.visited.note if res.visited is not None else ""
    if joint is None:  # every branch undecided: nothing was analysed
        return Sufficiency(
            names,
            None,
            undecided=tuple(targets),
            reason="no branch could be analysed: " + "; ".join(b.reason for b in res.branches),
            seed=res.seed,
            seconds=time.perf_counter() - t0,
            visited=note,
        )
    unobs, incon = set(joint.unobservable), set(joint.inconclusive)
    missing = tuple(n for n in targets if n in unobs)
    undecided = tuple(n for n in targets if n in incon)
    sufficient = False if missing else (None if undecided else True)
    if missing:
        reason = f"{', '.join(missing)} not jointly identifiable"
    elif undecided:
        reason = f"{', '.join(undecided)} undecided: {joint.reason}"
    else:
        reason = ""
    return Sufficiency(
        names,
        sufficient,
        missing=missing,
        undecided=undecided,
        how="analysis",
        reason=reason,
        probability=joint.probability,
        seed=res.seed,
        seconds=time.perf_counter() - t0,
        visited=note,
    )
