"""The discontinuous UKF (DUKF) of Chatzis & Chatzi (Front. Built Environ. 3:56, 2017), driven by a branch table.

In each step the branch is evaluated at the estimated mean (the signs of the table's switching
functions); the parameter coordinates the table marks unidentifiable in that branch are *frozen*:
no sigma-point spread, no update, no process noise. Every sigma point still goes through the full
non-smooth model. On a switching surface (a switching function within ``band`` of 0) the previous
step's mask is kept; the first step starts with everything active.

Which coordinates freeze. The table speaks of model parameters; the filter may estimate other
coordinates (:class:`~obsnl.estimation.codegen.ParameterMap`). A coordinate is frozen in a branch when every
model parameter that depends on it is unidentifiable there: with log coordinates this is the
table itself; with yield-displacement coordinates ``Delta_i = ±r_yi**(-2N)`` the coordinate
``r_yi`` freezes with ``Delta_i`` and ``N`` (which also moves the active ``Delta``) stays active.

The frozen-active covariance (``cross``). Putting the frozen rows and columns of the covariance
back after an update of the active block gives an indefinite matrix. Two rules keep it positive
semidefinite *by construction*:

``"regression"`` (default)
    The frozen block ``U`` is regressed on the prior active block ``A``, ``U = B A + e`` with
    ``B = P_UA P_AA^-1`` and ``e`` independent of everything the step does. Then the predicted
    cross-covariance is ``P_AU- = T P_AU`` with ``T = C_{A-A} P_AA^-1`` (statistical linearisation
    through the same sigma points), ``P_Uy = B C_{Ay}``, and the update uses the gain with zero
    rows for ``U``: ``P+ = P- - K P_zy^T - P_zy K^T + K P_yy K^T``. With covariance weights
    ``>= 0`` the joint second-moment matrix of ``(A, A-, y, U)`` is a sum of PSD terms, so ``P-``
    and ``P+`` are PSD whatever the gain; ``P_UU`` is untouched and the correlations survive until
    ``U`` is released.
``"zero"`` (variant (ii))
    ``P_AU = 0`` while frozen: block-diagonal, PSD, but the correlations are forgotten.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np
import numpy.typing as npt

from obsnl.errors import EstimatorError, TableError
from obsnl.estimation.ukf import UKF
from obsnl.observability.contract.branch_table import BranchTable

__all__ = ["DUKF"]


@dataclass(frozen=True, eq=False)
class DUKF(UKF):
    """UKF that freezes, in each branch, the coordinates the branch table marks unidentifiable.

    Parameters
    ----------
    table : BranchTable or None
        The branch table (:func:`obsnl.observability.contract.branch_table.read_branch_table`); it must be made for this
        model (names, fingerprint, switching functions), else :class:`~obsnl.errors.TableError`.
    cross : str
        ``"regression"`` (default) or ``"zero"``: the rule for the frozen-active covariance
        (module docstring).
    band : array_like
        A switching function counts as signed only beyond ``band`` (scalar or one per switching
        function); inside the band the previous mask is kept (against chattering). Default 0.
    **options : Any
        The options of :class:`obsnl.estimation.UKF`.

    References
    ----------
    .. [1] M. N. Chatzis and E. N. Chatzi, "A discontinuous unscented Kalman filter for non-smooth dynamic problems",
       Frontiers in Built Environment 3:56, 2017. doi:10.3389/fbuil.2017.00056
    """

    table: BranchTable | None = None
    cross: str = "regression"
    band: npt.ArrayLike = 0.0

    def __post_init__(self) -> None:
        super().__post_init__()
        t = self.table
        if not isinstance(t, BranchTable):
            raise TableError("the DUKF needs a branch table: table=read_branch_table(path)")
        t.signature.check(self.model.signature, exact_switching=True)
        if self.cross not in ("regression", "zero"):
            raise EstimatorError(f"unknown cross-covariance rule {self.cross!r}; use 'regression' or 'zero'")
        band = np.broadcast_to(np.asarray(self.band, float), (len(t.switching),)).copy()
        if np.any(band < 0) or not np.all(np.isfinite(band)):
            raise EstimatorError(f"band must be >= 0, got {self.band!r}")
        object.__setattr__(self, "band", band)

    @property
    def _table(self) -> BranchTable:
        """The branch table (checked when built, never None)."""
        assert self.table is not None  # __post_init__ refuses a DUKF without one
        return self.table

    def frozen_coordinates(self, signs: Sequence[int]) -> tuple[bool, ...]:
        """For the filter coordinates (states, then parameter coordinates): frozen in this branch?"""
        frozen_params = {p for p, f in zip(self.model.parameters, self._table.frozen_mask(signs)) if f}
        coords = tuple(bool(dep) and set(dep) <= frozen_params for dep in self._coordinates.depends)
        return (False,) * self.model.nx + coords

    def _extra_key(self) -> tuple:
        return (id(self.table), self.cross, tuple(np.asarray(self.band)))

    def _cross(self) -> str:
        return self.cross

    def _active_and_signs(self, z: ca.MX, u: ca.MX, prev: ca.MX, scale: ca.MX) -> tuple[ca.MX, ca.MX]:
        g, band = self._switching_at(z, u, scale), np.asarray(self.band)
        matched: Any = 0  # casadi expressions once the first branch is added
        active: Any = 0
        for b in self._table.branches:
            hit = 1
            for j, s in enumerate(b.signs):
                hit = ca.logic_and(hit, s * g[j] > band[j])
            mask = 1.0 - np.asarray(self.frozen_coordinates(b.signs), float)
            active = active + hit * ca.DM(mask)
            matched = matched + hit
        return active + (1 - matched) * prev, ca.sign(g)

    def branch_labels(self, signs: np.ndarray) -> list[str]:
        """Branch label per row of ``Trajectory.signs`` (``""`` on a switching surface)."""
        lookup = {tuple(b.signs): b.label for b in self._table.branches}
        out = []
        for row in np.atleast_2d(signs):
            out.append(lookup.get(tuple(int(v) for v in row), "") if np.all(np.isfinite(row)) else "")
        return out
