"""Which experiment makes a model identifiable: the branches a record visits as its amplitude grows, the
smallest amplitude that makes every target jointly identifiable, and which of several records suffice.

The model's ``[values]`` are simulated under ``s * record`` (:class:`obsnl.design.continuous.TrajectoryVisits`: the
fit's located, sliding step; the input between samples as the model's ``[intersample]`` table or ``intersample=``
says; from the known initial state, which is not scaled); the sign patterns along the continuous trajectory (a
contact that opens and closes between two samples included, a mass that friction holds on no branch) are the
branches the experiment at scale ``s`` visits, and the set suffices when :func:`obsnl.design.sufficiency.check_sensors` with
``visited=`` that set finds every target jointly identifiable. The verdict depends on the visited *set*
only (seconds and crossings are reported, not analysed): it is cached by the frozenset of patterns.

**The scale.** The default grid is the powers of 2 from ``2**-10`` to ``2**10`` (about 1e-3 to 1e3). The first
sufficient grid scale and the one below it bracket the smallest sufficient scale; the bracket is bisected (geometric
mid-points) until ``(hi - lo) / hi <= tol``. This assumes that the visited set grows with the scale (a larger motion
reaches every branch a smaller one does). When it does not, the bisection still ends on a boundary between an
insufficient ``lo`` and a sufficient ``hi`` (both simulated), reported with the bracket (not always the smallest
sufficient scale); :attr:`ExperimentDesign.notes` says where the visited set shrank and which larger grid scales fail.

**Structural first; blow-ups** (:mod:`obsnl.design.experiment_search`). Targets that the sensors leave unidentifiable
even when every branch is visited are named up front (:attr:`ExperimentDesign.structural`) and the scale is searched
for the others; all of them unidentifiable is an error. A scale whose fixed-step simulation blows up (a non-finite
state) gives no verdict: it is listed in :attr:`ExperimentDesign.blowups`, the larger grid scales are not tried and
the answer comes from the scales that ran (inconclusive above them when none of those suffices).

**Several records** are experiments sharing the parameters, each with its own states: their verdict is the joint
verdict over the union of their visited patterns (obsnl's joint verdict gives every visit its own states already). It
also pairs switching surfaces between visited branches, which may come from different records: a crossing it credits
may be one no single record makes. ``sufficient_records`` are the minimal subsets of the records (at scale 1) whose
union suffices, by increasing size; a superset of a sufficient subset is sufficient (more branches add rows to the
verdict) and is not listed.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Union, cast

import numpy as np

from obsnl._display import render
from obsnl._text import block, one_line
from obsnl._types import JSONValue
from obsnl.design.arguments import design_arguments, record_run
from obsnl.design.continuous import Drive, TrajectoryVisits
from obsnl.design.experiment_search import (
    NOT_NOISE,
    BlowUp,
    ScaleBlewUp,
    blow_up,
    minimal_records,
    no_scale_ran,
    structural_targets,
)
from obsnl.design.experiment_search import scale_notes as _notes
from obsnl.design.experiment_search import search_scales as _search
from obsnl.design.sufficiency import Sufficiency, check_sensors, resolve_targets, restrict
from obsnl.errors import AnalysisError, NotSupportedError, OptionError
from obsnl.estimation.accelerogram import Record
from obsnl.estimation.measured import is_frame
from obsnl.model.bounds.budget import check_time, remaining, time_budget
from obsnl.model.branching.branches import split_branches
from obsnl.model.core import Model
from obsnl.observability.analyze import assumptions as analysis_assumptions
from obsnl.observability.assumptions import Assumptions
from obsnl.observability.joint.visited import Visits

__all__ = [
    "VisitedBranch",
    "ScaleVisit",
    "DesignAssumptions",
    "ExperimentDesign",
    "BlowUp",
    "design",
    "DEFAULT_SCALES",
    "MAX_RECORDS",
]

#: The default scales: powers of 2 from 2**-10 (about 1e-3) to 2**10 (about 1e3), 21 of them, 1 among them.
DEFAULT_SCALES = tuple(2.0**k for k in range(-10, 11))
#: Most records of one design (the search of sufficient subsets visits at most ``2**MAX_RECORDS - 1``).
MAX_RECORDS = 12
#: Most switching functions whose visited patterns get branch labels (beyond, the sign pattern names a branch).
LABEL_UP_TO = 8

#: A record: a :class:`~obsnl.estimation.accelerogram.Record` or ``(name, t, {input: samples})``.
RecordLike = Union[Record, "tuple[str, Any, Mapping[str, Any]]"]


#: What a design assumes besides the analysis' own assumptions.
_ASSUMED = {
    "visited": "sign patterns of the model's [values] simulated under each scaled record along the continuous "
    "trajectory (crossings located between samples; a state resting on a switching surface, as a mass that friction "
    "holds, visits no branch)",
    "scale": "the visited set grows with the scale; if not, the bisection ends on a sufficient boundary (the bracket)",
    "records": "experiments sharing the parameters, each with its own states; the joint verdict pairs switching "
    "surfaces between visited branches, which may come from different records",
    "sufficient_records": "at scale 1; a superset of a sufficient subset is sufficient and not listed",
    "structural": "targets not jointly identifiable when every branch is visited are so at every scale: named, "
    "not searched",
    "blow-ups": "a scale whose fixed-step simulation blows up gives no verdict; the larger grid scales are not tried",
    "min_scale": NOT_NOISE,
}


@dataclass(frozen=True)
class DesignAssumptions:
    """What every verdict of a design assumes: the analysis' own, how the records were simulated, and the rules of
    the search (written by :meth:`to_dict` after the analysis' keys, from a table of fixed sentences).

    Attributes
    ----------
    analysis
        The assumptions of the joint verdicts (:class:`~obsnl.observability.assumptions.Assumptions`, unknown inputs
        arbitrary, known inputs generic).
    between_samples
        ``{input: kind}``: how each input was simulated between its samples (``zoh``, ``linear``, ``bandlimited``).
    initial_state
        ``{state: value as text}``: where the simulations started (the model's values or known initial conditions).
    """

    analysis: Assumptions
    between_samples: Mapping[str, str]
    initial_state: Mapping[str, str]

    def to_dict(self) -> dict[str, JSONValue]:
        """JSON-ready: the analysis' keys, the search's rules (``visited``, ``scale``, ``records``, ...), then
        ``between samples`` and ``initial state``."""
        return {
            **self.analysis.to_dict(),
            **_ASSUMED,
            "between samples": dict(self.between_samples),
            "initial state": dict(self.initial_state),
        }


def _pattern(signs: Sequence[int]) -> str:
    return "".join("+" if s > 0 else "-" for s in signs)


@dataclass(frozen=True)
class VisitedBranch:
    """One visited branch: its sign pattern, its label (None when not enumerated) and the seconds in it."""

    signs: tuple[int, ...]
    label: str | None
    seconds: float

    @property
    def pattern(self) -> str:
        """The signs as ``+`` and ``-`` (empty for a smooth model)."""
        return _pattern(self.signs)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields."""
        return {"pattern": _pattern(self.signs), "label": self.label, "seconds": round(self.seconds, 6)}


@dataclass(frozen=True)
class ScaleVisit:
    """What the records scaled by ``scale`` visit and whether that suffices.

    Attributes
    ----------
    scale, branches, crossings
        The factor on every record; the visited branches (union over the records, seconds summed) in order
        of first visit; sign changes per switching function (summed).
    sufficient, missing, undecided, reason
        The joint verdict over ``branches`` (True, False or None: inconclusive), the targets proven not identifiable
        and those undecided, and why (:attr:`Sufficiency.reason`).
    bisection, by_record
        True for a point of the bisection; the sign patterns each record visits (several records only).
    """

    scale: float
    branches: tuple[VisitedBranch, ...]
    crossings: Mapping[str, int]
    sufficient: bool | None
    missing: tuple[str, ...] = ()
    undecided: tuple[str, ...] = ()
    reason: str = ""
    bisection: bool = False
    by_record: Mapping[str, tuple[tuple[int, ...], ...]] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready fields."""
        return {
            "scale": self.scale,
            "bisection": self.bisection,
            "sufficient": self.sufficient,
            "patterns": [b.to_dict() for b in self.branches],
            "crossings": dict(self.crossings),
            "missing": list(self.missing),
            "undecided": list(self.undecided),
            "reason": self.reason,
            "by_record": {k: [_pattern(p) for p in v] for k, v in self.by_record.items()},
        }


@dataclass(frozen=True)
class ExperimentDesign:
    """The answer of :func:`design`.

    Attributes
    ----------
    model, targets, sensors, records, switching
        The model's name, the targets, the outputs used, the records' names and the switching functions
        (the order of the signs of every pattern).
    visits
        One :class:`ScaleVisit` per simulated scale (grid and bisection), by increasing scale.
    min_scale, bracket
        The smallest sufficient scale found (``hi`` of a bracket at most ``tol`` wide), or None; the bracket
        ``(lo, hi)``: ``hi`` sufficient, ``lo`` proven insufficient, None where no such scale is known.
    status, reason, tol
        ``"found"``; ``"smallest_suffices"`` (the smallest scale suffices: ``min_scale`` is at most it and
        is not estimated); ``"none_suffices"`` (not even the largest scale does; ``reason`` names the
        targets); ``"inconclusive"`` (a verdict the search needed is undecided; never guessed). The
        status in words, and the relative width the bisection aims at.
    sufficient_records, undecided_records
        Minimal subsets of the records (at scale 1) that suffice together; subsets left undecided.
    analyses
        Joint verdicts run (one per distinct visited set; reachability answers are not counted).
    seed, assumptions, notes, seconds
        Seed of the analyses, what every verdict assumes (:class:`DesignAssumptions`; None when not stated),
        observations (a visited set that does not grow with the scale), wall time.
    structural, structural_reason
        Targets not jointly identifiable with the sensors even when every branch is visited (no scale makes them
        identifiable: the scale is searched for the others, :attr:`searched`), and why (the symmetries).
    blowups, skipped
        The scales whose simulation blew up (:class:`~obsnl.design.experiment_search.BlowUp`: scale, record, time,
        reason; they gave no verdict), and the grid scales above the first of them, not tried.
    unjudged_records
        Records left out of :attr:`sufficient_records` because their simulation at scale 1 blew up.
    """

    model: str
    targets: tuple[str, ...]
    sensors: tuple[str, ...]
    records: tuple[str, ...]
    switching: tuple[str, ...]
    visits: tuple[ScaleVisit, ...]
    min_scale: float | None
    bracket: tuple[float | None, float | None]
    status: str
    reason: str
    tol: float
    sufficient_records: tuple[tuple[str, ...], ...]
    undecided_records: tuple[tuple[str, ...], ...] = ()
    analyses: int = 0
    seed: int = 0
    assumptions: DesignAssumptions | None = field(default=None, repr=False)
    notes: tuple[str, ...] = ()
    seconds: float = 0.0
    structural: tuple[str, ...] = ()
    structural_reason: str = ""
    blowups: tuple[BlowUp, ...] = ()
    skipped: tuple[float, ...] = ()
    unjudged_records: tuple[str, ...] = ()

    @property
    def searched(self) -> tuple[str, ...]:
        """The targets whose smallest scale is searched: :attr:`targets` less the :attr:`structural` ones."""
        return tuple(n for n in self.targets if n not in self.structural)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: ``min_scale``, ``bracket``, ``visited`` (per scale), ``sufficient_records`` and the rest."""
        return {
            "model": self.model,
            "targets": list(self.targets),
            "sensors": list(self.sensors),
            "records": list(self.records),
            "switching": list(self.switching),
            "min_scale": self.min_scale,
            "bracket": list(self.bracket),
            "status": self.status,
            "reason": self.reason,
            "tol": self.tol,
            "visited": [v.to_dict() for v in self.visits],
            "analyses": self.analyses,
            "seed": self.seed,
            "sufficient_records": [list(s) for s in self.sufficient_records],
            "notes": list(self.notes),
            "undecided_records": [list(s) for s in self.undecided_records],
            "seconds": round(self.seconds, 3),
            "assumptions": {} if self.assumptions is None else self.assumptions.to_dict(),
            "structural": list(self.structural),
            "structural_reason": self.structural_reason,
            "searched": list(self.searched),
            "blowups": [b.to_dict() for b in self.blowups],
            "skipped": list(self.skipped),
            "unjudged_records": list(self.unjudged_records),
        }

    def _repr_html_(self) -> str | None:
        """Notebook display: the status and the branches visited per scale, drawn by :mod:`obsnl.report`."""
        return render("html", self)

    def __repr__(self) -> str:
        return one_line(
            "ExperimentDesign", f"model={self.model!r}, status={self.status!r}, min_scale={self.min_scale!r}"
        )

    def summary(self) -> str:
        """A few lines: the status, ``min_scale`` and why, the records that suffice (``to_dict`` gives everything)."""
        scale, recs = (
            "unknown" if self.min_scale is None else f"{self.min_scale:.6g}",
            "; ".join("{" + ", ".join(r) + "}" for r in self.sufficient_records) or "none",
        )
        return block(
            f"{self.model}: {self.status}, min_scale {scale}",
            self.reason,
            f"sufficient records (scale 1): {recs}",
            f"{self.analyses} joint verdicts, {len(self.visits)} scales",
        )


class _Runs:
    """The simulations and joint verdicts of one design, each computed once."""

    def __init__(
        self,
        model: Model,
        sub: Model,
        runs: Sequence[tuple],
        targets: Sequence[str],
        seed: int,
        trajectory: TrajectoryVisits | None = None,
    ) -> None:
        self.model, self.sub, self.runs, self.targets, self.seed = model, sub, list(runs), tuple(targets), seed
        self.trajectory = trajectory or TrajectoryVisits(sub)
        self.drives: dict[int, Drive] = {}
        self.sims: dict[tuple[int, float], Visits] = {}
        self.verdicts: dict[frozenset, Sufficiency] = {}
        self.analyses = 0
        self.blowups: dict[tuple[int, float], BlowUp] = {}  # (record, scale): no verdict there
        self._labels: dict[tuple[int, ...], str] | None = None

    def simulate(self, i: int, scale: float) -> Visits:
        """Record ``i``'s visits at ``scale``; :class:`ScaleBlewUp` where its simulation blows up."""
        if (i, scale) in self.blowups:
            raise ScaleBlewUp(self.blowups[i, scale])
        if (i, scale) not in self.sims:
            name, t, inputs = self.runs[i]
            check_time(f"simulating record {name!r} at scale {scale:g}", "raise max_seconds=, or give fewer scales")
            if i not in self.drives:  # checked once: the inputs, the numbers, a regular clock
                self.drives[i] = self.trajectory.drive(t, inputs, where=f"record {name!r}")
            with np.errstate(over="ignore"):
                scaled = {k: scale * v for k, v in inputs.items()}
            blow = None
            if all(np.all(np.isfinite(v)) for v in inputs.values()) and not all(
                np.all(np.isfinite(v)) for v in scaled.values()
            ):
                blow = BlowUp(scale, name, None, f"the record scaled by {scale:g} overflows")
            else:
                try:
                    self.sims[i, scale] = self.trajectory.visits(self.drives[i], scale=scale)
                except AnalysisError as err:
                    blow = blow_up(err, scale, name)
                    if blow is None:  # not the scale's fault (a missing number, the time limit): raised as it is
                        raise
            if blow is not None:
                self.blowups[i, scale] = blow
                raise ScaleBlewUp(blow)
        return self.sims[i, scale]

    def union(self, idx: Sequence[int], scale: float) -> tuple[dict, dict, dict]:
        """Patterns (seconds summed), crossings (summed) and each record's patterns, over the records ``idx``."""
        patterns: Counter = Counter()  # adds the seconds, keeps the order of first visit
        crossings: Counter = Counter()
        by: dict[str, tuple[tuple[int, ...], ...]] = {}
        for i in idx:
            vis = self.simulate(i, scale)
            by[self.runs[i][0]] = tuple(vis.patterns)
            patterns.update(vis.patterns)
            crossings.update(vis.crossings)
        return dict(patterns), dict(crossings), by

    def verdict(self, patterns: Mapping[tuple[int, ...], float], crossings: Mapping[str, int]) -> Sufficiency:
        """The joint verdict over the visited set (cached by the set: seconds and crossings are only reported)."""
        key = frozenset(patterns)
        if key not in self.verdicts:
            check_time("the joint verdict over the visited branches", "raise max_seconds=")
            res = check_sensors(
                self.model,
                self.sub.output_names,
                self.targets,
                seed=self.seed,
                max_seconds=remaining(),
                visited=patterns,
                crossings=crossings,
            )
            self.analyses += res.how == "analysis"
            self.verdicts[key] = res
        return self.verdicts[key]

    def labels(self, switching: int) -> dict[tuple[int, ...], str]:
        """Branch labels by sign pattern (:func:`obsnl.model.split_branches`); none past :data:`LABEL_UP_TO` surfaces."""
        if self._labels is None:
            try:
                found = (
                    split_branches(self.sub, seed=self.seed, undecided=True, max_seconds=remaining())
                    if switching <= LABEL_UP_TO
                    else ()
                )
            except NotSupportedError:  # nested or too many surfaces: the patterns name the branches
                found = ()
            self._labels = {tuple(b.signs): b.label for b in found}
        return self._labels

    def at(self, scale: float, *, bisection: bool = False) -> ScaleVisit:
        patterns, crossings, by = self.union(range(len(self.runs)), scale)
        v = self.verdict(patterns, crossings)
        labels = self.labels(len(self.sims[0, scale].switching))
        branches = tuple(VisitedBranch(k, labels.get(k), sec) for k, sec in patterns.items())
        return ScaleVisit(
            scale,
            branches,
            crossings,
            v.sufficient,
            v.missing,
            v.undecided,
            v.reason,
            bisection,
            by if len(self.runs) > 1 else {},
        )


def design(
    model: Model,
    records: Record | Sequence[RecordLike],
    *,
    target: str | Sequence[str] = "all",
    sensors: str | Sequence[str] | None = None,
    scales: Sequence[float] | None = None,
    tol: float = 1e-3,
    seed: int = 0,
    max_seconds: float | None = None,
    intersample: str | Mapping[str, str] | Sequence[str] | None = None,
) -> ExperimentDesign:
    """The branches the records visit per scale, the smallest sufficient scale and the sufficient records.

    Parameters
    ----------
    model : Model
        A model with numbers for every parameter in its ``[values]`` and only known inputs.
    records : Record or sequence of RecordLike
        Each a :class:`~obsnl.estimation.accelerogram.Record` (one column drives the model's one input; named columns
        drive the inputs of their names), ``(name, t, {input: samples})`` or a pandas DataFrame with a column per input
        (its time a column or its index; named by ``attrs["name"]``, else ``record 1``, ``record 2``, ... by
        position); names unique, at most :data:`MAX_RECORDS`. One Record or DataFrame alone is one record.
    target : str or sequence of str
        ``"all"``, ``"parameters"`` or names (:func:`obsnl.design.sufficiency.resolve_targets`).
    sensors : str or sequence of str or None
        The outputs measured (a sequence or ``"a,b"``; None: every output).
    scales : sequence of float or None
        The grid of factors on every record (default :data:`DEFAULT_SCALES`, 2**-10 to 2**10).
    tol : float
        The relative width ``(hi - lo) / hi`` at which the bisection stops (1e-12 to below 1).
    seed : int
        Seed of every analysis.
    max_seconds : float or None
        Time limit of the whole design (simulations and verdicts); past it an ``AnalysisError`` says what ran.
    intersample : str or mapping or sequence of str or None
        How the inputs behave between samples (:func:`obsnl.estimation.intersample.intersample_kinds`: ``"zoh"``,
        ``"linear"`` or ``"bandlimited"`` for every input, ``"NAME=KIND"`` strings or ``{NAME: KIND}``). Default:
        the model's ``[intersample]`` table, else linear; what is given here overrides it per input.

    Returns
    -------
    ExperimentDesign

    Raises
    ------
    OptionError
        Bad records, scales, tolerance, target, sensors or input kinds.
    DataError
        A record whose clock is not regular (the input between samples needs one).
    AnalysisError
        A missing number in ``[values]``, a missing input, the time limit; every target structurally unidentifiable
        (with these sensors, even when every branch is visited); a simulation that blows up at the smallest scale.

    Notes
    -----
    The bisection assumes that the visited set grows with the scale; when it does not, it still ends on a boundary
    between an insufficient and a sufficient scale, reported with the bracket (and in ``notes``). Targets that are
    unidentifiable even when every branch is visited are named in ``structural`` and not searched; a scale whose
    simulation blows up is named in ``blowups`` and the larger grid scales in ``skipped`` (not tried).

    Examples
    --------
    A gap spring closing at ``x = g``: its contact branch (where ``kc`` and ``g`` act) is reached once the record is large.

    >>> import numpy as np
    >>> from obsnl import Model
    >>> m = Model(name="gap", states=["x", "v"], parameters=["c", "k", "kc", "g"], inputs=["u"],
    ...           equations={"x": "v", "v": "u - c*v - k*x - kc*Max(x - g, 0)"}, outputs={"y": "x"},
    ...           values={"c": 0.5, "k": 4.0, "kc": 40.0, "g": 0.1})
    >>> t = np.linspace(0.0, 4.0, 81)
    >>> d = design(m, [("push", t, {"u": np.sin(2 * t)})], scales=[0.125, 0.25, 1.0, 2.0])
    >>> d.status, round(d.min_scale, 3), d.bracket[1] - d.bracket[0] <= 1e-3 * d.bracket[1]
    ('found', 0.306, True)
    >>> [(v.scale, [b.label for b in v.branches], v.sufficient) for v in d.visits if not v.bisection]
    [(0.125, ['a'], False), (0.25, ['a'], False), (1.0, ['a', 'b'], True), (2.0, ['a', 'b'], True)]
    >>> d.sufficient_records, d.analyses
    ((('push',),), 2)
    """
    t0 = time.perf_counter()
    if isinstance(records, Record) or is_frame(records):  # one Record or DataFrame alone is one record
        records = [cast(RecordLike, records)]  # a DataFrame is read as a record (pandas has no types here)
    grid = design_arguments(model, records, scales=scales, tol=tol, sensors=sensors) or DEFAULT_SCALES
    with time_budget(max_seconds):
        targets = resolve_targets(model, target)
        chosen = (
            model.output_names
            if sensors is None
            else ([s.strip() for s in sensors.split(",") if s.strip()] if isinstance(sensors, str) else list(sensors))
        )
        sub = restrict(model, chosen)
        trajectory = TrajectoryVisits(sub, intersample=intersample)  # an unknown kind is refused before any work
        runs = [record_run(model, r, name=f"record {i + 1}") for i, r in enumerate(records)]
        names = [r[0] for r in runs]
        if not runs or len(runs) > MAX_RECORDS or len(set(names)) < len(names):
            raise OptionError(
                f"give 1 to {MAX_RECORDS} records with distinct names, got {len(runs)}: "
                f"{', '.join(map(repr, names[: MAX_RECORDS + 1]))}"
            )
        structural, why, reachable = structural_targets(model, sub, targets, seed=seed, max_seconds=remaining())
        state = _Runs(model, sub, runs, tuple(n for n in targets if n not in structural), seed, trajectory)
        on_grid: list[ScaleVisit] = []
        cut = None
        for s in grid:  # increasing; a scale that blows up stops the grid (a larger one is no better behaved)
            try:
                on_grid.append(state.at(s))
            except ScaleBlewUp as exc:
                cut = exc.blow
                break
        if cut is not None and not on_grid:
            raise no_scale_ran(cut)
        min_scale, bracket, status, reason, points = _search(state, on_grid, tol, cut, reachable)
        suff, undecided, left_out = minimal_records(state)
    how = DesignAssumptions(
        analysis_assumptions(sub, "arbitrary", None),
        between_samples=dict(trajectory.kinds),
        initial_state=dict(trajectory.initial),
    )
    return ExperimentDesign(
        model.name,
        targets,
        tuple(sub.output_names),
        tuple(names),
        state.sims[0, grid[0]].switching,
        tuple(sorted(on_grid + points, key=lambda v: v.scale)),
        min_scale,
        bracket,
        status,
        reason,
        float(tol),
        suff,
        undecided,
        state.analyses,
        seed,
        how,
        _notes(on_grid, bracket[1] if status == "found" else None),
        time.perf_counter() - t0,
        structural=structural,
        structural_reason=why,
        blowups=tuple(sorted(state.blowups.values(), key=lambda b: (b.scale, b.record))),
        skipped=tuple(s for s in grid if cut is not None and s > cut.scale),
        unjudged_records=left_out,
    )
