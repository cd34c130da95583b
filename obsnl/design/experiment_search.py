"""The searches of an experiment design (:func:`obsnl.design.experiment.design`): which targets no scale can make
identifiable, the scales whose simulation blew up, the bisection of the smallest sufficient scale, and the minimal
sufficient subsets of the records.

**Structural first.** A visited set is a subset of the feasible branches, and fewer branches never add rows to the
joint verdict: a target that is not jointly identifiable with the chosen sensors when *every* branch is visited (the
verdict :func:`obsnl.sensors` starts from) is not identifiable at any scale (:func:`structural_targets`). The design
names those targets up front, with the symmetries that move them, and searches the scale for the others only.

**Blow-ups.** The visits come from a simulation with fixed steps (:mod:`obsnl.design.continuous`: RK4 substeps,
split at located crossings, ROS2 where a step is stiff); a large scale can make it diverge, or carry the state where
the model is not defined (a non-finite state either way). Such a scale is a :class:`BlowUp` (the scale, the record, the time), never a verdict: the grid stops there (a
larger excitation of the same record is no better behaved with the same step), the answer is given from the scales
that ran, and a search the blow-up cut short is inconclusive above the last scale that ran, never "none suffices".
A bisection point that blows up ends the bisection on its bracket, which is not narrowed past it.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from obsnl.design.sufficiency import check_sensors
from obsnl.errors import AnalysisError
from obsnl.model.core import Model
from obsnl.observability.joint.visited import BlewUp

__all__ = [
    "BlowUp",
    "ScaleBlewUp",
    "blow_up",
    "no_scale_ran",
    "structural_targets",
    "search_scales",
    "scale_notes",
    "minimal_records",
    "NOT_NOISE",
]

#: Why a sufficient scale says nothing about noise (the reading of ``min_scale`` the design warns against).
NOT_NOISE = (
    "a structural statement (which branches the record visits), not about noise: whether so small a "
    "response can be measured well enough is a practical question (rank the sensors along the record "
    "by the Cramer-Rao bound: rank_sensor_sets)"
)
#: Why the grid stops at a blow-up.
_STOPS = "a larger excitation of the same record is no better behaved with the simulation's fixed step"


@dataclass(frozen=True)
class BlowUp:
    """A scale at which the simulation of a record blew up (a non-finite state) and so gave no verdict.

    Attributes
    ----------
    scale, record
        The factor on the records and the record whose simulation failed.
    time
        The time at which the state stopped being finite (None: the scaled record itself overflows).
    reason
        The simulation's message.
    """

    scale: float
    record: str
    time: float | None
    reason: str

    def text(self) -> str:
        """``scale 256: the simulation of record 'r' blew up at t = 7.12``."""
        when = f"at t = {self.time:.4g}" if self.time is not None else "(the scaled record overflows)"
        return f"scale {self.scale:g}: the simulation of record {self.record!r} blew up {when}"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields."""
        return {"scale": self.scale, "record": self.record, "time": self.time, "reason": self.reason}


class ScaleBlewUp(Exception):
    """Raised by a design's simulation at a scale that blew up; carries the :class:`BlowUp`."""

    def __init__(self, blow: BlowUp) -> None:
        super().__init__(blow.text())
        self.blow = blow


def blow_up(err: AnalysisError, scale: float, record: str) -> BlowUp | None:
    """The :class:`BlowUp` that the simulation's error ``err`` reports, or None for another error.

    Parameters
    ----------
    err : AnalysisError
        What the simulation (:meth:`obsnl.design.continuous.TrajectoryVisits.visits`) raised.
    scale : float
        The factor on the record.
    record : str
        The record's name.

    Returns
    -------
    BlowUp or None
        None for an error that is not a blow-up (a missing number, the time limit): it is raised as it is.

    Examples
    --------
    >>> blow_up(BlewUp(7.12), 256.0, "r").time
    7.12
    >>> blow_up(AnalysisError("record= simulates the model's [values]: give a number for k"), 1.0, "r") is None
    True
    """
    return BlowUp(float(scale), record, err.time, str(err)) if isinstance(err, BlewUp) else None


def no_scale_ran(blow: BlowUp) -> AnalysisError:
    """The one-line error of a design whose smallest scale already blew up (so no scale ran).

    Parameters
    ----------
    blow : BlowUp
        The blow-up at the smallest scale tried.

    Returns
    -------
    AnalysisError
    """
    return AnalysisError(
        f"no scale ran: the simulation of record {blow.record!r} blew up at the smallest scale "
        f"tried, {blow.scale:g}"
        + (f" (t = {blow.time:.4g})" if blow.time is not None else "")
        + f"; give smaller scales= (below {blow.scale:g}), or check the [values] and the record's "
        "amplitude"
    )


