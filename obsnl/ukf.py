"""Unscented Kalman filter for joint state-parameter estimation, one filter step as one casadi Function.

The filter state is ``z = [x / state_scale; phi]``: scaled model states and parameter coordinates
``phi`` (``theta = coordinates.forward(phi)``, e.g. log parameters, so values from 1e-3 to 1e10
live together). Parameters are constant states with an optional random walk (``Q``).

One step (predict with ``u_k -> u_{k+1}``, update with ``y_{k+1}``) is one ``SX`` Function: scaled
sigma points (Julier 2002; ``alpha=1, beta=2, kappa=0`` by default, so every covariance weight is
``>= 0`` and the predicted covariance is a sum of PSD terms) from a Cholesky factor, every sigma
point through the full non-smooth discrete model (``Function.map``; RK4, with the implicit ROS2
fallback only for the sigma points where RK4 is unstable, see :mod:`obsnl.codegen`), unscented mean
and covariance, sigma points redrawn from the predicted mean and covariance for the update (so that
``Q`` reaches ``P_yy``; on a linear model the filter is then exactly the Kalman filter), Kalman
update, symmetrisation. ``run`` wraps the step in ``mapaccum``: one call for a whole record; with
``jit=True`` the whole step is compiled to C (about 15-30 s once, then a few times faster).

The step takes a mask of *active* coordinates; the UKF passes all ones, the DUKF
(:mod:`obsnl.dukf`) the mask of the current branch (see there for the frozen-block rule).

Repairs (counted per step in :class:`Trajectory`, never silent): a mean component outside
``bounds`` is put back on the bound; a Cholesky pivot below
``1e-12`` times its diagonal entry is raised to that floor; a sigma point whose propagated state is
not finite or beyond ``1e6`` typical magnitudes (``state_scale``) is replaced by the propagated
mean point. A NaN in the mean or
covariance stops ``run`` with an :class:`~obsnl.errors.EstimatorError`.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import casadi as ca
import numpy as np

from .codegen import NumericModel, ParameterMap, jit_options
from .errors import DataError, EstimatorError

__all__ = ["UKF", "Estimate", "Trajectory", "check_inputs"]

_PIVOT_FLOOR = 1e-12
_BIG = 1e6  # scaled states: a million times their typical magnitude


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

    def to_dict(self) -> dict[str, Any]:
        return {"k": self.k, "z": self.z.tolist(), "P": self.P.tolist(), "x": self.x.tolist(),
                "theta": self.theta.tolist(), "active": self.active.astype(bool).tolist()}


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
    repairs
        Repairs per step (floored Cholesky pivots + replaced sigma points).
    implicit
        Sigma points per step whose propagation needed the implicit (ROS2) fallback.
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
    repairs: np.ndarray
    implicit: np.ndarray
    seconds: float
    names: tuple[str, ...]
    parameters: tuple[str, ...]
    states: tuple[str, ...]

    @property
    def final(self) -> Estimate:
        return Estimate(k=len(self.t) - 1, z=self.z[-1], P=self.P[-1], x=self.x[-1], theta=self.theta[-1],
                        active=self.active[-1])

    @property
    def total_repairs(self) -> int:
        return int(np.sum(self.repairs))

    def to_dict(self) -> dict[str, Any]:
        return {"names": list(self.names), "parameters": list(self.parameters), "states": list(self.states),
                "t": self.t.tolist(), "theta": self.theta.tolist(), "x": self.x.tolist(),
                "P_diag": np.diagonal(self.P, axis1=1, axis2=2).tolist(),
                "innovations": self.innovations.tolist(), "signs": self.signs.tolist(),
                "repairs": self.repairs.tolist(), "implicit": self.implicit.tolist(), "seconds": self.seconds}


# --------------------------------------------------------------------------- the symbolic step
def _chol_floor(A: ca.SX, n: int) -> tuple[ca.SX, ca.SX]:
    """Lower Cholesky factor of ``A``; pivots below ``1e-12 * A_jj`` are floored (and counted)."""
    L = ca.SX.zeros(n, n)
    repairs = ca.SX(0)
    for j in range(n):
        s = A[j, j] - sum((L[j, k] ** 2 for k in range(j)), ca.SX(0))
        floor = _PIVOT_FLOOR * ca.fmax(A[j, j], 1e-300)
        bad = s < floor
        repairs += bad
        d = ca.sqrt(ca.if_else(bad, floor, s))
        L[j, j] = d
        for i in range(j + 1, n):
            L[i, j] = (A[i, j] - sum((L[i, k] * L[j, k] for k in range(j)), ca.SX(0))) / d
    return L, repairs


def _sym_outer(D: ca.SX, w: ca.SX, n: int) -> ca.SX:
    """``D diag(w) D^T`` computing only the lower triangle (symmetric result)."""
    low = ca.mac(D * ca.repmat(w.T, n, 1), D.T, ca.SX.zeros(ca.Sparsity.lower(n)))
    return low + ca.tril(low, False).T


def _lower_solve(L: ca.SX, B: ca.SX, n: int) -> ca.SX:
    """``L^{-1} B`` by forward substitution (``L`` lower triangular)."""
    X = ca.SX.zeros(B.shape)
    for i in range(n):
        X[i, :] = (B[i, :] - ca.mtimes(L[i, :i], X[:i, :])) / L[i, i] if i else B[i, :] / L[i, i]
    return X


def build_step(model: NumericModel, coords: ParameterMap, dt: float, *, state_scale: np.ndarray,
               method: str, substeps: int, cross: str = "regression") -> ca.Function:
    """The filter step ``(z, P, u0, u1, y, active, Q, R, hyp) -> (z+, P+, y_pred, nu, S, repairs, implicit)``.

    ``hyp = [alpha, beta, kappa]``; ``active`` is 1 for estimated coordinates, 0 for frozen ones;
    ``cross`` is the DUKF rule for the frozen-active covariance (``"regression"`` or ``"zero"``);
    ``implicit`` counts the sigma points that needed the implicit fallback of the discrete step.
    Three SX blocks (sigma points, propagation mapped over the sigma points, unscented update)
    joined in an MX Function, so that the implicit fallback is only evaluated where needed.
    """
    if cross not in ("regression", "zero"):
        raise EstimatorError(f"unknown cross-covariance rule {cross!r}; use 'regression' or 'zero'")
    nx, nq, ny, nu_ = model.nx, len(coords.names), model.ny, model.nu
    L = nx + nq
    npts = 2 * L + 1
    opts: dict[str, Any] = {}
    scale = ca.DM(np.asarray(state_scale, float))

    # 1. sigma points over the active coordinates only, every one through RK4 (the common case)
    z, P, a, hyp = ca.SX.sym("z", L), ca.SX.sym("P", L, L), ca.SX.sym("active", L), ca.SX.sym("hyp", 3)
    u0, u1 = ca.SX.sym("u0", nu_), ca.SX.sym("u1", nu_)
    alpha, beta, kappa = hyp[0], hyp[1], hyp[2]
    A, U = ca.diag(a), ca.diag(1 - a)
    nA = ca.sum1(a)
    lam = alpha ** 2 * (nA + kappa) - nA
    gam = ca.sqrt(nA + lam)
    S, rep_chol = _chol_floor(ca.mtimes([A, P, A]) + U, L)
    Sm = ca.mtimes(A, S)
    X = ca.horzcat(z, ca.repmat(z, 1, L) + gam * Sm, ca.repmat(z, 1, L) - gam * Sm)
    fns = model.integrators(dt, substeps=substeps, scale=state_scale)
    zc = ca.SX.sym("zc", L)
    xc, th = zc[:nx] * scale, coords.forward(zc[nx:])
    first = "ros2" if method == "ros2" else "rk4"
    xr = fns[first](xc, th, u0, u1)
    stiff = fns["stiff"](xc, xr, th, u0, u1, 2.0) if method == "auto" else ca.SX(0)
    prop = ca.Function("prop", [zc, u0, u1], [ca.vertcat(xr / scale, zc[nx:]), stiff]).map(npts)
    Xp, flags = prop(X, u0, u1)
    sig = ca.Function("sigma_points", [z, P, a, hyp, u0, u1], [X, S, rep_chol, Xp, flags], opts)

    # 2. the implicit fallback (ROS2) for the flagged sigma points; evaluated only when one is flagged
    imp = ca.Function("implicit", [zc, u0, u1], [ca.vertcat(fns["ros2"](xc, th, u0, u1) / scale, zc[nx:])], opts)
    zM, xM, fM = ca.MX.sym("zc", L), ca.MX.sym("xr", L), ca.MX.sym("flag")
    u0M, u1M = ca.MX.sym("u0", nu_), ca.MX.sym("u1", nu_)
    fix = ca.Function("fix", [zM, xM, fM, u0M, u1M], [ca.if_else(fM, imp(zM, u0M, u1M), xM, True)]).map(npts)

    # 3. unscented mean and covariance, frozen-active covariance, update
    Xp, y, Q, R = ca.SX.sym("Xp", L, npts), ca.SX.sym("y", ny), ca.SX.sym("Q", L, L), ca.SX.sym("R", ny, ny)
    S_ = ca.SX.sym("S", L, L)
    good = ca.SX.ones(1, npts - 1)
    for i in range(nx):
        good = ca.logic_and(good, ca.fabs(Xp[i, 1:]) < _BIG)
    rep = ca.sum2(1 - good)
    Xp_ = ca.horzcat(Xp[:, 0], ca.if_else(ca.repmat(good, L, 1), Xp[:, 1:], ca.repmat(Xp[:, 0], 1, npts - 1)))
    w = a / (2 * (nA + lam))
    Wm = ca.vertcat(lam / (nA + lam), w, w)
    Wc = ca.vertcat(lam / (nA + lam) + 1 - alpha ** 2 + beta, w, w)
    m = ca.mtimes(A, ca.mtimes(Xp_, Wm)) + ca.mtimes(U, z)  # frozen means kept exactly
    D = Xp_ - ca.repmat(m, 1, npts)
    Psig = _sym_outer(D, Wc, L)
    if cross == "regression":   # frozen block regressed on the prior active block (dukf.py)
        G = _lower_solve(S_, ca.mtimes(P, U), L)                 # S^-1 P_{.,U}
        PAU = ca.mtimes([A, gam * (Xp_[:, 1:L + 1] - Xp_[:, L + 1:]), ca.diag(w), G])
    else:
        PAU = ca.SX.zeros(L, L)
    Pp = ca.mtimes([A, Psig + Q, A]) + ca.mtimes([U, P, U]) + PAU + PAU.T

    # update: sigma points redrawn from the predicted mean and covariance (so that Q reaches P_yy)
    S2, rep2 = _chol_floor(ca.mtimes([A, Pp, A]) + U, L)
    S2m = ca.mtimes(A, S2)
    X2 = ca.horzcat(m, ca.repmat(m, 1, L) + gam * S2m, ca.repmat(m, 1, L) - gam * S2m)
    zx = ca.SX.sym("zx", L)
    hf = ca.Function("hz", [zx, u1], [model.h(zx[:nx] * scale, coords.forward(zx[nx:]), u1)])
    Y = hf.map(npts)(X2, u1)
    yhat = ca.mtimes(Y, Wm)
    dY = Y - ca.repmat(yhat, 1, npts)
    Pyy = ca.mtimes([dY, ca.diag(Wc), dY.T]) + R
    Pzy = ca.mtimes([X2 - ca.repmat(m, 1, npts), ca.diag(Wc), dY.T])
    if cross == "regression":   # P_Uy = P_UA- (P_AA-)^-1 P_A-y through the same sigma points
        G2 = _lower_solve(S2, ca.mtimes(Pp, U), L)
        Pzy_full = Pzy + ca.mtimes([U, gam * G2.T, ca.diag(w), (Y[:, 1:L + 1] - Y[:, L + 1:]).T])
    else:
        Pzy_full = Pzy
    K = ca.mtimes(A, ca.solve(Pyy, Pzy.T).T) if ny > 1 else ca.mtimes(A, Pzy / Pyy)
    nu = y - yhat
    zn = m + ca.mtimes(K, nu)
    lo, hi = ca.SX.sym("lo", L), ca.SX.sym("hi", L)
    clamped = ca.fmin(ca.fmax(zn, lo), hi)  # the valid region: a mean outside it is put back on its edge
    rep += ca.sum1(clamped != zn)
    zn = clamped
    Pn = Pp - ca.mtimes(K, Pzy_full.T) - ca.mtimes(Pzy_full, K.T) + ca.mtimes([K, Pyy, K.T])
    Pn = 0.5 * (Pn + Pn.T)
    rep = rep + rep2
    upd = ca.Function("update", [z, P, a, hyp, S_, Xp, u1, y, Q, R, lo, hi], [zn, Pn, yhat, nu, Pyy, rep], opts)

    # joined
    zM, PM, aM, hM = ca.MX.sym("z", L), ca.MX.sym("P", L, L), ca.MX.sym("active", L), ca.MX.sym("hyp", 3)
    u0M, u1M, yM = ca.MX.sym("u0", nu_), ca.MX.sym("u1", nu_), ca.MX.sym("y", ny)
    QM, RM = ca.MX.sym("Q", L, L), ca.MX.sym("R", ny, ny)
    XM, SM, rc, XpM, flM = sig(zM, PM, aM, hM, u0M, u1M)
    nflag = ca.sum2(flM)
    XpM = ca.if_else(nflag > 0, fix(XM, XpM, flM, u0M, u1M), XpM, True)
    loM, hiM = ca.MX.sym("lo", L), ca.MX.sym("hi", L)
    zn, Pn, yp, nuM, Syy, ru = upd(zM, PM, aM, hM, SM, XpM, u1M, yM, QM, RM, loM, hiM)
    return ca.Function("ukf_step", [zM, PM, u0M, u1M, yM, aM, QM, RM, hM, loM, hiM],
                       [zn, Pn, yp, nuM, Syy, rc + ru, nflag],
                       ["z", "P", "u0", "u1", "y", "active", "Q", "R", "hyp", "lo", "hi"],
                       ["z_next", "P_next", "y_pred", "innovation", "S", "repairs", "implicit"])


def check_inputs(ys: Any, us: Any, *, ny: int, nu: int) -> tuple[np.ndarray, np.ndarray]:
    """Validate a record for a filter: shapes ``(T, ny)``, ``(T, nu)``, finite values.

    Raises
    ------
    DataError
        Wrong shapes, too short, or NaN/inf (naming the first bad sample).
    """
    ys = np.asarray(ys, float)
    us = np.asarray(us, float)
    ys = ys.reshape(-1, 1) if ys.ndim == 1 and ny == 1 else ys
    us = us.reshape(-1, 1) if us.ndim == 1 and nu == 1 else us
    if ys.ndim != 2 or ys.shape[1] != ny:
        raise DataError(f"outputs must have shape (T, {ny}), got {ys.shape}")
    if us.ndim != 2 or us.shape[1] != nu:
        raise DataError(f"inputs must have shape (T, {nu}), got {us.shape}")
    if len(ys) != len(us):
        raise DataError(f"outputs have {len(ys)} samples but inputs {len(us)}; give one of each per sample")
    if len(ys) < 2:
        raise DataError("a record needs at least 2 samples")
    for name, arr in (("outputs", ys), ("inputs", us)):
        bad = np.flatnonzero(~np.all(np.isfinite(arr), axis=1))
        if bad.size:
            raise DataError(f"{name} contain NaN/inf at sample {bad[0]} ({bad.size} bad samples); "
                            f"clean or interpolate the record first")
    return ys, us


# --------------------------------------------------------------------------- the filter
def _identity_map(names: Sequence[str]) -> ParameterMap:
    p = ca.SX.sym("p", len(names))
    f = ca.Function("identity", [p], [p])
    return ParameterMap(names=tuple(names), parameters=tuple(names), forward=f, inverse=f,
                        depends=tuple((n,) for n in names))


def _matrix(value: Any, n: int, what: str) -> np.ndarray:
    arr = np.asarray(value, float)
    if arr.ndim == 0:
        arr = arr * np.eye(n)
    elif arr.ndim == 1:
        arr = np.diag(arr)
    if arr.shape != (n, n):
        raise EstimatorError(f"{what} must be a scalar, a diagonal of length {n} or a {n}x{n} matrix; got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise EstimatorError(f"{what} contains NaN/inf")
    if not np.allclose(arr, arr.T, rtol=1e-10, atol=0.0):
        raise EstimatorError(f"{what} must be symmetric")
    if np.linalg.eigvalsh(arr).min() < -1e-12 * max(1.0, np.abs(arr).max()):
        raise EstimatorError(f"{what} must be positive semidefinite (smallest eigenvalue "
                             f"{np.linalg.eigvalsh(arr).min():.3g})")
    return arr


@dataclass(frozen=True, eq=False)
class UKF:
    """Scaled unscented Kalman filter for joint state-parameter estimation (frozen configuration).

    Parameters
    ----------
    model
        The compiled model (:func:`obsnl.codegen.to_casadi`).
    dt
        Sampling interval of the records it will filter.
    coordinates
        Parameter coordinates (:func:`obsnl.codegen.log_map`, :func:`obsnl.codegen.parameter_map`);
        default: the parameters themselves.
    state_scale
        Filter states are ``x / state_scale`` (default 1).
    Q, R
        Process noise per step (``L x L`` in filter coordinates, or its diagonal) and measurement
        noise covariance (``ny x ny``). Changing them with :meth:`with_options` does not recompile.
    alpha, beta, kappa
        Scaled unscented transform (default ``1, 2, 0``: all covariance weights ``>= 0``).
    method, substeps
        Discrete step of the model (:meth:`obsnl.codegen.NumericModel.step`).
    jit
        Compile the step to C (needs a C compiler; off by default).
    fixed
        Parameters held at their initial value (no spread, no update, no noise), e.g. parameters
        found practically unidentifiable; the coordinates that move only them are frozen.
    bounds
        ``(lo, hi)`` in filter coordinates (``-inf``/``inf`` allowed): the valid region. A mean that an
        update takes outside is put back on the edge and counted as a repair (a filter diverging
        along a direction the data do not yet inform otherwise runs to ``exp`` overflow).

    Examples
    --------
    >>> import numpy as np
    >>> from obsnl import Model, UKF
    >>> from obsnl.codegen import to_casadi
    >>> m = Model(name="osc", states=["x", "v"], parameters=["k"], inputs=["u"],
    ...           equations={"x": "v", "v": "u - k*x - v"}, outputs={"y": "x"})
    >>> f = UKF(to_casadi(m), dt=0.1, Q=1e-8, R=1e-4)
    >>> est = f.initial(x0=[0.0, 0.0], theta0=[4.0], P0=[1e-6, 1e-6, 1.0])
    >>> est = f.step(est, y=[0.0], u0=[1.0], u1=[1.0])
    >>> est.z.shape
    (3,)
    """

    model: NumericModel
    dt: float
    coordinates: ParameterMap | None = None
    state_scale: Any = None
    Q: Any = 0.0
    R: Any = None
    alpha: float = 1.0
    beta: float = 2.0
    kappa: float = 0.0
    method: str = "auto"
    substeps: int = 8
    jit: bool = False
    fixed: tuple[str, ...] = ()
    bounds: Any = None
    cache: dict = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self) -> None:
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731
        if not (np.isfinite(self.dt) and self.dt > 0):
            raise EstimatorError(f"dt must be a positive number, got {self.dt!r}")
        coords = self.coordinates or _identity_map(self.model.parameters)
        if coords.parameters != self.model.parameters:
            raise EstimatorError(f"coordinates are for parameters {list(coords.parameters)}, the model has "
                                 f"{list(self.model.parameters)}")
        set_("coordinates", coords)
        scale = np.ones(self.model.nx) if self.state_scale is None else np.asarray(self.state_scale, float)
        if scale.shape != (self.model.nx,) or not np.all(np.isfinite(scale)) or np.any(scale <= 0):
            raise EstimatorError(f"state_scale must be {self.model.nx} positive numbers, got {self.state_scale!r}")
        set_("state_scale", scale)
        set_("Q", _matrix(self.Q, self.size, "Q"))
        if self.R is None:
            raise EstimatorError("give the measurement noise covariance R (ny x ny, or a scalar)")
        set_("R", _matrix(self.R, self.model.ny, "R"))
        if np.linalg.eigvalsh(self.R).min() <= 0:
            raise EstimatorError("R must be positive definite")
        unknown = set(self.fixed) - set(self.model.parameters)
        if unknown:
            raise EstimatorError(f"fixed names {sorted(unknown)} are not parameters of {self.model.name!r}")
        set_("fixed", tuple(self.fixed))
        if self.bounds is not None:
            lo, hi = (np.broadcast_to(np.asarray(b, float), (self.size,)).copy() for b in self.bounds)
            if np.any(np.isnan(lo)) or np.any(np.isnan(hi)) or np.any(lo >= hi):
                raise EstimatorError("bounds must be (lo, hi) with lo < hi for every filter coordinate")
            set_("bounds", (lo, hi))
        if not (self.alpha > 0 and self.size + self.kappa > 0):
            raise EstimatorError(f"need alpha > 0 and L + kappa > 0 (alpha={self.alpha}, kappa={self.kappa})")

    # ------------------------------------------------------------------ sizes, coordinates
    @property
    def size(self) -> int:
        """Length ``L`` of the filter state (states + parameter coordinates)."""
        return self.model.nx + len(self.coordinates.names)

    @property
    def names(self) -> tuple[str, ...]:
        return self.model.states + self.coordinates.names

    def with_options(self, **changes: Any) -> UKF:
        """A copy with some options changed (compiled functions are reused where possible)."""
        return replace(self, **changes)

    def to_z(self, x: Any, theta: Any) -> np.ndarray:
        return np.concatenate([np.asarray(x, float) / self.state_scale, self.coordinates.to_phi(theta)])

    def split(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Model states and parameters of filter means ``z`` (``(L,)`` or ``(T, L)``)."""
        z = np.atleast_2d(z)
        nx = self.model.nx
        th = np.asarray(self.coordinates.forward.map(len(z))(z[:, nx:].T)).T
        return z[:, :nx] * self.state_scale, th

    def initial(self, *, x0: Any, theta0: Any, P0: Any) -> Estimate:
        """The starting estimate from model states, model parameters and ``P0`` in filter coordinates."""
        x0, theta0 = np.asarray(x0, float), np.asarray(theta0, float)
        if x0.shape != (self.model.nx,) or theta0.shape != (self.model.np,):
            raise EstimatorError(f"x0 needs {self.model.nx} values and theta0 {self.model.np}")
        z = self.to_z(x0, theta0)
        if not np.all(np.isfinite(z)):
            raise EstimatorError(f"theta0 {theta0.tolist()} is outside the coordinates' domain (e.g. a log of "
                                 f"a value <= 0)")
        P = _matrix(P0, self.size, "P0")
        if np.linalg.eigvalsh(P).min() <= 0:
            raise EstimatorError("P0 must be positive definite")
        x, th = self.split(z)
        return Estimate(k=0, z=z, P=P, x=x[0], theta=th[0], active=self.allowed)

    # ------------------------------------------------------------------ compiled functions
    def _key(self) -> tuple:
        return (id(self.model), id(self.coordinates), self.dt, tuple(self.state_scale), self.method,
                self.substeps, self.jit, type(self).__name__) + self._extra_key()

    def _extra_key(self) -> tuple:
        return ()

    def _active_and_signs(self, z: ca.MX, u: ca.MX, prev: ca.MX) -> tuple[ca.MX, ca.MX]:
        """Active mask and switching-function signs at the mean (UKF: everything active)."""
        return ca.MX(ca.DM.ones(self.size)), ca.sign(self._switching_at(z, u))

    def _switching_at(self, z: ca.MX, u: ca.MX) -> ca.MX:
        nx = self.model.nx
        return self.model.g(z[:nx] * ca.DM(self.state_scale), self.coordinates.forward(z[nx:]), u)

    def _cross(self) -> str:
        return "zero"  # nothing is ever frozen in the UKF: both rules coincide, "zero" is cheaper

    def _compiled(self) -> ca.Function:
        key = self._key()
        if key not in self.cache:
            core = build_step(self.model, self.coordinates, self.dt, state_scale=self.state_scale,
                              method=self.method, substeps=self.substeps, cross=self._cross())
            L, m, nu, ny = self.size, len(self.model.switching), self.model.nu, self.model.ny
            z, P, prev = ca.MX.sym("z", L), ca.MX.sym("P", L, L), ca.MX.sym("prev", L)
            u0, u1, y = ca.MX.sym("u0", nu), ca.MX.sym("u1", nu), ca.MX.sym("y", ny)
            Q, R, hyp = ca.MX.sym("Q", L, L), ca.MX.sym("R", ny, ny), ca.MX.sym("hyp", 3)
            allowed = ca.MX.sym("allowed", L)
            act, signs = self._active_and_signs(z, u0, prev)
            act = act * allowed
            lo, hi = ca.MX.sym("lo", L), ca.MX.sym("hi", L)
            zn, Pn, yp, nuv, S, rep, imp = core(z, P, u0, u1, y, act, Q, R, hyp, lo, hi)
            opts = jit_options() if self.jit else {}
            self.cache[key] = ca.Function(
                "filter_step", [z, P, prev, u0, u1, y, Q, R, hyp, allowed, lo, hi],
                [zn, Pn, act, yp, nuv, S, rep, imp, signs if m else ca.MX.zeros(0)], opts)
        return self.cache[key]

    def _bounds(self) -> tuple[np.ndarray, np.ndarray]:
        if self.bounds is None:
            return np.full(self.size, -np.inf), np.full(self.size, np.inf)
        return self.bounds

    @property
    def allowed(self) -> np.ndarray:
        """1 for coordinates the filter may estimate, 0 for those held fixed (``fixed``)."""
        held = set(self.fixed)
        return np.array([0.0 if dep and set(dep) <= held else 1.0
                         for dep in ((),) * self.model.nx + self.coordinates.depends])

    def _hyp(self) -> np.ndarray:
        return np.array([self.alpha, self.beta, self.kappa], float)

    # ------------------------------------------------------------------ filtering
    def step(self, est: Estimate, *, y: Any, u0: Any, u1: Any) -> Estimate:
        """One step: predict from ``u0`` to ``u1`` over ``dt``, update with the measurement ``y``."""
        ys, us = check_inputs(np.vstack([np.reshape(y, (1, -1))] * 2), np.vstack([np.reshape(u0, (1, -1)),
                              np.reshape(u1, (1, -1))]), ny=self.model.ny, nu=self.model.nu)
        out = self._compiled()(est.z, est.P, est.active, us[0], us[1], ys[1], self.Q, self.R, self._hyp(),
                               self.allowed, *self._bounds())
        z, P = np.asarray(out[0]).ravel(), np.asarray(out[1])
        if not (np.all(np.isfinite(z)) and np.all(np.isfinite(P))):
            raise EstimatorError(f"the filter produced NaN/inf at step {est.k + 1}; lower P0/Q, use method='ros2' "
                                 f"or more substeps")
        x, th = self.split(z)
        return Estimate(k=est.k + 1, z=z, P=P, x=x[0], theta=th[0], active=np.asarray(out[2]).ravel())

    def run(self, est0: Estimate, ys: Any, us: Any, *, t: Any = None) -> Trajectory:
        """Filter a whole record (``ys[0]`` is the sample of ``est0``; it is not used).

        Returns
        -------
        Trajectory
            Estimates at every sample; raises :class:`~obsnl.errors.EstimatorError` at the first NaN.
        """
        ys, us = check_inputs(ys, us, ny=self.model.ny, nu=self.model.nu)
        T, L = len(ys), self.size
        fn = self._compiled()
        key = ("mapaccum", self._key(), T)
        if key not in self.cache:
            self.cache[key] = fn.mapaccum("run", T - 1, 3, {})
        tic = time.perf_counter()
        out = self.cache[key](est0.z, est0.P, est0.active, us[:-1].T, us[1:].T, ys[1:].T, self.Q, self.R,
                              self._hyp(), self.allowed, *self._bounds())
        seconds = time.perf_counter() - tic
        Z = np.vstack([est0.z, np.asarray(out[0]).T])
        Ps = np.concatenate([est0.P[None], np.asarray(out[1]).T.reshape(T - 1, L, L).transpose(0, 2, 1)])
        bad = np.flatnonzero(~(np.all(np.isfinite(Z), axis=1) & np.all(np.isfinite(Ps), axis=(1, 2))))
        if bad.size:
            raise EstimatorError(f"the filter produced NaN/inf at step {bad[0]} of {T}; lower P0/Q, use "
                                 f"method='ros2' or more substeps")
        nan_row = lambda a: np.vstack([np.full((1, a.shape[0]), np.nan), a.T])  # noqa: E731
        ny = self.model.ny
        S = np.concatenate([np.full((1, ny, ny), np.nan), np.asarray(out[5]).T.reshape(T - 1, ny, ny)])
        signs = np.asarray(out[8]).T if len(self.model.switching) else np.zeros((T - 1, 0))
        X, TH = self.split(Z)
        return Trajectory(
            t=np.arange(T) * self.dt if t is None else np.asarray(t, float), z=Z, P=Ps, x=X, theta=TH,
            y_pred=nan_row(np.asarray(out[3])), innovations=nan_row(np.asarray(out[4])), S=S,
            signs=np.vstack([signs, np.full((1, signs.shape[1]), np.nan)]) if signs.size else signs,
            active=np.vstack([est0.active, np.asarray(out[2]).T]),
            repairs=np.concatenate([[0], np.asarray(out[6]).ravel()]).astype(int),
            implicit=np.concatenate([[0], np.asarray(out[7]).ravel()]).astype(int),
            seconds=seconds, names=self.names, parameters=self.model.parameters, states=self.model.states)
