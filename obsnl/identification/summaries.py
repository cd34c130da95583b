"""The parts of an identification run that ``identify.json`` writes as objects, as frozen values.

:class:`RefinementSummary` is what the run keeps of the maximum-likelihood fit
(:class:`~obsnl.identification.refine.Refinement`, whose arrays, Jacobian and objective stay behind);
:class:`NoiseLevel` is one channel's noise level and where it came from (given, estimated, or only an upper bound);
:class:`RecordSummary` is the record the run was fitted to. Each ``to_dict()`` is the object ``identify.json`` holds
under ``refinement``, ``noise`` and ``data`` (the same keys, in the same order, as the mappings these values
replace); each ``from_dict`` reads that object back.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from obsnl._text import names, number, one_line
from obsnl.errors import DataError
from obsnl.estimation.intersample import InputBetween

if TYPE_CHECKING:
    from obsnl.identification.refine import Refinement

__all__ = ["RefinementSummary", "NoiseLevel", "RecordSummary", "REFINEMENT_KEYS", "MEASURED_KEYS", "SIMULATED_KEYS"]

#: The keys every ``refinement`` object of ``identify.json`` holds, in their order (a fit's ``to_dict`` also names its
#: objective and its predictor's gain, after ``method``; read as ``"output"`` and None where they are absent).
REFINEMENT_KEYS: tuple[str, ...] = (
    "method",
    "converged",
    "reason",
    "iterations",
    "evaluations",
    "newton_decrement",
    "last_step_in_std",
    "chi2",
    "samples",
    "seconds",
    "noise_std",
    "misfit_over_noise",
    "x0",
    "correlation",
    "input_noise_widening",
)


def _floats(d: Mapping[str, Any]) -> dict[str, float]:
    return {str(k): float(v) if v is not None else float("nan") for k, v in d.items()}


def _missing(what: str, d: Mapping[str, Any], keys: tuple[str, ...]) -> None:
    lacking = [k for k in keys if k not in d]
    if lacking:
        raise DataError(
            f"the {what} object lacks {', '.join(repr(k) for k in lacking)}; give the object identify.json writes"
        )


@dataclass(frozen=True)
class RefinementSummary:
    """What an identification keeps of its maximum-likelihood fit (``identify.json``'s ``refinement``).

    ``method``: how the fit was made, in words; ``converged`` with ``reason``: the verdict of its first-order
    conditions; ``iterations`` (Levenberg-Marquardt) and ``evaluations`` (of the objective); ``newton_decrement``
    and ``last_step_in_std``: the first-order measures the verdict reads; ``chi2`` over ``samples`` residuals;
    ``seconds``; ``noise_std``: per output, the noise std estimated from the residuals; ``misfit_over_noise``: per
    output, the RMS residual over the noise level the fit was given (1: the noise floor); ``x0``: the initial state
    per state; ``correlation``: the estimates' correlations (None for a held or flat parameter);
    ``input_noise_widening``: per parameter, how much the measured inputs' noise widens its std (1: exact inputs);
    ``objective``: the misfit minimised (``"output"``: output error, the model simulated; ``"prediction"``: the
    one-step predictor's error); ``predictor_gain``: the predictor's gain per state and output where it has one (None
    for output error); ``left_out_near_jumps``: per output that jumps with the field, the samples next to a jump the
    fit left out (:func:`obsnl.identification.refine.near_jumps`).

    Examples
    --------
    >>> s = RefinementSummary(method="maximum likelihood", converged=True, reason="first-order condition met",
    ...                       iterations=4, evaluations=9, newton_decrement=1e-9, last_step_in_std=1e-4, chi2=98.0,
    ...                       samples=100, seconds=0.5, noise_std={"y": 0.01}, misfit_over_noise={"y": 1.02},
    ...                       x0={"x": 0.0}, correlation={"k": {"k": 1.0}}, input_noise_widening={"k": 1.0})
    >>> s.misfit_over_noise["y"], list(s.to_dict())[:4]
    (1.02, ['method', 'objective', 'predictor_gain', 'converged'])
    >>> RefinementSummary.from_dict(s.to_dict()) == s
    True
    """

    method: str
    converged: bool
    reason: str
    iterations: int
    evaluations: int
    newton_decrement: float
    last_step_in_std: float
    chi2: float
    samples: int
    seconds: float
    noise_std: Mapping[str, float]
    misfit_over_noise: Mapping[str, float]
    x0: Mapping[str, float]
    correlation: Mapping[str, Mapping[str, float | None]] = field(repr=False)
    input_noise_widening: Mapping[str, float] = field(repr=False)
    objective: str = "output"
    predictor_gain: Mapping[str, Mapping[str, float]] | None = field(default=None, repr=False)
    left_out_near_jumps: Mapping[str, int] = field(default_factory=dict, repr=False)

    def __repr__(self) -> str:
        return one_line(
            "RefinementSummary",
            f"objective={self.objective!r}",
            f"converged={self.converged}",
            f"chi2={number(self.chi2)}",
            f"iterations={self.iterations}",
            f"misfit_over_noise='{names([f'{o}={number(v)}' for o, v in self.misfit_over_noise.items()], 4)}'",
        )

    @classmethod
    def from_refinement(cls, ref: Refinement) -> RefinementSummary:
        """The summary of a fit (:func:`obsnl.identification.refine.refine`): the values its ``to_dict`` gives,
        the objective and the predictor's gain too where it names them."""
        return cls.from_dict(ref.to_dict())

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> RefinementSummary:
        """The summary from ``identify.json``'s ``refinement`` object (or a fit's ``to_dict``).

        Raises
        ------
        DataError
            A key of :data:`REFINEMENT_KEYS` is missing.
        """
        _missing("refinement", d, REFINEMENT_KEYS)
        gain = d.get("predictor_gain")
        return cls(
            method=str(d["method"]),
            converged=bool(d["converged"]),
            reason=str(d["reason"]),
            iterations=int(d["iterations"]),
            evaluations=int(d["evaluations"]),
            newton_decrement=float("nan") if d["newton_decrement"] is None else float(d["newton_decrement"]),
            last_step_in_std=float("nan") if d["last_step_in_std"] is None else float(d["last_step_in_std"]),
            chi2=float("nan") if d["chi2"] is None else float(d["chi2"]),
            samples=int(d["samples"]),
            seconds=float(d["seconds"]),
            noise_std=_floats(d["noise_std"]),
            misfit_over_noise=_floats(d["misfit_over_noise"]),
            x0=_floats(d["x0"]),
            correlation={
                str(p): {str(q): None if v is None else float(v) for q, v in row.items()}
                for p, row in d["correlation"].items()
            },
            input_noise_widening=_floats(d["input_noise_widening"]),
            objective=str(d.get("objective") or "output"),
            predictor_gain=None
            if gain is None
            else {str(s): {str(o): float(k) for o, k in row.items()} for s, row in gain.items()},
            left_out_near_jumps={str(o): int(n) for o, n in (d.get("left_out_near_jumps") or {}).items()},
        )

    def to_dict(self) -> dict[str, Any]:
        """``identify.json``'s ``refinement`` object: the keys of :data:`REFINEMENT_KEYS` in their order, with
        ``objective`` and ``predictor_gain`` after ``method`` (as the fit's own ``to_dict`` writes them)."""
        return {
            "method": self.method,
            "objective": self.objective,
            "predictor_gain": None
            if self.predictor_gain is None
            else {s: dict(row) for s, row in self.predictor_gain.items()},
            "converged": self.converged,
            "reason": self.reason,
            "iterations": self.iterations,
            "evaluations": self.evaluations,
            "newton_decrement": self.newton_decrement,
            "last_step_in_std": self.last_step_in_std,
            "chi2": self.chi2,
            "samples": self.samples,
            "seconds": self.seconds,
            "noise_std": dict(self.noise_std),
            "misfit_over_noise": dict(self.misfit_over_noise),
            "x0": dict(self.x0),
            "correlation": {p: dict(row) for p, row in self.correlation.items()},
            "input_noise_widening": dict(self.input_noise_widening),
            "left_out_near_jumps": dict(self.left_out_near_jumps),
        }


@dataclass(frozen=True)
class NoiseLevel:
    """One channel's noise level: ``ratio``, the noise-to-signal RMS ratio the filter and the fit were given, and
    where it came from (``source``, in words).

    A level given by the user (or by a simulation study) has no ``estimate``; an estimated one keeps the estimate
    (``ratio`` is it raised to the filter's floor: :attr:`floored`; or the floor alone for an input taken as exact),
    and ``upper_bound`` says the estimate is only an upper bound (the channel is not oversampled). :attr:`origin`
    says which of the three.

    Examples
    --------
    >>> NoiseLevel(0.01, "given").origin
    'given'
    >>> level = NoiseLevel.from_dict({"ratio": 1e-4, "estimate": 2e-5, "upper_bound": False,
    ...                               "source": "estimated from the differences; floored at 0.0001"})
    >>> level.origin, level.floored, list(level.to_dict())
    ('estimated', True, ['ratio', 'estimate', 'upper_bound', 'source'])
    """

    ratio: float
    source: str
    estimate: float | None = None
    upper_bound: bool = False

    @property
    def floored(self) -> bool:
        """The estimate was raised to the filter's floor (``ratio`` above it): a smaller misfit is not seen."""
        return self.estimate is not None and self.ratio > self.estimate

    @property
    def origin(self) -> str:
        """``"given"``, ``"estimated"`` or ``"upper bound"`` (estimated, and only an upper bound)."""
        if self.estimate is None:
            return "given"
        return "upper bound" if self.upper_bound else "estimated"

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> NoiseLevel:
        """The level from ``identify.json``'s ``noise`` object of one channel.

        Raises
        ------
        DataError
            ``ratio`` or ``source`` is missing.
        """
        _missing("noise level", d, ("ratio", "source"))
        estimate = d.get("estimate")
        return cls(
            ratio=float(d["ratio"]),
            source=str(d["source"]),
            estimate=None if estimate is None else float(estimate),
            upper_bound=bool(d.get("upper_bound", False)),
        )

    def to_dict(self) -> dict[str, Any]:
        """``{"ratio", "source"}`` for a given level; ``{"ratio", "estimate", "upper_bound", "source"}`` for an
        estimated one."""
        if self.estimate is None:
            return {"ratio": self.ratio, "source": self.source}
        return {"ratio": self.ratio, "estimate": self.estimate, "upper_bound": self.upper_bound, "source": self.source}


#: The keys of ``identify.json``'s ``data`` object, in their order: of measured data (``intersample`` only where it
#: is said: not in ``validate.json``'s ``record``), and of a simulation study's record (``channels`` only where the
#: record names them).
MEASURED_KEYS: tuple[str, ...] = (
    "name",
    "source",
    "dt",
    "samples",
    "inputs",
    "outputs",
    "clock_deviation",
    "clock_tolerance",
    "missing",
    "ignored",
    "intersample",
)
SIMULATED_KEYS: tuple[str, ...] = ("name", "dt", "samples", "source", "notes", "pga_m_s2", "channels")


@dataclass(frozen=True)
class RecordSummary:
    """The record a run was fitted to (``identify.json``'s ``data``).

    ``kind``: ``"measured"`` (:func:`obsnl.identification.runs.identify_measured`: its channels, how the clock was
    read, the output samples missing, the columns ignored, how each input is taken between samples, ``intersample``:
    None where the record does not say, as in a validation, which says it beside the record) or
    ``"simulated"`` (a simulation study's driving record: its notes, its peak ground acceleration, its channels).
    The fields of the other kind keep their empty defaults.

    Examples
    --------
    >>> r = RecordSummary(name="run1", dt=0.01, samples=300, missing={"y": 150})
    >>> r.missing_samples, list(r.to_dict())[:4]
    (150, ['name', 'source', 'dt', 'samples'])
    >>> RecordSummary.from_dict(r.to_dict()) == r
    True
    """

    name: str
    dt: float
    samples: int
    source: str = ""
    kind: str = "measured"
    inputs: tuple[str, ...] = ()
    outputs: tuple[str, ...] = ()
    clock_deviation: float = 0.0
    clock_tolerance: float | None = None
    missing: Mapping[str, int] = field(default_factory=dict)
    ignored: tuple[str, ...] = ()
    intersample: tuple[InputBetween, ...] | None = None
    notes: tuple[str, ...] = ()
    pga_m_s2: float | None = None
    channels: tuple[str, ...] = ()

    @property
    def missing_samples(self) -> int:
        """The output samples missing, over every output."""
        return int(sum(self.missing.values()))

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> RecordSummary:
        """The record from ``identify.json``'s ``data`` object (or the ``to_dict`` of a measured record or of a
        simulation study's record); a simulation study's record is told by its ``pga_m_s2``.

        Raises
        ------
        DataError
            ``name``, ``dt`` or ``samples`` is missing.
        """
        _missing("data", d, ("name", "dt", "samples"))
        name, dt, samples = str(d["name"]), float(d["dt"]), int(d["samples"])
        if "pga_m_s2" in d:
            pga = d["pga_m_s2"]
            return cls(
                name=name,
                dt=dt,
                samples=samples,
                source=str(d.get("source") or ""),
                kind="simulated",
                notes=tuple(d.get("notes") or ()),
                pga_m_s2=None if pga is None else float(pga),
                channels=tuple(d.get("channels") or ()),
            )
        tol = d.get("clock_tolerance")
        return cls(
            name=name,
            dt=dt,
            samples=samples,
            source=str(d.get("source") or ""),
            inputs=tuple(d.get("inputs") or ()),
            outputs=tuple(d.get("outputs") or ()),
            clock_deviation=float(d.get("clock_deviation") or 0.0),
            clock_tolerance=None if tol is None else float(tol),
            missing={str(k): int(v) for k, v in (d.get("missing") or {}).items()},
            ignored=tuple(d.get("ignored") or ()),
            intersample=None
            if d.get("intersample") is None
            else tuple(b if isinstance(b, InputBetween) else InputBetween(**dict(b)) for b in d["intersample"]),
        )

    def to_dict(self) -> dict[str, Any]:
        """The keys of :data:`MEASURED_KEYS` or of :data:`SIMULATED_KEYS`, by ``kind``."""
        if self.kind == "simulated":
            return {
                "name": self.name,
                "dt": self.dt,
                "samples": self.samples,
                "source": self.source,
                "notes": list(self.notes),
                "pga_m_s2": self.pga_m_s2,
                **({"channels": list(self.channels)} if self.channels else {}),
            }
        return {
            "name": self.name,
            "source": self.source,
            "dt": self.dt,
            "samples": self.samples,
            "inputs": list(self.inputs),
            "outputs": list(self.outputs),
            "clock_deviation": self.clock_deviation,
            "clock_tolerance": self.clock_tolerance,
            "missing": dict(self.missing),
            "ignored": list(self.ignored),
            **({} if self.intersample is None else {"intersample": [b.to_dict() for b in self.intersample]}),
        }