def structural_targets(
    model: Model, sub: Model, targets: tuple[str, ...], *, seed: int, max_seconds: float | None
) -> tuple[tuple[str, ...], str, bool]:
    """The targets no scale makes identifiable: the joint verdict with the design's sensors over every branch.

    Parameters
    ----------
    model : Model
        The model with every candidate sensor as an output.
    sub : Model
        The model restricted to the design's sensors.
    targets : tuple of str
        The targets of the design.
    seed : int
        Seed of the analysis and of the symmetry search.
    max_seconds : float or None
        Time limit of the analysis.

    Returns
    -------
    tuple
        The targets unidentifiable at every scale (in the order of ``targets``), why in words (the symmetries that
        move them; empty when there are none), and whether every other target was proven identifiable over every
        branch.

    Raises
    ------
    AnalysisError
        Every target unidentifiable: no scale to search.
    """
    from obsnl.design.sensors import shared_symmetry_text

    lost: tuple[str, ...] = ()
    left = targets
    while True:  # a target with no path to the sensors stops the test before the analysis: test the others too
        whole = check_sensors(model, sub.output_names, left, seed=seed, max_seconds=max_seconds)
        lost += whole.missing
        left = tuple(n for n in left if n not in whole.missing)
        if whole.how != "reachability" or not left:
            break
    if not lost:
        return (), "", not whole.undecided
    lost = tuple(n for n in targets if n in lost)
    gens = shared_symmetry_text(sub, seed)
    why = (
        f"{', '.join(lost)} {'is' if len(lost) == 1 else 'are'} structurally unidentifiable whatever the scale "
        f"(not jointly identifiable with {', '.join(sub.output_names)} even when every branch is visited"
        f"{'; ' + gens if gens else ''}): reparametrize with `obsnl reparametrize`, or add sensors"
    )
    if not left:
        raise AnalysisError(f"{why}; no target is left whose scale could be searched")
    return lost, why, not whole.undecided


def minimal_records(runs: Any) -> tuple[tuple[tuple[str, ...], ...], tuple[tuple[str, ...], ...], tuple[str, ...]]:
    """Minimal sufficient subsets of the records at scale 1, smallest first, the undecided subsets, and the records
    left out because they blew up at scale 1 (or already at a smaller scale: not tried at 1).

    Parameters
    ----------
    runs : Any
        The simulations and verdicts of the design (``runs``, ``blowups``, ``simulate``, ``union``, ``verdict``).

    Returns
    -------
    tuple
    """
    names = [r[0] for r in runs.runs]
    ran = []
    for i in range(len(names)):
        if any(j == i and s <= 1.0 for j, s in runs.blowups):
            continue
        try:
            runs.simulate(i, 1.0)
            ran.append(i)
        except ScaleBlewUp:
            pass
    left_out = tuple(n for i, n in enumerate(names) if i not in ran)
    if not ran or runs.verdict(*runs.union(ran, 1.0)[:2]).sufficient is False:  # no subset of an insufficient union
        return (), (), left_out
    out: dict[bool | None, list[tuple[str, ...]]] = {True: [], None: []}
    for size in range(1, len(ran) + 1):
        for combo in itertools.combinations(ran, size):
            if any(set(f) <= {names[i] for i in combo} for f in out[True]):  # a superset of a sufficient one
                continue
            ok = runs.verdict(*runs.union(combo, 1.0)[:2]).sufficient
            if ok is not False:
                out[ok].append(tuple(names[i] for i in combo))
    return tuple(out[True]), tuple(out[None]), left_out


