"""The figures of merit of a simulation against a measured output, and a validation's result as a value.

Per output, over the scored samples (the warm-up samples excluded), with ``e = y - y_sim``:

- ``rmse = sqrt(mean(e**2))``, in the output's units (the figure the benchmarks publish: Noël and Schoukens,
  "Hysteretic benchmark with a dynamic nonlinearity", 2016);
- ``nrmse = rmse / RMS(y - mean(y))``: 0 for a perfect simulation, 1 for the measured mean as the prediction;
- ``fit_percent = 100 (1 - ||e|| / ||y - mean(y)||)``, the fit of MATLAB's ``compare`` (Ljung, System
  Identification Toolbox); over the same samples it is ``100 (1 - nrmse)``;
- ``db = 20 log10(rmse / RMS(y))``: the error's level under the output's own.

A sample missing from the measurement (NaN: a gap of the output) is left out of all four. An output constant
over the scored samples has no ``nrmse`` and no ``fit_percent`` (``None``: there is no variation to explain), an
output zero throughout has no ``db`` either; :class:`OutputScore` says so.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from obsnl._display import render
from obsnl._text import block, names, number, one_line
from obsnl.identification.summaries import RecordSummary

__all__ = ["figures_of_merit", "OutputScore", "Validation"]


def figures_of_merit(measured: Any, simulated: Any) -> tuple[float, float | None, float | None, float | None]:
    """``(rmse, nrmse, fit_percent, db)`` of one output's simulation against its measurement (module docstring).

    Parameters
    ----------
    measured, simulated : array_like
        The samples scored, one series each, of the same length; a measured NaN (a gap) is left out, and at
        least 2 samples must remain.

    Returns
    -------
    tuple
        RMSE; NRMSE, fit % and dB, each ``None`` where it is undefined (a constant, or a zero, measurement).

    Examples
    --------
    >>> figures_of_merit([1.0, -1.0, 1.0, -1.0], [0.5, -0.5, 0.5, -0.5])
    (0.5, 0.5, 50.0, -6.020599913279624)
    >>> figures_of_merit([2.0, 2.0], [2.0, 1.0])[1:3]
    (None, None)
    """
    y, s = np.asarray(measured, float).ravel(), np.asarray(simulated, float).ravel()
    if y.shape != s.shape:
        raise ValueError(f"measured and simulated need the same length; got {y.size} and {s.size}")
    y, s = y[~np.isnan(y)], s[~np.isnan(y)]
    if y.size < 2:
        raise ValueError(f"{y.size} measured samples to score; at least 2 are needed")
    rmse = float(np.sqrt(np.mean((y - s) ** 2)))
    spread = float(np.sqrt(np.mean((y - np.mean(y)) ** 2)))
    level = float(np.sqrt(np.mean(y**2)))
    nrmse = rmse / spread if spread > 0 else None
    db = (20 * math.log10(rmse / level) if rmse > 0 else -math.inf) if level > 0 else None
    return rmse, nrmse, None if nrmse is None else 100 * (1 - nrmse), db


@dataclass(frozen=True)
class OutputScore:
    """The figures of merit of one output (:func:`figures_of_merit`); ``None`` where one is undefined."""

    name: str
    rmse: float
    nrmse: float | None
    fit_percent: float | None
    db: float | None

    def __repr__(self) -> str:
        return one_line(
            "OutputScore",
            f"{self.name}",
            f"rmse={number(self.rmse)}",
            f"nrmse={number(self.nrmse)}",
            f"fit={number(self.fit_percent)} %",
            f"db={number(self.db)}",
        )

    def summary(self) -> str:
        """One line of plain text: the four figures, and why one is missing."""
        why = "" if self.nrmse is not None else " (the measured output is constant: no NRMSE or fit %)"
        return block(
            f"{self.name}: RMSE {number(self.rmse)}, NRMSE {number(self.nrmse)}, fit "
            f"{number(self.fit_percent)} %, {number(self.db)} dB{why}"
        )

    def to_dict(self) -> dict[str, Any]:
        clean = lambda v: None if v is None or not math.isfinite(v) else float(v)  # JSON: no inf
        return {
            "rmse": clean(self.rmse),
            "nrmse": clean(self.nrmse),
            "fit_percent": clean(self.fit_percent),
            "db": clean(self.db),
        }


#: How the simulation started: from the model's initial state (or zeros), from a state given, or from a state
#: estimated on the first samples.
STARTS = ("rest", "given", "estimated")


@dataclass(frozen=True, eq=False)
class Validation:
    """A fitted model simulated on a new record, scored against the measured outputs (``validate.json`` is
    :meth:`to_dict`).

    ``start``: one of :data:`STARTS`; ``x0``: the initial state the simulation started from; ``warmup``: the
    first samples, which estimated it (``start == "estimated"``) and are not scored; ``intersample``: how each
    input was taken between samples. ``t``, ``y_measured``, ``y_simulated`` and ``x`` (the simulated states)
    cover the whole record and feed the figures; they are not in the JSON.
    """

    model: str
    record: RecordSummary
    parameters: Mapping[str, float]
    parameters_from: str
    start: str
    x0: Mapping[str, float]
    warmup: int
    intersample: Mapping[str, str]
    outputs: Mapping[str, OutputScore]
    assumptions: tuple[str, ...]
    seconds: float
    start_note: str = ""
    states: tuple[str, ...] = ()
    t: np.ndarray | None = field(default=None, repr=False)
    y_measured: np.ndarray | None = field(default=None, repr=False)
    y_simulated: np.ndarray | None = field(default=None, repr=False)
    x: np.ndarray | None = field(default=None, repr=False)

    @property
    def scored(self) -> int:
        """Samples scored: the record without its warm-up."""
        return self.record.samples - self.warmup

    def _start_text(self) -> str:
        if self.start == "estimated":
            return f"from the state estimated on the first {self.warmup} samples (not scored)"
        return "from rest (the model's initial state, else zero)" if self.start == "rest" else "from the state given"

    def __repr__(self) -> str:
        scores = names(
            [f"{o}: rmse {number(s.rmse)}, fit {number(s.fit_percent)} %" for o, s in self.outputs.items()], 3
        )
        return one_line(
            "Validation",
            f"model={self.model!r}",
            f"record={self.record.name!r}",
            f"scored={self.scored}",
            f"start={self.start!r}",
            f"'{scores}'",
        )

    def summary(self) -> str:
        """A few lines of plain text: the model, the record and the start, then the figures of each output."""
        rows = [s.summary().rstrip("\n") for s in self.outputs.values()]
        kinds = names([f"{u} {k}" for u, k in self.intersample.items()], 6)
        return block(
            f"{self.model} on {self.record.name!r}: {self.scored} samples scored at dt = "
            f"{number(self.record.dt)} s, simulated {self._start_text()}",
            *rows[:9],
            f"... and {len(rows) - 9} more outputs" if len(rows) > 9 else "",
            f"inputs between samples: {kinds}" if kinds else "",
        )

    def to_frame(self) -> Any:
        """The figures of merit as a pandas DataFrame, one row per output (indexed by name): ``rmse``, ``nrmse``,
        ``fit_percent``, ``db`` (the values of :meth:`to_dict`; an undefined one NaN).

        Returns
        -------
        pandas.DataFrame
        """
        import pandas as pd

        rows = {o: s.to_dict() for o, s in self.outputs.items()}
        frame = pd.DataFrame.from_dict(
            rows, orient="index", columns=["rmse", "nrmse", "fit_percent", "db"], dtype=float
        )
        frame.index.name = "output"
        return frame

    def _repr_html_(self) -> str | None:
        """Notebook display: the figures per output, drawn by :mod:`obsnl.report` (:mod:`obsnl._display`)."""
        return render("html", self)

    def to_dict(self) -> dict[str, Any]:
        finite = lambda v: float(v) if math.isfinite(v) else None
        return {
            "schema": "obsnl.validate/1",
            "model": self.model,
            "record": self.record.to_dict(),
            "outputs": {o: s.to_dict() for o, s in self.outputs.items()},
            "start": self.start,
            "start_note": self.start_note,
            "warmup": self.warmup,
            "scored_samples": self.scored,
            "x0": {k: finite(v) for k, v in self.x0.items()},
            "intersample": dict(self.intersample),
            "parameters": {k: finite(v) for k, v in self.parameters.items()},
            "parameters_from": self.parameters_from,
            "seconds": self.seconds,
            "assumptions": list(self.assumptions),
        }
