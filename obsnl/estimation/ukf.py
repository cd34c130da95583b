"""Unscented Kalman filter for joint state-parameter estimation, one filter step as one casadi Function.

The filter state is ``z = [x / state_scale; phi]``: scaled model states and parameter coordinates
``phi`` (``theta = coordinates.forward(phi)``, e.g. log parameters, so values from 1e-3 to 1e10
live together). Parameters are constant states with an optional random walk (``Q``).

One step (predict with ``u_k -> u_{k+1}``, update with ``y_{k+1}``) is one casadi Function built by
:mod:`obsnl.estimation.ukf_step` (scaled sigma points, ``alpha=1, beta=2, kappa=0`` by default so that every
covariance weight is ``>= 0``; every sigma point through the full non-smooth discrete model;
sigma points redrawn for the update, so that on a linear model the filter is exactly the Kalman
filter; an output sample that is NaN is missing, and the update uses the outputs present). ``run`` wraps
the step in ``mapaccum``: one call for a whole record; with ``jit=True`` the whole step is compiled to C
(30-50 s once per model and filter, whatever the record; then a few times faster).

The step takes a mask of *active* coordinates; the UKF passes all ones, the DUKF
(:mod:`obsnl.estimation.dukf`) the mask of the current branch (see there for the frozen-block rule).

Interventions (counted per step and kind in :class:`Trajectory`, never silent; rules in
:mod:`obsnl.estimation.ukf_step`): floored Cholesky pivots, replaced sigma points, the innovation gate
(``gate``), rejected updates (non-finite or indefinite: the prediction is kept), held steps (the
prediction is not finite: the previous estimate is kept), means put back into ``bounds``, standard
deviations capped at ``cap``. No step can produce NaN or inf from a finite start; ``run`` still
checks and raises :class:`~obsnl.errors.EstimatorError` if one ever did.
"""

from __future__ import annotations

import time
from collections.abc import Hashable, Sequence
from dataclasses import dataclass, field, fields, replace
from typing import Any

import casadi as ca
import numpy as np
import numpy.typing as npt

from obsnl.errors import EstimatorError
from obsnl.estimation.accelerogram import check_inputs
from obsnl.estimation.jitcache import jit_compile
from obsnl.estimation.numeric import NumericModel, ParameterMap
from obsnl.estimation.simulate import call
from obsnl.estimation.trajectory import Estimate, Trajectory
from obsnl.estimation.ukf_step import INTERVENTIONS, build_step

__all__ = ["UKF", "Estimate", "Trajectory"]


# --------------------------------------------------------------------------- the filter
def _record(ys: Any, us: Any, *, ny: int, nu: int) -> tuple[np.ndarray, np.ndarray]:
    """``(ys, us)`` checked as :func:`~obsnl.estimation.accelerogram.check_inputs` does, except that an output may
    be NaN: a missing sample, which the step skips (its update uses the outputs present)."""
    ys = np.asarray(ys, float)
    gaps = np.isnan(ys)
    ys, us = check_inputs(np.where(gaps, 0.0, ys), us, ny=ny, nu=nu)
    return np.where(gaps.reshape(ys.shape), np.nan, ys), us


def _identity_map(names: Sequence[str]) -> ParameterMap:
    p = ca.SX.sym("p", len(names))
    f = ca.Function("identity", [p], [p])
    return ParameterMap(
        names=tuple(names), parameters=tuple(names), forward=f, inverse=f, depends=tuple((n,) for n in names)
    )


