"""The result of an identification run, as values: :class:`Identification` and its :class:`ParameterEstimate`
(``identify.json`` is :meth:`Identification.to_dict`), with the JSON and error helpers they use.

Reporting rules: a parameter held at its guess (only with ``hold``) is reported as held, with ``estimate``
and ``std`` ``null``, never as an estimate; a relative error with a zero truth is given as an absolute
error instead; no NaN or inf reaches the JSON.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any

import numpy as np

from obsnl._display import render
from obsnl._text import block, names, number, one_line
from obsnl.errors import ObsnlError
from obsnl.estimation.ukf import Trajectory
from obsnl.identification.adequacy import INADEQUATE, Adequacy
from obsnl.identification.practical import Practical
from obsnl.identification.profile import Profile
from obsnl.identification.setup import Tuning
from obsnl.identification.structural import StructuralCheck
from obsnl.identification.summaries import NoiseLevel, RecordSummary, RefinementSummary

if TYPE_CHECKING:
    from obsnl.identification.modal import Modal
    from obsnl.identification.validation.merit import Validation
    from obsnl.model.core import Model

__all__ = [
    "Identification",
    "ParameterEstimate",
    "RefinementSummary",
    "NoiseLevel",
    "RecordSummary",
    "clean_json",
    "error_of",
]


def clean_json(x: Any) -> Any:
    """``x`` with every non-finite float replaced by ``None`` (JSON has no NaN or Infinity).

    Examples
    --------
    >>> clean_json({"a": [1.0, float("inf")], "b": float("nan")})
    {'a': [1.0, None], 'b': None}
    """
    if isinstance(x, Mapping):
        return {k: clean_json(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [clean_json(v) for v in x]
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, np.integer):
        return int(x)
    return x


@dataclass(frozen=True)
class ParameterEstimate:
    """One parameter: the estimate and its posterior std, or ``held`` at its guess (then both ``None``).

    ``flagged``: poorly informed by these data (practical identifiability, with ``reason``). In a
    simulation study ``true`` and ``error`` (per cent of the truth, or absolute where the truth is 0:
    ``error_kind``) are set.
    """

    name: str
    guess: float
    estimate: float | None
    std: float | None
    held: bool
    flagged: bool
    reason: str | None = None
    true: float | None = None
    error: float | None = None
    error_kind: str | None = None
    interval: tuple[float | None, float | None] | None = None
    interval_method: str | None = None

    def __repr__(self) -> str:
        value = f"held at {number(self.guess)}" if self.held else f"{number(self.estimate)} (std {number(self.std)})"
        return one_line(
            "ParameterEstimate",
            f"{self.name}={value}",
            "flagged" if self.flagged else "",
            f"error={number(self.error)}{' %' if self.error_kind == 'percent' else ''}"
            if self.error is not None
            else "",
        )

    def summary(self) -> str:
        """One line of plain text: the estimate, its std and its 95 % interval (or held), the error in a simulation
        study, the flag. An interval end the profile did not reach is said open."""
        interval = ""
        if self.interval is not None and not self.held:
            lo, hi = (("open" if v is None else number(v)) for v in self.interval)
            interval = f", 95 % [{lo}, {hi}]"
        value = (
            f"held at its guess {number(self.guess)}"
            if self.held
            else f"= {number(self.estimate)} (std {number(self.std)}{interval})"
        )
        truth = (
            ""
            if self.true is None
            else f"; true {number(self.true)}, error {number(self.error)}"
            + (" %" if self.error_kind == "percent" else "")
        )
        return block(f"{self.name} {value}{truth}" + (f"; flagged: {self.reason}" if self.flagged else ""))

    def to_dict(self) -> dict[str, Any]:
        d = {
            "name": self.name,
            "estimate": self.estimate,
            "std": self.std,
            "interval": None if self.interval is None else list(self.interval),
            "interval_method": self.interval_method,
            "held": self.held,
            "held_at": self.guess if self.held else None,
            "flagged": self.flagged,
            "reason": self.reason,
            "guess": self.guess,
        }
        if self.true is not None:
            d.update(true=self.true, error=self.error, error_kind=self.error_kind)
        return clean_json(d)


@dataclass(frozen=True, eq=False)
class Identification:
    """The result of one identification run (``identify.json`` is :meth:`to_dict`).

    ``fit``: NRMSE in per cent per output, ``100 RMS(simulated - measured) / RMS(measured)``, of the
    model simulated at the estimate under the measured input (held parameters at their guess).
    ``practical``: the practical identifiability of the parameters at the filter's estimate
    (:class:`~obsnl.identification.practical.Practical`; None where it was not computed);
    ``structural``: what the structural analysis said
    (:class:`~obsnl.identification.structural.StructuralCheck`; None until
    :func:`obsnl.identification.identify.identify` joins it). ``identify.json`` carries them as
    ``practical_identifiability`` and ``structural`` (``{}`` for None).
    ``traces``, ``t``, ``y_measured``, ``y_fit`` feed the figures and are not in the JSON.
    ``compiled``: whether the filter and the fit ran compiled to C (the same numbers to rounding; None where not
    recorded). ``adequacy``: whether the fitted model explains the data to the noise level
    (:class:`~obsnl.identification.adequacy.Adequacy`, residual tests after the maximum-likelihood fit; None where no
    fit was made); when it failed every parameter is flagged, and :meth:`summary` says so first.
    ``refinement``: what the run keeps of the maximum-likelihood fit
    (:class:`~obsnl.identification.summaries.RefinementSummary`; None without one: ``{}`` in the JSON);
    ``noise``: each channel's :class:`~obsnl.identification.summaries.NoiseLevel` and where it came from;
    ``data``: the record fitted (:class:`~obsnl.identification.summaries.RecordSummary`).
    """

    model: str
    mode: str
    method: str
    parameters: tuple[ParameterEstimate, ...]
    fit: Mapping[str, float | None]
    passes: int
    passes_run: int
    seconds: float
    converged: bool
    output_misfit: float | None
    noise: Mapping[str, NoiseLevel]
    tuning: Tuning
    tuning_scores: tuple[tuple[Tuning, float], ...]
    data: RecordSummary
    practical: Practical | None
    assumptions: tuple[str, ...]
    repairs: int = 0
    fitted_model: Model | None = field(default=None, repr=False)  # the Model identified (identify, study): simulate()
    structural: StructuralCheck | None = None
    seed: int | None = None
    traces: tuple[Trajectory, ...] = field(default=(), repr=False)
    t: np.ndarray | None = field(default=None, repr=False)
    y_measured: np.ndarray | None = field(default=None, repr=False)
    y_fit: np.ndarray | None = field(default=None, repr=False)
    outputs: tuple[str, ...] = ()
    converged_reason: str = ""
    refinement: RefinementSummary | None = None
    profiles: tuple[Profile, ...] = field(default=(), repr=False)
    compiled: bool | None = None
    adequacy: Adequacy | None = None
    u_measured: np.ndarray | None = field(default=None, repr=False)  # the measured inputs (T, nu), for the figures
    inputs: tuple[str, ...] = ()

    def __repr__(self) -> str:
        est = names([f"{p.name}={'held' if p.held else number(p.estimate)}" for p in self.parameters], 6)
        return one_line(
            "Identification",
            f"model={self.model!r}",
            f"mode={self.mode!r}",
            f"method={self.method!r}",
            "" if self.adequacy is None else f"adequate={self.adequacy.passed}",
            f"converged={self.converged}",
            f"flagged={names(self.flagged, 4)!r}",
            f"estimates='{est}'",
        )

    def summary(self) -> str:
        """A few lines of plain text: a failed adequacy first, the run, the structural verdict, each parameter's
        estimate, what is flagged, the fit, a passed adequacy."""
        fit = names([f"{o} {number(v)} %" for o, v in self.fit.items()])
        inadequate = self.adequacy is not None and not self.adequacy.passed
        rows = [p.summary().rstrip("\n") for p in self.parameters]
        most = (8 if self.structural is None else 7) - (self.adequacy is not None)  # a dozen lines in all
        return block(
            self.adequacy.headline() if self.adequacy is not None and inadequate else "",
            f"{self.model}: {self.mode}, {self.method}, {self.passes_run} of {self.passes} passes, "
            f"{'converged' if self.converged else 'NOT converged'}"
            f"{f' ({self.converged_reason})' if self.converged_reason else ''}, {self.seconds:.3g} s",
            self.structural.note() if self.structural is not None else "",
            *rows[:most],
            f"... and {len(rows) - most} more parameters" if len(rows) > most else "",
            f"flagged (poorly informed by these data): {names(self.flagged)}"
            if self.flagged and not inadequate
            else f"flagged, every parameter: {INADEQUATE}"
            if inadequate
            else "",
            f"fit (NRMSE of the model at the estimate): {fit}",
            self.adequacy.headline() if self.adequacy is not None and not inadequate else "",
        )

    @property
    def held(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters if p.held)

    @property
    def flagged(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters if p.flagged)

    def estimates(self) -> dict[str, float | None]:
        """``{name: estimate}`` (``None`` for a held parameter)."""
        return {p.name: p.estimate for p in self.parameters}

    def simulate(self, record: Any, *, warmup: int = 0, intersample: Any = None, model: Any = None) -> Validation:
        """The fitted model run on a new record and scored (:func:`obsnl.simulate`): RMSE, NRMSE, fit % and dB per
        output, at the estimates (a held parameter at its guess).

        Parameters
        ----------
        record : Measured, mapping of str to Any, str or Path
            The new record, as :func:`obsnl.identify` takes its data.
        warmup : int
            Samples at the start that estimate the initial state and are not scored (0: the simulation starts from
            rest, the model's initial states under ``[values]``, else 0).
        intersample : None, str, mapping or sequence of str
            How the inputs are taken between samples (default: as this fit took them).
        model : Model, str, Path or None
            The model identified (default: the one this result keeps, from :func:`obsnl.identify` or ``study``;
            needed only for a result made otherwise).

        Returns
        -------
        Validation

        Raises
        ------
        OptionError
            This result keeps no model and ``model`` is not given.
        """
        from obsnl.errors import OptionError
        from obsnl.identification.validation.run import simulate

        model = self.fitted_model if model is None else model
        if model is None:
            raise OptionError(
                f"this result of {self.model!r} keeps no model (it was not made by obsnl.identify); pass "
                f"model=, the model identified"
            )
        # a parameter's estimate is None exactly where it was held at its guess
        values = {p.name: p.guess if p.held or p.estimate is None else p.estimate for p in self.parameters}
        kinds = (
            intersample if intersample is not None else {b.input: b.kind for b in self.data.intersample or ()} or None
        )
        return simulate(model, values, record, warmup=warmup, intersample=kinds)

    def modal(self, *, state: Mapping[str, float] | Sequence[float] | None = None) -> Modal:
        """The fitted model linearised at rest (or at ``state``): natural frequencies, damping ratios and mode shapes
        at the measured outputs, each with its std from the estimates' covariance
        (:func:`obsnl.identification.modal.modal`).

        Parameters
        ----------
        state : mapping of str to float, sequence of float or None
            The state linearised at (None: every state 0, which must be at rest under zero inputs).

        Returns
        -------
        Modal
        """
        from obsnl.identification.modal import modal

        return modal(self, state=state)

    def state_space(self, *, state: Mapping[str, float] | Sequence[float] | None = None) -> Any:
        """The fitted model linearised at rest (or at ``state``) as a python-control ``StateSpace``
        (:meth:`Modal.to_control <obsnl.identification.modal.Modal.to_control>`)."""
        return self.modal(state=state).to_control()

    @cached_property
    def linear_at_rest(self) -> Modal | None:
        """The fitted model linearised at rest with its modes (:meth:`modal`), or None where it cannot be: no model
        kept, or the zero state is not at rest under zero inputs."""
        if self.fitted_model is None:
            return None
        try:
            return self.modal()
        except ObsnlError:
            return None

    @property
    def modal_at_rest(self) -> Modal | None:
        """:attr:`linear_at_rest` where it has modes (a complex pair of eigenvalues: an oscillatory model), else
        None; ``identify.json`` holds it as ``"modal"``."""
        lin = self.linear_at_rest
        return lin if lin is not None and lin.oscillatory else None

    def to_frame(self) -> Any:
        """The parameters as a pandas DataFrame, one row each (indexed by name): ``estimate``, ``std``,
        ``interval_low``, ``interval_high``, ``interval_method``, ``held``, ``flagged``, ``reason``, ``guess``, and
        ``true``, ``error``, ``error_kind`` in a simulation study; the values of :meth:`to_dict` (a missing one NaN).

        Returns
        -------
        pandas.DataFrame
        """
        import pandas as pd

        rows = []
        for p in self.parameters:
            d = p.to_dict()
            interval = d.pop("interval") or [None, None]
            d.pop("held_at")
            rows.append({**d, "interval_low": interval[0], "interval_high": interval[1]})
        cols = [
            "name",
            "estimate",
            "std",
            "interval_low",
            "interval_high",
            "interval_method",
            "held",
            "flagged",
            "reason",
            "guess",
        ] + [c for c in ("true", "error", "error_kind") if any(c in r for r in rows)]
        frame = pd.DataFrame(rows, columns=cols).set_index("name")
        for c in ("estimate", "std", "interval_low", "interval_high", "guess", "true", "error"):
            if c in frame:
                frame[c] = frame[c].astype(float)
        return frame

    def _repr_html_(self) -> str | None:
        """Notebook display: the run's table, drawn by :mod:`obsnl.report` (:mod:`obsnl._display`)."""
        return render("html", self)

    def to_dict(self) -> dict[str, Any]:
        modal = self.modal_at_rest
        return clean_json(
            {
                "schema": "obsnl.identify/1",
                "model": self.model,
                "mode": self.mode,
                "method": self.method,
                "passes": self.passes,
                "passes_run": self.passes_run,
                "seconds": self.seconds,
                "seed": self.seed,
                "compiled": self.compiled,
                "held": len(self.held),
                "flagged": list(self.flagged),
                "parameters": [p.to_dict() for p in self.parameters],
                "fit": dict(self.fit),
                "converged": self.converged,
                "converged_reason": self.converged_reason,
                "refinement": {} if self.refinement is None else self.refinement.to_dict(),
                "profiles": [p.to_dict() for p in self.profiles],
                "output_misfit": self.output_misfit,
                "noise": {c: level.to_dict() for c, level in self.noise.items()},
                "tuning": self.tuning.to_dict(),
                "tuning_scores": [{**t.to_dict(), "output_misfit": s} for t, s in self.tuning_scores],
                "data": self.data.to_dict(),
                "structural": {} if self.structural is None else self.structural.to_dict(),
                "repairs": self.repairs,
                "practical_identifiability": {} if self.practical is None else self.practical.to_dict(),
                "adequacy": None if self.adequacy is None else self.adequacy.to_dict(),
                "modal": None if modal is None else modal.to_dict(),
                "assumptions": list(self.assumptions),
            }
        )


def error_of(estimate: float | None, true: float) -> tuple[float | None, str | None]:
    """The error of an estimate: per cent of the truth, or absolute where the truth is 0 (never inf).

    Parameters
    ----------
    estimate : float or None
        The estimate (None: none).
    true : float
        The true value.

    Returns
    -------
    tuple
        ``(error, "percent" or "absolute")``, or ``(None, None)``.

    Examples
    --------
    >>> error_of(1.1, 1.0)[1], error_of(0.25, 0.0), error_of(None, 2.0)
    ('percent', (0.25, 'absolute'), (None, None))
    """
    if estimate is None:
        return None, None
    return (100 * (estimate - true) / abs(true), "percent") if true != 0 else (estimate - true, "absolute")
