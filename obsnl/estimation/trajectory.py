"""What a filter returns: one estimate (:class:`Estimate`) and a run over a record (:class:`Trajectory`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from obsnl._text import block, names, number, numbers, one_line
from obsnl.estimation.ukf_step import INTERVENTIONS, REPAIRS

__all__ = ["Estimate", "Trajectory"]


@dataclass(frozen=True, eq=False)
class Estimate:
    """Filter state after step ``k``: mean ``z`` and covariance ``P`` in filter coordinates.

    ``x`` and ``theta`` are the same mean in model states and model parameters.
    """

    k: int
    z: np.ndarray
    P: np.ndarray
    x: np.ndarray
    theta: np.ndarray
    active: np.ndarray

    def __repr__(self) -> str:
        return one_line("Estimate", f"k={self.k}", f"theta={numbers(self.theta)}", f"x={numbers(self.x, 4)}")

    def summary(self) -> str:
        """A few lines of plain text: the parameters and states after step ``k``, with their std."""
        sd = np.sqrt(np.clip(np.diag(self.P), 0, None))
        return block(
            f"estimate after step {self.k}",
            f"parameters {numbers(self.theta, 10)}",
            f"states {numbers(self.x, 10)}",
            f"std in filter coordinates {numbers(sd, 10)}",
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "k": self.k,
            "z": self.z.tolist(),
            "P": self.P.tolist(),
            "x": self.x.tolist(),
            "theta": self.theta.tolist(),
            "active": self.active.astype(bool).tolist(),
        }


@dataclass(frozen=True, eq=False)
class Trajectory:
    """A filter run over a record (row ``k`` is the estimate after the measurement at sample ``k``).

    Attributes
    ----------
    t
        Sample times.
    z, P
        Means ``(T, L)`` and covariances ``(T, L, L)`` in filter coordinates.
    x, theta
        Means in model states ``(T, nx)`` and model parameters ``(T, np)``.
    y_pred, innovations, S
        Predicted outputs, innovations ``y - y_pred`` and their covariance, per step (row 0: NaN).
    signs
        Sign of each switching function at the estimated mean before each step ``(T, m)``.
    active
        Active (not frozen) coordinates per step.
    interventions
        Interventions per step and kind ``(T, len(INTERVENTIONS))`` (:mod:`obsnl.estimation.ukf_step`).
    repairs
        Repairs per step: the interventions except the innovation gate.
    implicit
        Sigma points per step whose propagation needed the implicit (ROS2) fallback.
    refined
        Sigma points per step whose crossing substep was redone with finer ones because a switching
        function across which the field can jump changed sign inside the step (:mod:`obsnl.estimation.numeric`).
    seconds
        Wall time of the run (after compilation).
    names, parameters, states
        Names of the filter coordinates, model parameters and model states.
    """

    t: np.ndarray
    z: np.ndarray
    P: np.ndarray
    x: np.ndarray
    theta: np.ndarray
    y_pred: np.ndarray
    innovations: np.ndarray
    S: np.ndarray
    signs: np.ndarray
    active: np.ndarray
    interventions: np.ndarray
    implicit: np.ndarray
    refined: np.ndarray
    seconds: float
    names: tuple[str, ...]
    parameters: tuple[str, ...]
    states: tuple[str, ...]

    def __repr__(self) -> str:
        final = names([f"{p}={number(v)}" for p, v in zip(self.parameters, self.theta[-1])], 6)
        return one_line(
            "Trajectory",
            f"samples={len(self.t)}",
            f"final: {final}",
            f"repairs={self.total_repairs}",
            f"{self.seconds:.3g} s",
        )

    def summary(self) -> str:
        """A few lines of plain text: the final estimate per parameter (with its std), the repairs."""
        sd = np.sqrt(np.clip(np.diagonal(self.P[-1]), 0, None))
        coords = [f"{n} {number(v)}" for n, v in list(zip(self.names, sd))[len(self.states) :]]
        rows = [f"{p} = {number(v)}" for p, v in zip(self.parameters, self.theta[-1])]
        return block(
            f"filter run over {len(self.t)} samples ({number(self.t[0])} to {number(self.t[-1])} s), "
            f"{self.total_repairs} repairs, {self.seconds:.3g} s",
            *rows[:9],
            f"... and {len(rows) - 9} more parameters" if len(rows) > 9 else "",
            f"final std of the parameter coordinates: {', '.join(coords[:8])}" if coords else "",
        )

    @property
    def final(self) -> Estimate:
        return Estimate(
            k=len(self.t) - 1, z=self.z[-1], P=self.P[-1], x=self.x[-1], theta=self.theta[-1], active=self.active[-1]
        )

    @property
    def repairs(self) -> np.ndarray:
        return self.interventions[:, [INTERVENTIONS.index(k) for k in REPAIRS]].sum(axis=1)

    @property
    def total_repairs(self) -> int:
        return int(np.sum(self.repairs))

    def counts(self) -> dict[str, int]:
        """Total of each kind of intervention over the run."""
        return {k: int(v) for k, v in zip(INTERVENTIONS, self.interventions.sum(axis=0))}

    def to_dict(self) -> dict[str, Any]:
        return {
            "names": list(self.names),
            "parameters": list(self.parameters),
            "states": list(self.states),
            "t": self.t.tolist(),
            "theta": self.theta.tolist(),
            "x": self.x.tolist(),
            "P_diag": np.diagonal(self.P, axis1=1, axis2=2).tolist(),
            "innovations": self.innovations.tolist(),
            "signs": self.signs.tolist(),
            "repairs": self.repairs.tolist(),
            "interventions": self.counts(),
            "implicit": self.implicit.tolist(),
            "refined": self.refined.tolist(),
            "seconds": self.seconds,
        }