def _matrix(value: Any, n: int, what: str) -> np.ndarray:
    arr = np.asarray(value, float)
    if arr.ndim == 0:
        arr = arr * np.eye(n)
    elif arr.ndim == 1:
        arr = np.diag(arr)
    if arr.shape != (n, n):
        raise EstimatorError(
            f"{what} must be a scalar, a diagonal of length {n} or a {n}x{n} matrix; got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise EstimatorError(f"{what} contains NaN/inf")
    if not np.allclose(arr, arr.T, rtol=1e-10, atol=0.0):
        raise EstimatorError(f"{what} must be symmetric")
    if np.linalg.eigvalsh(arr).min() < -1e-12 * max(1.0, np.abs(arr).max()):
        raise EstimatorError(
            f"{what} must be positive semidefinite (smallest eigenvalue {np.linalg.eigvalsh(arr).min():.3g})"
        )
    return arr


@dataclass(frozen=True, eq=False)
class UKF:
    """Scaled unscented Kalman filter for joint state-parameter estimation (frozen configuration).

    Parameters
    ----------
    model : NumericModel
        The compiled model (:func:`obsnl.estimation.codegen.to_casadi`).
    dt : float
        Sampling interval of the records it will filter.
    coordinates : ParameterMap or None
        Parameter coordinates (:func:`obsnl.estimation.codegen.log_map`, :func:`obsnl.estimation.codegen.parameter_map`);
        default: the parameters themselves.
    state_scale : array_like or None
        Filter states are ``x / state_scale`` (default 1).
    Q, R : array_like
        Process noise per step (``L x L`` in filter coordinates, or its diagonal) and measurement
        noise covariance (``ny x ny``). Changing them with :meth:`with_options` does not recompile.
    alpha, beta, kappa : float
        Scaled unscented transform (default ``1, 2, 0``: all covariance weights ``>= 0``).
    method : str
    substeps, refine : int
        Discrete step of the model (:meth:`obsnl.estimation.numeric.NumericModel.step`): RK4 with ``substeps``
        (default 4); a sigma point whose step is stiff for RK4 is redone with ROS2 and ``refine * substeps``, one
        whose step crosses a switching function across which the field can jump with that substep split into
        ``refine`` (default 8).
    locate : bool
        That substep split at the located crossing instead, sliding modes followed (default off).
    jit : bool
        Compile the step to C (needs a C compiler; off by default).
    fixed : tuple of str
        Parameters held at their initial value (no spread, no update, no noise), e.g. parameters
        found practically unidentifiable; the coordinates that move only them are frozen.
    gate : float
        Innovation gate: beyond this Mahalanobis distance the gain is scaled down (Huber-type,
        :mod:`obsnl.estimation.ukf_step`); default ``inf`` (off). Changing it does not recompile.
    cap : array_like
        Ceiling of the standard deviations in filter coordinates (scalar or one per coordinate;
        default ``inf``, off); larger ones are scaled down by a congruence (PSD kept) and counted.
    bounds : (array_like, array_like) or None
        ``(lo, hi)`` in filter coordinates (``-inf``/``inf`` allowed): the valid region. A mean that an
        update takes outside is put back on the edge and counted as a repair (a filter diverging
        along a direction the data do not yet inform otherwise runs to ``exp`` overflow).
    cache : dict
        The compiled Functions (and coordinate maps) of this filter, by options; filled as it runs.

    Notes
    -----
    The array options are typed as given (``numpy.typing.ArrayLike``); once built the filter holds them as
    float arrays (``Q`` and ``R`` as full matrices, ``state_scale`` and ``cap`` as one entry per state or
    coordinate, ``bounds`` as a pair of arrays).

    References
    ----------
    .. [1] S. J. Julier and J. K. Uhlmann, "Unscented filtering and nonlinear estimation", Proc. IEEE 92(3), 401-422,
       2004. doi:10.1109/JPROC.2003.823141

    Examples
    --------
    >>> from obsnl import Model
    >>> from obsnl.estimation import UKF, to_casadi
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
    state_scale: npt.ArrayLike | None = None
    Q: npt.ArrayLike = 0.0
    R: npt.ArrayLike | None = None
    alpha: float = 1.0
    beta: float = 2.0
    kappa: float = 0.0
    method: str = "auto"
    substeps: int = 4
    refine: int = 8
    locate: bool = False
    jit: bool = False
    fixed: tuple[str, ...] = ()
    bounds: tuple[npt.ArrayLike, npt.ArrayLike] | None = None
    gate: float = float("inf")
    cap: npt.ArrayLike = float("inf")
    cache: dict[tuple[Hashable, ...], ca.Function | tuple[ParameterMap, ca.Function]] = field(
        default_factory=dict, repr=False, compare=False
    )

    def __post_init__(self) -> None:
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731
        if not (np.isfinite(self.dt) and self.dt > 0):
            raise EstimatorError(f"dt must be a positive number, got {self.dt!r}")
        coords = self.coordinates or _identity_map(self.model.parameters)
        if coords.parameters != self.model.parameters:
            raise EstimatorError(
                f"coordinates are for parameters {list(coords.parameters)}, the model has {list(self.model.parameters)}"
            )
        set_("coordinates", coords)
        scale = np.ones(self.model.nx) if self.state_scale is None else np.asarray(self.state_scale, float)
        if scale.shape != (self.model.nx,) or not np.all(np.isfinite(scale)) or np.any(scale <= 0):
            raise EstimatorError(f"state_scale must be {self.model.nx} positive numbers, got {self.state_scale!r}")
        set_("state_scale", scale)
        set_("Q", _matrix(self.Q, self.size, "Q"))
        if self.R is None:
            raise EstimatorError("give the measurement noise covariance R (ny x ny, or a scalar)")
        R = _matrix(self.R, self.model.ny, "R")
        set_("R", R)
        if np.linalg.eigvalsh(R).min() <= 0:
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
        for k in ("substeps", "refine"):
            v = getattr(self, k)
            if not (isinstance(v, (int, np.integer)) and v >= 1):
                raise EstimatorError(f"{k} must be a whole number >= 1, got {v!r}")
        if not self.gate > 0:
            raise EstimatorError(f"gate must be > 0 (inf: off), got {self.gate!r}")
        cap = np.broadcast_to(np.asarray(self.cap, float), (self.size,)).copy()
        set_("cap", cap)
        if np.any(np.isnan(cap)) or np.any(cap <= 0):
            raise EstimatorError("cap must be > 0 (inf: off) for every filter coordinate")
        if not (self.alpha > 0 and self.size + self.kappa > 0):
            raise EstimatorError(f"need alpha > 0 and L + kappa > 0 (alpha={self.alpha}, kappa={self.kappa})")

    # ------------------------------------------------------------------ sizes, coordinates
    @property
    def _coordinates(self) -> ParameterMap:
        """The parameter coordinates: those given, else the identity (set once built, never None)."""
        assert self.coordinates is not None  # __post_init__ sets the identity map where none was given
        return self.coordinates

    @property
    def size(self) -> int:
        """Length ``L`` of the filter state (states + parameter coordinates)."""
        return self.model.nx + len(self._coordinates.names)

    @property
    def names(self) -> tuple[str, ...]:
        return self.model.states + self._coordinates.names

    def with_options(self, **changes: Any) -> UKF:
        """A copy with some options changed (compiled functions are reused where possible).

        Parameters
        ----------
        **changes : Any
            New values of options, by name: the keywords are the filter's constructor arguments (the dataclass's
            fields), so the call keeps the constructor's own contract; a name that is not one is refused.

        Returns
        -------
        UKF
            A filter of the same class (a :class:`~obsnl.estimation.dukf.DUKF` stays one).

        Raises
        ------
        EstimatorError
            A keyword that is not an option of the filter.
        """
        options = [f.name for f in fields(self) if f.init]
        unknown = [k for k in changes if k not in options]
        if unknown:  # dataclasses.replace would raise a TypeError
            raise EstimatorError(
                f"{type(self).__name__}.with_options takes the filter's options ({', '.join(options)}); "
                f"{unknown[0][:40]!r} is none"
            )
        return replace(self, **changes)

    def to_z(self, x: Any, theta: Any) -> np.ndarray:
        return np.concatenate([np.asarray(x, float) / self.state_scale, self._coordinates.to_phi(theta)])

    def split(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Model states and parameters of filter means ``z`` (``(L,)`` or ``(T, L)``)."""
        z, nx = np.atleast_2d(z), self.model.nx
        key = ("forward", id(self._coordinates), len(z))
        if key not in self.cache:  # keeps the coordinates alive with it: their id stays unique
            self.cache[key] = (self._coordinates, self._coordinates.forward.map(len(z)))
        kept = self.cache[key]
        forward = kept[1] if isinstance(kept, tuple) else kept
        th = call(forward, [z[:, nx:].T])[0].T
        return z[:, :nx] * np.asarray(self.state_scale), th

    def initial(self, *, x0: Any, theta0: Any, P0: Any) -> Estimate:
        """The starting estimate from model states, model parameters and ``P0`` in filter coordinates."""
        x0, theta0 = np.asarray(x0, float), np.asarray(theta0, float)
        if x0.shape != (self.model.nx,) or theta0.shape != (self.model.np,):
            raise EstimatorError(f"x0 needs {self.model.nx} values and theta0 {self.model.np}")
        z = self.to_z(x0, theta0)
        if not np.all(np.isfinite(z)):
            raise EstimatorError(
                f"theta0 {theta0.tolist()} is outside the coordinates' domain (e.g. a log of a value <= 0)"
            )
        P = _matrix(P0, self.size, "P0")
        if np.linalg.eigvalsh(P).min() <= 0:
            raise EstimatorError("P0 must be positive definite")
        x, th = self.split(z)
        return Estimate(k=0, z=z, P=P, x=x[0], theta=th[0], active=self.allowed)

    # ------------------------------------------------------------------ compiled functions
    def _key(self) -> tuple:
        return (
            id(self.model),
            id(self.coordinates),
            self.dt,
            self.method,
            self.substeps,
            self.refine,
            self.locate,
            self.jit,
            type(self).__name__,
        ) + self._extra_key()

    def _extra_key(self) -> tuple:
        return ()

    def _active_and_signs(self, z: ca.MX, u: ca.MX, prev: ca.MX, scale: ca.MX) -> tuple[ca.MX, ca.MX]:
        """Active mask and switching-function signs at the mean (UKF: everything active)."""
        return ca.MX(ca.DM.ones(self.size)), ca.sign(self._switching_at(z, u, scale))

    def _switching_at(self, z: ca.MX, u: ca.MX, scale: ca.MX) -> ca.MX:
        nx = self.model.nx
        return self.model.g(z[:nx] * scale, self._coordinates.forward(z[nx:]), u)

    def _cross(self) -> str:
        return "zero"  # nothing is ever frozen in the UKF: both rules coincide, "zero" is cheaper

    def _compiled(self) -> ca.Function:
        key = self._key()
        if key not in self.cache:
            core = build_step(
                self.model,
                self._coordinates,
                self.dt,
                method=self.method,
                substeps=self.substeps,
                cross=self._cross(),
                refine=self.refine,
                locate=self.locate,
            )
            L, m, nu, ny = self.size, len(self.model.switching), self.model.nu, self.model.ny
            z, P, prev = ca.MX.sym("z", L), ca.MX.sym("P", L, L), ca.MX.sym("prev", L)
            u0, u1, y = ca.MX.sym("u0", nu), ca.MX.sym("u1", nu), ca.MX.sym("y", ny)
            Q, R, hyp = ca.MX.sym("Q", L, L), ca.MX.sym("R", ny, ny), ca.MX.sym("hyp", 4)
            allowed, sc = ca.MX.sym("allowed", L), ca.MX.sym("scale", self.model.nx)
            act, signs = self._active_and_signs(z, u0, prev, sc)
            act = act * allowed
            lo, hi, cap = ca.MX.sym("lo", L), ca.MX.sym("hi", L), ca.MX.sym("cap", L)
            zn, Pn, yp, nuv, S, rep, imp, fine = core(z, P, u0, u1, y, act, Q, R, hyp, lo, hi, cap, sc)
            fn = ca.Function(
                "filter_step",
                [z, P, prev, u0, u1, y, Q, R, hyp, allowed, lo, hi, cap, sc],
                [zn, Pn, act, yp, nuv, S, rep, imp, signs if m else ca.MX.zeros(0), fine],
            )
            self.cache[key] = jit_compile(fn) if self.jit else fn  # compiled once per machine, then from disk
        return self._function(key)

    def _function(self, key: tuple[Hashable, ...]) -> ca.Function:
        """The compiled Function kept under ``key`` (the cache also keeps coordinate maps, as pairs)."""
        fn = self.cache[key]
        if not isinstance(fn, ca.Function):
            raise TypeError(f"the filter's cache holds no Function under {key!r}")  # a bug, never the user's
        return fn

    def _bounds(self) -> tuple[np.ndarray, np.ndarray]:
        if self.bounds is None:
            return np.full(self.size, -np.inf), np.full(self.size, np.inf)
        lo, hi = self.bounds
        return np.asarray(lo), np.asarray(hi)

    @property
    def allowed(self) -> np.ndarray:
        """1 for coordinates the filter may estimate, 0 for those held fixed (``fixed``)."""
        held = set(self.fixed)
        return np.array(
            [0.0 if dep and set(dep) <= held else 1.0 for dep in ((),) * self.model.nx + self._coordinates.depends]
        )

    def _hyp(self) -> np.ndarray:
        return np.array([self.alpha, self.beta, self.kappa, self.gate], float)

    # ------------------------------------------------------------------ filtering
    def step(self, est: Estimate, *, y: Any, u0: Any, u1: Any) -> Estimate:
        """One step: predict from ``u0`` to ``u1`` over ``dt``, update with the measurement ``y`` (NaN: an output
        not measured at this sample; the update uses the others, none: the prediction)."""
        ys, us = _record(
            np.vstack([np.reshape(y, (1, -1))] * 2),
            np.vstack([np.reshape(u0, (1, -1)), np.reshape(u1, (1, -1))]),
            ny=self.model.ny,
            nu=self.model.nu,
        )
        out = self._compiled()(
            est.z,
            est.P,
            est.active,
            us[0],
            us[1],
            ys[1],
            np.asarray(self.Q),
            np.asarray(self.R),
            self._hyp(),
            self.allowed,
            *self._bounds(),
            np.asarray(self.cap),
            np.asarray(self.state_scale),
        )
        z, P = np.asarray(out[0]).ravel(), np.asarray(out[1])
        if not (np.all(np.isfinite(z)) and np.all(np.isfinite(P))):
            raise EstimatorError(
                f"the filter produced NaN/inf at step {est.k + 1}; lower P0/Q, use method='ros2' or more substeps"
            )
        x, th = self.split(z)
        return Estimate(k=est.k + 1, z=z, P=P, x=x[0], theta=th[0], active=np.asarray(out[2]).ravel())

    def run(self, est0: Estimate, ys: Any, us: Any, *, t: Any = None) -> Trajectory:
        """Filter a whole record (``ys[0]`` is the sample of ``est0``; it is not used). NaN in ``ys``: a missing
        output sample (the step updates with the outputs present; its innovation is NaN).

        Returns
        -------
        Trajectory
            Estimates at every sample; raises :class:`~obsnl.errors.EstimatorError` at the first NaN.
        """
        ys, us = _record(ys, us, ny=self.model.ny, nu=self.model.nu)
        tic = time.perf_counter()
        out = self._evaluate([est0], [(ys, us)], [self])
        return self._trajectory(est0, out, len(ys), t, time.perf_counter() - tic)

    def _runs(self, T: int, n: int) -> ca.Function:
        """``n`` runs over ``T`` samples in one Function: the step looped over the record (``mapaccum``), each
        run's options given once (not per step), the runs side by side (casadi ``map``)."""
        key = ("runs", self._key(), T, n)
        if key not in self.cache:
            step = self._compiled()
            acc = step.mapaccum("run", T - 1, 3, {})
            ins = [
                ca.MX.sym(f"i{j}", *(step.size_in(j) if j not in (3, 4, 5) else acc.size_in(j)))
                for j in range(step.n_in())
            ]
            one = ca.Function("one_run", ins, acc.call(ins))
            self.cache[key] = one if n == 1 else one.map(n, "serial")
        return self._function(key)

    def _evaluate(
        self, est0s: Sequence[Estimate], data: Sequence[tuple[np.ndarray, np.ndarray]], filters: Sequence[UKF]
    ) -> list[np.ndarray]:
        """The raw outputs of the runs (checked records of one length), runs side by side in each output."""
        cols = lambda rows: np.hstack(rows)  # noqa: E731 - runs side by side, as casadi's map wants them
        args = [
            cols([e.z[:, None] for e in est0s]),
            cols([e.P for e in est0s]),
            cols([e.active[:, None] for e in est0s]),
            cols([u[:-1].T for _, u in data]),
            cols([u[1:].T for _, u in data]),
            cols([y[1:].T for y, _ in data]),
            cols([np.asarray(f.Q) for f in filters]),
            cols([np.asarray(f.R) for f in filters]),
            cols([f._hyp()[:, None] for f in filters]),
            cols([f.allowed[:, None] for f in filters]),
            cols([f._bounds()[0][:, None] for f in filters]),
            cols([f._bounds()[1][:, None] for f in filters]),
            cols([np.asarray(f.cap)[:, None] for f in filters]),
            cols([np.asarray(f.state_scale)[:, None] for f in filters]),
        ]
        return call(self._runs(len(data[0][0]), len(data)), args)

    def run_batch(
        self, est0s: Sequence[Estimate], ys: Sequence[Any], us: Sequence[Any], *, filters: Sequence[UKF] | None = None
    ) -> list[Trajectory | EstimatorError]:
        """Many runs over records of one length in one compiled call (casadi ``map`` over the runs).

        Run ``i`` starts at ``est0s[i]`` on ``ys[i]``, ``us[i]`` with the options (Q, R, gate, fixed,
        bounds, cap, state_scale) of ``filters[i]`` (default: this filter); the filters must share this
        filter's compiled step (same model, coordinates, dt, method, substeps; only run-time options
        may differ). The numbers equal those of :meth:`run` one at a time.

        Returns
        -------
        list
            A :class:`Trajectory` per run, or the :class:`~obsnl.errors.EstimatorError` that
            :meth:`run` would have raised for that run.
        """
        filters = list(filters) if filters is not None else [self] * len(est0s)
        if not (len(filters) == len(est0s) == len(ys) == len(us)) or not est0s:
            raise EstimatorError("run_batch needs one start estimate, record and filter per run (and at least one run)")
        if any(f._key() != self._key() for f in filters):
            raise EstimatorError(
                "run_batch: every filter must share this filter's compiled step (same model, "
                "coordinates, dt, method and substeps)"
            )
        data = [_record(y, u, ny=self.model.ny, nu=self.model.nu) for y, u in zip(ys, us)]
        T, n = len(data[0][0]), len(data)
        if any(len(y) != T for y, _ in data):
            raise EstimatorError("run_batch needs records of one length")
        tic = time.perf_counter()
        out = self._evaluate(est0s, data, filters)
        seconds = (time.perf_counter() - tic) / n
        result: list[Trajectory | EstimatorError] = []
        for i in range(n):
            part = [np.hsplit(o, n)[i] if o.size else o for o in out]
            try:
                result.append(filters[i]._trajectory(est0s[i], part, T, None, seconds))
            except EstimatorError as exc:
                result.append(exc)
        return result

    def _trajectory(self, est0: Estimate, out: list[np.ndarray], T: int, t: Any, seconds: float) -> Trajectory:
        L = self.size
        Z = np.vstack([est0.z, np.asarray(out[0]).T])
        Ps = np.concatenate([est0.P[None], np.asarray(out[1]).T.reshape(T - 1, L, L).transpose(0, 2, 1)])
        bad = np.flatnonzero(~(np.all(np.isfinite(Z), axis=1) & np.all(np.isfinite(Ps), axis=(1, 2))))
        if bad.size:
            raise EstimatorError(
                f"the filter produced NaN/inf at step {bad[0]} of {T}; lower P0/Q, use method='ros2' or more substeps"
            )
        nan_row = lambda a: np.vstack([np.full((1, a.shape[0]), np.nan), a.T])  # noqa: E731
        ny = self.model.ny
        S = np.concatenate([np.full((1, ny, ny), np.nan), np.asarray(out[5]).T.reshape(T - 1, ny, ny)])
        signs = np.asarray(out[8]).T if len(self.model.switching) else np.zeros((T - 1, 0))
        X, TH = self.split(Z)
        return Trajectory(
            t=np.arange(T) * self.dt if t is None else np.asarray(t, float),
            z=Z,
            P=Ps,
            x=X,
            theta=TH,
            y_pred=nan_row(np.asarray(out[3])),
            innovations=nan_row(np.asarray(out[4])),
            S=S,
            signs=np.vstack([signs, np.full((1, signs.shape[1]), np.nan)]) if signs.size else signs,
            active=np.vstack([est0.active, np.asarray(out[2]).T]),
            interventions=np.vstack([np.zeros((1, len(INTERVENTIONS))), np.asarray(out[6]).T]).astype(int),
            implicit=np.concatenate([[0], np.asarray(out[7]).ravel()]).astype(int),
            refined=np.concatenate([[0], np.asarray(out[9]).ravel()]).astype(int),
            seconds=seconds,
            names=self.names,
            parameters=self.model.parameters,
            states=self.model.states,
        )