def search_scales(
    runs: Any, grid: Sequence[Any], tol: float, cut: BlowUp | None = None, reachable: bool = False
) -> tuple[Any, ...]:
    """``(min_scale, bracket, status, reason, bisection points)`` from the verdicts at the grid scales that ran.

    Parameters
    ----------
    runs : Any
        What simulates a scale and gives its verdict (``runs.at(scale, bisection=True)``, raising
        :class:`ScaleBlewUp` at a scale that blows up).
    grid : sequence of ScaleVisit
        The grid scales that ran, increasing.
    tol : float
        Relative width at which the bisection stops.
    cut : BlowUp or None
        The grid scale whose simulation blew up (the grid stopped there), if any.
    reachable : bool
        Whether every target was proven identifiable when every branch is visited (said when no scale suffices).

    Returns
    -------
    tuple
        ``min_scale`` (or None), the bracket ``(lo, hi)``, the status, the reason and the bisection points.
    """
    first = next((i for i, v in enumerate(grid) if v.sufficient), None)
    proven = ([v.scale for v in grid[:first] if v.sufficient is False] or [None])[-1]  # largest insufficient
    top = grid[-1]
    stop = (
        (
            f"; the search was cut by the blow-up at {cut.text()} (larger scales not tried: {_STOPS}): "
            f"inconclusive above {top.scale:g}"
        )
        if cut is not None
        else ""
    )
    if first is None and top.sufficient is False:
        left = f" ({', '.join(top.undecided)} undecided)" if top.undecided else ""
        lost = (
            f"at the largest scale {'that ran' if cut else 'tried'}, {top.scale:g}, {', '.join(top.missing)} "
            f"stay unidentifiable{left}"
        )
        if cut is not None:
            return None, (top.scale, None), "inconclusive", f"no scale that ran suffices: {lost}{stop}", []
        more = (
            (
                " (identifiable once every branch is visited: a larger scale or another record may reach the "
                "branches they need)"
            )
            if reachable
            else ""
        )
        return None, (top.scale, None), "none_suffices", lost + more, []
    if first is None:
        return (
            None,
            (proven, None),
            "inconclusive",
            (
                f"no scale is proven sufficient; at the largest scale {'that ran, ' if cut else ''}{top.scale:g}: "
                f"{top.reason}{stop}"
            ),
            [],
        )
    lo, hi = (grid[first - 1].scale if first else None), grid[first].scale
    if first == 0:
        return (
            None,
            (None, hi),
            "smallest_suffices",
            (
                f"the smallest scale tried, {hi:g}, already visits branches that make the targets jointly identifiable: "
                f"min_scale is at most {hi:g} (give smaller scales to estimate it); {NOT_NOISE}"
            ),
            [],
        )
    if grid[first - 1].sufficient is None:
        return (
            None,
            (proven, hi),
            "inconclusive",
            (f"the verdict at scale {lo:g} is inconclusive ({grid[first - 1].reason}); scale {hi:g} suffices"),
            [],
        )
    points: list[Any] = []
    while (hi - lo) / hi > tol:
        mid = math.sqrt(lo * hi)
        try:
            points.append(v := runs.at(mid, bisection=True))
        except ScaleBlewUp as exc:  # no verdict there: the bracket stays what the scales that ran prove
            return (
                None,
                (lo, hi),
                "inconclusive",
                (
                    f"the bisection stopped at {exc.blow.text()}, between {lo:.6g} (insufficient) and {hi:.6g} "
                    f"(sufficient), which ran; the boundary lies in [{lo:.6g}, {hi:.6g}]"
                ),
                points,
            )
        if v.sufficient is None:
            why = f"the verdict at scale {v.scale:.6g} is inconclusive ({v.reason})"
            return None, (lo, hi), "inconclusive", f"{why}; the boundary lies in [{lo:.6g}, {hi:.6g}]", points
        lo, hi = (lo, v.scale) if v.sufficient else (v.scale, hi)
    return hi, (lo, hi), "found", f"scale {hi:.6g} suffices, {lo:.6g} does not", points


def scale_notes(grid: Sequence[Any], hi: float | None) -> tuple[str, ...]:
    """Where the visited set does not grow with the scale (the assumption of the bisection).

    Parameters
    ----------
    grid : sequence of ScaleVisit
        The grid scales that ran, increasing.
    hi : float or None
        The sufficient end of the bracket found (None: no bracket).

    Returns
    -------
    tuple of str
    """

    def pattern(signs: Sequence[int]) -> str:
        return "".join("+" if s > 0 else "-" for s in signs)

    shrink = [(a, b, {x.signs for x in a.branches} - {x.signs for x in b.branches}) for a, b in zip(grid, grid[1:])]
    notes = [
        f"scale {a.scale:g} visits {', '.join(pattern(s) for s in lost)}, which scale {b.scale:g} does not: "
        f"the visited set does not grow with the scale there"
        for a, b, lost in shrink
        if lost
    ][:1]
    worse = [v.scale for v in grid if hi is not None and v.scale > hi and v.sufficient is False]
    if worse:
        notes.append(
            f"scale(s) {', '.join(f'{s:g}' for s in worse)} above the sufficient boundary are insufficient: "
            f"the bracket is a sufficient boundary, not necessarily the only one"
        )
    return tuple(notes)
