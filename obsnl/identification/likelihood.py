"""Maximum likelihood after the filter: the output-error fit of the parameters and the initial state.

The filter's passes are the initializer; this module finds the maximum of the likelihood of the
measured outputs given the measured inputs.

Formulation (output error, single shooting). With Gaussian white output noise of standard deviation
``sigma_c`` per channel, the negative log-likelihood is, up to a constant, half of

.. math:: \\chi^2(z) = \\sum_{k, c} \\big((\\hat y_c(t_k; z) - y_c(t_k)) / \\sigma_c\\big)^2,

``z = (phi, s)``: the parameters in the filter's coordinates ``phi = log|theta|`` and the initial state
``x0 = x0_ref + scale * s`` (records start in motion, so ``x0`` is estimated too). ``y_hat`` is the model
simulated from ``x0`` under the measured input by the same discrete step as everywhere in obsnl
(:meth:`obsnl.estimation.numeric.NumericModel.step`: RK4 substeps, a substep in which a switching function
across which the field jumps changes sign redone finer, ROS2 where stiff). The derivatives of the
residuals are exact derivatives of that discrete map (casadi's forward mode through the whole record;
with ``setup.jit``, forward sensitivities compiled to C, :func:`obsnl.estimation.simulate.residuals`), not
finite differences. Why output error and not the filter's innovations: the filter's process noise is
a tuning device, not a property of the structure, and the output-error likelihood is the one that the
profile-likelihood intervals (:mod:`obsnl.identification.profile`) and the Fisher information need; single
shooting suffices because the refinement starts at the filter's estimate (near the optimum) and the
structures are damped (their sensitivities do not grow along the record).

Solver: Levenberg-Marquardt with Marquardt's diagonal scaling on the Gauss-Newton Hessian ``J'J``,
each step accepted only if it lowers ``chi2`` (so a step across a branch switch that the linear model
did not foresee is rejected and the damping raised). Non-smoothness: inside a branch the discrete map is
smooth; where the vector field is continuous across a switching surface (Bouc-Wen's ``sign(v z)``) the
map stays once differentiable and Gauss-Newton converges as usual; where the field jumps (Coulomb
friction, the healing switch of the seed model), the crossing time moves with the parameters. The fit's
step therefore splits the substep that holds such a crossing at the located crossing
(:func:`obsnl.estimation.crossing.located_substep`, :data:`LOCATE`): the map is continuous there and ``J``
carries the crossing time's motion (the saltation term). Without it, ``J`` was the derivative along the
branches the RK4 stages happened to sample, and on a friction oscillator half of the fits ended with a
gradient inconsistent with the objective ("not converged"). A sliding mode (the field pushing back on
both sides: a mass that sticks) is followed as Filippov's solution on the surface until the mass breaks
away (:mod:`obsnl.estimation.crossing`); its entry is a located crossing and its exit a kink of a continuous
field, so the map stays continuous there too. Where the number of stick phases changes with the parameters
(a grazing reversal) the objective keeps a kink; the acceptance test keeps the iteration monotone there.

Prediction error (``Setup.objective == "prediction"``, ``--objective prediction``). Output error assumes that
measurement noise is the only disturbance: a plant that drifts under unmeasured forces (a slowly varying load, a
temperature drift, the unmodelled friction of a real drive) or runs in closed loop leaves a residual that is not
noise, and its output-error estimate is biased with intervals that miss. The innovations form of the
prediction-error method (L. Ljung, System Identification: Theory for the User, 2nd ed., 1999, sections 4.3 and
7.2) fits a predictor instead: before each step the state is corrected by a constant gain times the sample's
innovation, ``x <- x + K (y_k - h(x))``, and the residuals are the one-step prediction errors. The gain ``K``
(``nx * ny`` coordinates ``kappa`` appended to ``z``, dimensionless in the states' and outputs' scales,
:meth:`Objective.gain`) is fitted with the parameters, so the same Gauss-Newton machinery, Fisher information and
profiles apply, the gain integrated out as a nuisance. For a linear plant with white process and measurement noise
the best such gain is the steady-state Kalman gain; for a nonlinear one the predictor is an observer with a
constant gain. ``K = 0`` is the output error. A missing output sample corrects nothing.

Missing output samples (NaN in the data: an output sampled more slowly than the inputs, or with gaps) are not
measured: their residuals and rows of ``J`` are 0 (weight zero), and they count in no ``N`` below. The model is
still simulated through them, under the complete input.

Noise levels: the fit starts with the given or estimated noise per channel, then re-weights once with
the noise of the fit's residuals, ``sigma_c^2 = RSS_c / (N_c - h_c)`` (``N_c`` its samples measured; the
concentrated likelihood of unknown channel variances, over the residual degrees of freedom: ``h_c`` is the fitted coordinates' share of channel
``c``, :func:`obsnl.identification.refine.residual_dof`; the maximum-likelihood ``RSS_c / N`` is low by them
and made every std too small by ``sqrt(N / (N - h_c))``), floored at :data:`NOISE_FLOOR` of the channel's standard deviation (below it the residual is
the integrator's error, not noise), and refits. The Fisher information ``J'J`` at the optimum, with those
weights, gives the standard deviations of the output noise; noise on the measured inputs adds
``C A' S A C`` (:meth:`Objective.input_covariance`: the fit runs on the measured input, so its minimiser
moves with that input's noise; first order, the errors-in-variables sandwich of an output-error fit).

Convergence (:attr:`Refinement.converged`) is claimed only when the first-order condition holds
(Newton decrement ``g' H^+ g`` below ``DECREMENT``: the remaining Gauss-Newton step moves no parameter by
more than ``sqrt(DECREMENT)`` of its std), the last accepted step moved no parameter by more than
``STEP_LIMIT`` of its std, and no parameter sits on the edge of its valid region.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Literal, overload

import casadi as ca
import numpy as np

from obsnl.errors import EstimatorError
from obsnl.estimation.simulate import call, residual_graph, residuals
from obsnl.identification.setup import Data, Setup

__all__ = [
    "Objective",
    "Fit",
    "objective",
    "levenberg_marquardt",
    "covariance",
    "DECREMENT",
    "STEP_LIMIT",
    "NOISE_FLOOR",
]

#: First-order condition: the Newton decrement ``g' H^+ g`` (the chi2 decrease a full Gauss-Newton step
#: would bring) at the estimate is below this; by Cauchy-Schwarz the step then moves no coordinate by
#: more than ``sqrt(DECREMENT)`` of its standard deviation.
DECREMENT = 1e-2
#: The iteration itself goes on until the decrement is below this (or no step lowers chi2): Gauss-Newton
#: converges fast near the optimum, so the estimate is then the optimum to about 3e-5 of a std.
STOP = 1e-9
#: The last accepted step moved no parameter by more than this fraction of its standard deviation.
STEP_LIMIT = 0.1
#: A damped step that fails to lower chi2 when a full Gauss-Newton step could gain at most this much ends the
#: iteration: the objective's own roughness (switches of a discontinuous field inside a step) is of that size.
ROUGH = 0.1
#: Floor of the re-estimated noise std, relative to each output's standard deviation (its variation, not its offset): a smaller residual is the error of the
#: integrator (RK4 substeps against the true flow), not noise, and a noise level below it would give intervals
#: narrower than the model's own numerical precision (on noise-free data they missed the truth).
NOISE_FLOOR = 1e-5
#: The fit's step splits a substep at the located crossing of a jump of the field (the filters' step does not).
LOCATE = True
#: Relative eigenvalue below which a direction of ``J'J`` counts as uninformed (a flat likelihood).
NULL_TOL = 1e-10


@dataclass(frozen=True, eq=False)
class Objective:
    """The whitened output-error residuals of one record and their exact Jacobian.

    ``evaluate(z) -> (r, J)``: ``r`` of length ``T * ny`` (sample-major), ``J`` ``(T * ny, nz)``; ``z`` is
    ``phi`` (``np`` parameter coordinates) followed by the scaled initial state ``s`` (``nx``), then, for the
    prediction-error objective (``predictor``), the predictor's gains ``kappa`` (``nx * ny``, :meth:`gain`).
    ``sigma``: the noise std per output used as weights (:meth:`reweighted` changes them); ``yscale``: each
    output's scale, the unit of the gains' innovations.
    """

    setup: Setup
    data: Data
    substeps: int
    scale: np.ndarray
    sigma: np.ndarray
    function: ca.Function = field(repr=False)
    predictor: bool = False
    yscale: np.ndarray | None = field(default=None, repr=False)

    @property
    def n_parameters(self) -> int:
        return self.setup.model.np

    def theta(self, z: np.ndarray) -> np.ndarray:
        """The model parameters at ``z``."""
        return self.setup.coordinate_map.to_theta(np.asarray(z)[: self.n_parameters])

    @property
    def n_gains(self) -> int:
        """The predictor's gains in ``z`` (``nx * ny`` for the prediction-error objective, else 0)."""
        m = self.setup.model
        return m.nx * m.ny if self.predictor else 0

    def x0(self, z: np.ndarray) -> np.ndarray:
        """The initial state at ``z``."""
        n = self.n_parameters
        return self.setup.x0 + self.scale * np.asarray(z)[n : n + self.setup.model.nx]

    def gain(self, z: np.ndarray) -> np.ndarray:
        """The predictor's gain ``K`` ``(nx, ny)`` at ``z`` in the model's units (state per output): the correction
        ``x <- x + K (y - h(x))`` before each step; zeros for the output-error objective."""
        m = self.setup.model
        if not self.predictor:
            return np.zeros((m.nx, m.ny))
        kappa = np.asarray(z, float)[m.np + m.nx :].reshape(m.ny, m.nx).T  # column-major, as the graph's reshape
        return self.scale[:, None] * kappa / np.asarray(self.yscale, float)[None, :]

    @property
    def present(self) -> np.ndarray:
        """``(T, ny)``: True where the output sample was measured, False at a gap (NaN in the data)."""
        return ~np.isnan(np.asarray(self.data.y, float).reshape(len(self.data.u), -1))

    @property
    def measured(self) -> np.ndarray:
        """The number of samples measured per output: the ``N`` of its noise estimate and degrees of freedom."""
        return np.sum(self.present, axis=0)

    def _outputs(self) -> np.ndarray:
        """The measured outputs ``(T, ny)`` with a missing sample's NaN replaced by 0 (its residual gets no weight)."""
        y = np.asarray(self.data.y, float).reshape(len(self.data.u), -1)
        return np.where(np.isnan(y), 0.0, y)

    @overload
    def evaluate(self, z: np.ndarray, *, jacobian: Literal[True] = True) -> tuple[np.ndarray, np.ndarray]: ...
    @overload
    def evaluate(self, z: np.ndarray, *, jacobian: Literal[False]) -> tuple[np.ndarray, None]: ...
    @overload
    def evaluate(self, z: np.ndarray, *, jacobian: bool) -> tuple[np.ndarray, np.ndarray | None]: ...

    def evaluate(self, z: np.ndarray, *, jacobian: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """Residuals (and their Jacobian, unless ``jacobian`` is False: then None) at ``z``; non-finite entries where
        the simulation overflowed. The residual of a missing output sample and its row of the Jacobian are 0 (weight
        zero: no NaN reaches the fit)."""
        r_all, J_all = call(self.function, self._arguments(z))
        r, J = np.asarray(r_all).ravel(), (np.asarray(J_all) if jacobian else None)
        missing = ~self.present.ravel()  # sample-major, as r
        if missing.any():
            r[missing] = 0.0
            if J is not None:
                J[missing] = 0.0
        return r, J

    def _arguments(self, z: np.ndarray) -> list[np.ndarray]:
        """The residual function's arguments at ``z`` (:func:`obsnl.estimation.simulate.residuals`)."""
        u = np.asarray(self.data.u, float).reshape(len(self.data.u), -1)
        args = [np.asarray(z, float), u.T, self._outputs().T, 1.0 / self.sigma, self.setup.x0, self.scale]
        if self.predictor:
            args += [self.present.T.astype(float), np.asarray(self.yscale, float)]
        return args

    def input_effect(self, z: np.ndarray, J: np.ndarray) -> np.ndarray:
        """``A = G' J``, ``(T * nu, nz)``: ``G = dr/du`` the exact sensitivity of the whitened residuals to every
        input sample (``vec(u)`` sample by sample: input ``j`` of sample ``k`` at ``k * nu + j``), through the
        whole record in reverse mode, one sweep per column of ``J``."""
        key = self._key() + ("input",)
        if key not in _BUILT:
            m = self.setup.model
            *args, R = residual_graph(
                m,
                self.setup.coordinate_map.forward,
                self.setup.record.dt,
                len(self.data.u),
                substeps=self.substeps,
                refine=self.setup.refine,
                locate=LOCATE,
                predictor=self.predictor,
            )
            V = ca.MX.sym("v", R.shape[0], args[0].shape[0])
            _BUILT[key] = ca.Function("input_effect", [*args, V], [ca.jtimes(R, ca.vec(args[1]), V, True)])
            _trim()
        # J's rows of missing samples are 0
        return np.asarray(_BUILT[key](*self._arguments(z), np.asarray(J, float)))

    def input_covariance(self, z: np.ndarray, J: np.ndarray, C: np.ndarray, sigma_u: np.ndarray) -> np.ndarray:
        """The covariance of the estimate ``z`` added by white noise of std ``sigma_u`` on the measured inputs.

        The fit simulates the model under the measured input ``u + e``; to first order its minimiser moves by
        ``dz = -C J' G e`` (:meth:`input_effect`: ``A = G' J``), ``C`` the inverse Fisher information
        (``covariance(J)``). So ``cov(dz) = C A' S A C``, ``S`` the input noise variance per sample: zero when
        ``sigma_u`` is zero; added to ``C`` it is the estimate's covariance under noise on both the outputs and
        the inputs (the errors-in-variables sandwich of an output-error fit). A flat coordinate (``inf`` in
        ``C``) is left out: its row and column are 0 here and stay ``inf`` in ``C``.
        """
        sigma_u = np.asarray(sigma_u, float)
        ok = np.isfinite(np.diag(C))
        if not np.any(sigma_u > 0) or not ok.any():
            return np.zeros_like(C)
        A = self.input_effect(z, J)
        nu = len(sigma_u)
        if A.shape[0] != len(self.data.u) * nu:  # a driven model: a sample's noise moves its block (held)
            A = A.reshape(len(self.data.u), -1, nu, A.shape[1]).sum(axis=1).reshape(-1, A.shape[1])
        CA = np.zeros((len(C), A.shape[0]))
        CA[ok] = C[np.ix_(ok, ok)] @ A[:, ok].T
        S = np.tile(sigma_u**2, len(self.data.u))
        out = np.zeros_like(C)
        out[np.ix_(ok, ok)] = ((CA * S) @ CA.T)[np.ix_(ok, ok)]
        return out

    def _key(self) -> tuple:
        return _key(self.setup, len(self.data.u), self.substeps, self.predictor)

    def reweighted(self, sigma: np.ndarray) -> Objective:
        """The same objective with other noise levels (the function takes them as an argument)."""
        return dataclasses.replace(self, sigma=np.asarray(sigma, float))


_BUILT: dict[tuple, ca.Function] = {}


def objective(
    setup: Setup,
    data: Data,
    *,
    theta: np.ndarray,
    substeps: int | None = None,
    sigma: np.ndarray | None = None,
    scale: np.ndarray | None = None,
) -> Objective:
    """The output-error objective of ``setup`` on ``data``.

    Parameters
    ----------
    setup : Setup
        The experiment (model, record step, coordinates, noise levels, the integrator's ``refine``).
    data : Data
        Measured inputs and outputs.
    theta : numpy.ndarray
        Parameter values at which the states' typical magnitudes (the scale of ``x0``) are taken.
    substeps : int or None
        RK4 substeps per sample (default: ``setup.fit_substeps``, else the filter's).
    sigma : numpy.ndarray or None
        Noise std per output (default: the setup's levels on these data).
    scale : numpy.ndarray or None
        The scale of ``x0`` per state (default: the RMS of each state simulated at ``theta``, at least
        1 % of the largest); a worker rebuilding another process's objective passes that one's.

    Returns
    -------
    Objective
    """
    from obsnl.estimation.simulate import simulate

    m = setup.model
    n = int(substeps or setup.fit_substeps or setup.substeps)
    T = len(data.u)
    if scale is None:
        sim = simulate(m, theta=theta, x0=setup.x0, u=data.u, dt=setup.record.dt, substeps=n, refine=setup.refine)
        typical = np.sqrt(np.mean(sim.x**2, axis=0))
        scale = np.maximum(typical, 1e-2 * max(float(typical.max()), 1e-300))
    scale = np.asarray(scale, float)
    predictor = setup.objective == "prediction"
    key = _key(setup, T, n, predictor)
    if key not in _BUILT:
        _BUILT[key] = residuals(
            m,
            setup.coordinate_map.forward,
            setup.record.dt,
            T,
            substeps=n,
            refine=setup.refine,
            locate=LOCATE,
            jit=setup.jit,
            predictor=predictor,
        )
        _trim()
    if sigma is None:
        sigma = setup.noise_std(data)[1]
    y = np.asarray(data.y, float).reshape(T, -1)
    spread = np.nanstd(y, axis=0) if np.isfinite(y).any() else np.zeros(m.ny)
    yscale = np.maximum(np.nan_to_num(spread), 1e-300)
    return Objective(
        setup,
        data,
        n,
        scale,
        np.maximum(np.asarray(sigma, float), 1e-300),
        _BUILT[key],
        predictor=predictor,
        yscale=yscale,
    )


def _key(setup: Setup, T: int, n: int, predictor: bool = False) -> tuple:
    return (
        bool(predictor),
        id(setup.model),
        id(setup.coordinates),
        float(setup.record.dt),
        T,
        n,
        int(setup.refine),
        bool(LOCATE),
        bool(setup.jit),
    )


def _trim() -> None:
    while len(_BUILT) > 16:
        _BUILT.pop(next(iter(_BUILT)))


def covariance(J: np.ndarray, *, mark_flat: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """The inverse Fisher information ``(J'J)^+`` and a mask of the coordinates along a flat direction.

    The eigen-analysis is made on the correlation form ``D^-1/2 J'J D^-1/2`` (``D`` its diagonal), so
    that coordinates of very different scales are judged alike: a coordinate whose column of ``J`` is 0,
    or that has a weight above 1e-3 in an eigenvector whose eigenvalue is below ``NULL_TOL``, lies along
    a flat direction of the likelihood; its variance is set to ``inf`` (``mark_flat``; otherwise the whole
    matrix is the pseudo-inverse, positive semi-definite: the metric of the Newton decrement). The rest is
    the pseudo-inverse.

    Parameters
    ----------
    J : numpy.ndarray
        The Jacobian of the whitened residuals, ``(N, n)``.
    mark_flat : bool
        Set the variance of a coordinate along a flat direction to ``inf`` (default).

    Examples
    --------
    >>> C, flat = covariance(np.array([[1.0, 1.0, 0.0], [2.0, 2.0, 0.0], [0.0, 0.0, 2.0]]))
    >>> flat.tolist(), float(C[2, 2])
    ([True, True, False], 0.25)
    """
    H = J.T @ J
    d = np.sqrt(np.diag(H))
    live = d > 0
    dl = np.where(live, d, 1.0)
    w, V = np.linalg.eigh(H / np.outer(dl, dl))
    keep = w > NULL_TOL
    Cs = (V[:, keep] / w[keep]) @ V[:, keep].T
    C = Cs / np.outer(dl, dl)
    flat = ~live | (np.any(np.abs(V[:, ~keep]) > 1e-3, axis=1) if (~keep).any() else np.zeros(len(w), bool))
    if not mark_flat:
        return C, flat
    C[~live, :] = 0.0
    C[:, ~live] = 0.0
    C[np.diag_indices_from(C)] = np.where(flat, np.inf, np.diag(C))
    return C, flat


@dataclass(frozen=True)
class Fit:
    """One Levenberg-Marquardt run: the point, its chi2, and how it ended."""

    z: np.ndarray
    chi2: float
    iterations: int
    evaluations: int
    decrement: float
    last_step: float
    at_bound: tuple[int, ...]
    stalled: bool
    J: np.ndarray = field(repr=False)
    r: np.ndarray = field(repr=False)


def levenberg_marquardt(
    fun: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    z0: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    *,
    free: Sequence[bool] | np.ndarray | None = None,
    max_iter: int = 60,
    max_evals: int = 400,
    stop: float = STOP,
) -> Fit:
    """Minimise ``|r(z)|^2`` from ``z0`` within ``[lower, upper]``, moving only the ``free`` coordinates.

    Marquardt's damping ``(J'J + lam diag(J'J)) dz = -J'r``; a step is accepted only when it lowers the
    sum of squares; a coordinate on a bound whose gradient pushes it outwards is held there for the
    iteration (the first-order conditions of the bounded problem). Stops when the Newton decrement is
    below ``STOP`` and the last accepted step moved every free coordinate by at most ``STEP_LIMIT`` of its
    std, when three ever shorter steps fail to lower the sum although a full step could gain ``ROUGH``
    at most (``stalled``), or after ``max_iter`` iterations or ``max_evals`` evaluations.

    Parameters
    ----------
    fun : callable
        ``z -> (r, J)``.
    z0, lower, upper : numpy.ndarray
        Start and bounds.
    free : sequence of bool, numpy.ndarray or None
        Coordinates to move (default: all).
    max_iter : int
        Iterations at most.
    max_evals : int
        Evaluations of ``fun`` at most.
    stop : float
        The Newton decrement below which the iteration ends (default ``STOP``; a profile point needs
        less: its chi2 is then within ``stop`` of its minimum).

    Returns
    -------
    Fit

    Raises
    ------
    EstimatorError
        The residuals are not finite at ``z0``.

    References
    ----------
    .. [1] D. W. Marquardt, "An algorithm for least-squares estimation of nonlinear parameters", J. SIAM 11(2),
       431-441, 1963. doi:10.1137/0111030

    Examples
    --------
    >>> A = np.array([[1.0, 0.0], [1.0, 1.0], [1.0, 2.0]]); b = np.array([1.0, 2.0, 2.0])
    >>> fit = levenberg_marquardt(lambda z: (A @ z - b, A), np.zeros(2), np.full(2, -9.0), np.full(2, 9.0))
    >>> bool(np.allclose(fit.z, np.linalg.lstsq(A, b, rcond=None)[0]))
    True
    """
    mask = np.ones(len(z0), bool) if free is None else np.asarray(free, bool)
    z = np.clip(np.asarray(z0, float), lower, upper)
    r, J = fun(z)
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(J))):
        raise EstimatorError(
            "the model cannot be simulated at the start of the likelihood fit (non-finite output or derivatives)"
        )
    cost, lam, evals, last, it, stalled = float(r @ r), 1e-3, 1, math.inf, 0, False
    decrement = math.inf
    for it in range(1, max_iter + 1):
        gz = J.T @ r
        # active set: a coordinate on a bound whose gradient pushes it out stays there this iteration (KKT)
        blocked = mask & (((z <= lower) & (gz > 0)) | ((z >= upper) & (gz < 0)))
        move = mask & ~blocked
        Jf = J[:, move]
        g, H = gz[move], Jf.T @ Jf
        P, flat = covariance(Jf, mark_flat=False)  # the pseudo-inverse, positive semi-definite
        std = np.where(flat, np.inf, np.sqrt(np.clip(np.diag(P), 0.0, None)))
        decrement = float(g @ P @ g)  # on the informed directions, >= 0
        if decrement <= stop and last <= STEP_LIMIT:
            it -= 1
            break
        d = np.maximum(np.diag(H), 1e-12 * max(float(np.diag(H).max(initial=0.0)), 1e-300))
        fails = 0
        while True:
            try:
                dz = -np.linalg.solve(H + lam * np.diag(d), g)
            except np.linalg.LinAlgError:
                dz = -np.linalg.lstsq(H + lam * np.diag(d), g, rcond=None)[0]
            zn = z.copy()
            zn[move] = np.clip(z[move] + dz, lower[move], upper[move])
            rn, Jn = fun(zn)
            evals += 1
            ok = np.all(np.isfinite(rn)) and np.all(np.isfinite(Jn))
            cn = float(rn @ rn) if ok else math.inf
            if cn < cost:
                moved = zn[move] - z[move]
                pred = -(2 * g @ moved + moved @ H @ moved)
                rho = (cost - cn) / pred if pred > 0 else 0.0
                lam = max(lam * max(1 / 3, 1 - (2 * rho - 1) ** 3), 1e-12)
                with np.errstate(divide="ignore", invalid="ignore"):
                    last = float(np.max(np.where(std > 0, np.abs(moved) / std, 0.0), initial=0.0))
                z, r, J, cost = zn, rn, Jn, cn
                break
            lam, fails = lam * 4.0, fails + 1
            if lam > 1e10 or (decrement <= ROUGH and fails >= 3) or evals >= max_evals:  # bottom, up to roughness
                stalled = True
                break
        if stalled or evals >= max_evals:
            # no step lowers chi2: at the bottom to rounding (then the decrement is at rounding level), or stuck
            last = 0.0
            break
    at_bound = tuple(int(i) for i in np.flatnonzero(mask & ((z <= lower) | (z >= upper))))
    return Fit(
        z=z,
        chi2=cost,
        iterations=it,
        evaluations=evals,
        decrement=decrement,
        last_step=last,
        at_bound=at_bound,
        stalled=stalled,
        J=J,
        r=r,
    )
