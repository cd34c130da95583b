"""Profile-likelihood intervals of the parameters at the maximum-likelihood estimate.

For a parameter ``theta_i`` the profile is ``PL(phi_i) = min chi2`` over every other coordinate (the
other parameters and the initial state) with ``phi_i = log|theta_i|`` fixed; ``Delta(phi_i) = PL - chi2_min``.
The 95 % interval is where ``Delta`` stays below the 0.95 quantile of chi2 with one degree of freedom,
``THRESHOLD = 3.8415`` (Raue, Kreutz, Maiwald, Bachmann, Schilling, Klingmüller and Timmer, "Structural and
practical identifiability analysis of partially observed dynamical models by exploiting the profile
likelihood", Bioinformatics 25:1923-1929, 2009, doi:10.1093/bioinformatics/btp358). The interval is
invariant under a monotone change of coordinates, so it is the same whether ``theta`` or ``log|theta|``
is profiled.

Search, per side: the first trial is the quadratic prediction ``sqrt(THRESHOLD)`` standard deviations from
the estimate (exact when the model is linear in its parameters); then regula falsi on ``sqrt(Delta)``
(linear in the distance for a quadratic profile) between the last point below and the first above the
threshold, until ``|Delta - THRESHOLD| <= TOLERANCE``; below the threshold, trials grow by at most 3x.
Each profile point re-optimises the other coordinates with Levenberg-Marquardt from the linear
prediction ``z_hat + C[:, i] / C[i, i] * (phi_i - phi_hat_i)``, or takes that prediction as it is where its
Newton decrement is already below the points' stop (one evaluation instead of two; :func:`_point`).

Noise on the measured inputs (given or estimated with the outputs' noise): the output-error profile has the
curvature of the output noise alone, while the estimate also moves with the input's noise (its covariance
``Refinement.total_cov``); the interval then ends where ``Delta`` reaches ``THRESHOLD`` times the square of
``Refinement.widening`` (the ratio of the two std), which to second order is the interval of the estimate's
whole variance, the profile's own asymmetry kept. With exact inputs the widening is 1.

Shapes: ``closed`` (both ends found); ``open-low``/``open-high``: ``Delta`` stays below the threshold on that
side as far as the profile was followed; ``flat``: open on both sides with ``Delta`` never above ``FLAT``
anywhere (cross-checked with the structural analysis by the caller). How far a side was followed, and why it
stopped, is kept per side (:attr:`Profile.sides`): the interval's end (``end``), the full ``SEARCH`` (a factor
10 of the estimate: the data do not bound the parameter there, a practical non-identifiability), the edge of
the valid region (``bound``: the search stopped there, not the data; a guess far off), a bound the model file
declares (``declared``: the data do not bound it inside what the model allows), the points' budget
(``points``), or a point that fits better than the estimate (``better``). :func:`judge` says which.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from obsnl._text import block, number, one_line
from obsnl.errors import EstimatorError
from obsnl.executor import Executor, built_once
from obsnl.identification.likelihood import covariance, levenberg_marquardt
from obsnl.identification.refine import Refinement, declared_bounds

__all__ = [
    "Profile",
    "profile",
    "profiles",
    "judge",
    "THRESHOLD",
    "TOLERANCE",
    "SEARCH",
    "FLAT",
    "BAND",
    "MAX_SECONDS",
    "PARALLEL_MIN",
]

#: chi2(1) 0.95 quantile (scipy.stats.chi2.ppf(0.95, 1)).
THRESHOLD = 3.841458820694124
#: How close to the threshold an interval end is found (in chi2 units: about 0.01 std of the end).
TOLERANCE = 0.02
#: The farthest a profile is followed from the estimate, in ``log|theta|``: a factor 10.
SEARCH = math.log(10.0)
#: A profile whose rise stays below this everywhere it was followed is flat.
FLAT = 0.1
#: Time budget of the profiles of one estimate (s): beyond it the remaining parameters get no interval.
MAX_SECONDS = 900.0
#: Profile points per side at most (each a re-optimisation of every other coordinate).
POINTS = 8
#: Fewer profiles than this run in this process even on an executor with several workers: starting a worker
#: and compiling its objective costs a few seconds, about what two or three small profiles take.
PARALLEL_MIN = 4


@dataclass(frozen=True)
class Profile:
    """The profile of one parameter: its points, the 95 % interval and its shape.

    ``points``: ``(theta_i, Delta)`` pairs, sorted by ``theta_i`` (the estimate included with 0);
    ``interval``: ``(low, high)`` in the parameter's own units, ``None`` on an open side; ``shape``: one of
    ``closed``, ``open-low``, ``open-high``, ``open`` (both sides open, rising somewhere), ``flat``, or
    ``not-optimal`` (a profile point fitted better than the estimate: no interval is claimed), or
    ``not-computed`` (the time budget of :func:`profiles` ran out first): those two claim no interval, both ends
    are ``None``;
    ``better``: a profile point whose chi2 fell below the optimum (the estimate was not the global
    optimum along this parameter), else ``None``, and ``better_z`` the coordinates of that point (every
    parameter and the initial state: where a refit starts); ``threshold``: the rise of ``Delta`` at which the
    interval ends (``THRESHOLD``, widened by the measured inputs' noise: module docstring); ``sides``: why the
    search stopped on the low and the high side of the parameter (module docstring: ``end``, ``search``,
    ``bound``, ``points``, ``better``; empty where not searched).
    """

    name: str
    estimate: float
    interval: tuple[float | None, float | None]
    shape: str
    points: tuple[tuple[float, float], ...] = field(repr=False)
    evaluations: int = 0
    better: float | None = None
    threshold: float = THRESHOLD
    sides: tuple[str, str] = ("", "")
    better_z: tuple[float, ...] | None = field(default=None, repr=False)

    def __repr__(self) -> str:
        lo, hi = ("open" if v is None else number(v) for v in self.interval)
        return one_line(
            "Profile",
            f"name={self.name!r}",
            f"estimate={number(self.estimate)}",
            f"interval=[{lo}, {hi}]",
            f"shape={self.shape!r}",
        )

    def summary(self) -> str:
        """One or two lines of plain text: the estimate, its 95 % interval and the profile's shape."""
        lo, hi = ("open" if v is None else number(v) for v in self.interval)
        return block(
            f"{self.name} = {number(self.estimate)}, 95 % profile-likelihood interval [{lo}, {hi}] "
            f"({self.shape}; {len(self.points)} points, {self.evaluations} evaluations)",
            f"a profile point fits better (chi2 {number(self.better)}): the estimate is not the optimum"
            if self.better is not None
            else "",
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "estimate": self.estimate,
            "interval": list(self.interval),
            "shape": self.shape,
            "points": [list(p) for p in self.points],
            "evaluations": self.evaluations,
            "better": self.better,
            "threshold": self.threshold,
            "stopped": {"low": self.sides[0], "high": self.sides[1]},
        }


def _point(ref: Refinement, i: int, phi_i: float, start: np.ndarray, stop: float) -> tuple[float, np.ndarray, int]:
    """chi2 minimised over the free coordinates other than ``i`` with ``z_i = phi_i``.

    The start (the linear prediction along the covariance) is evaluated first. Where its Newton decrement, the
    decrease of chi2 that a Gauss-Newton step from it predicts, is already at most ``stop``, the start is the
    point: its chi2 is within about ``stop`` of the minimum, the criterion Levenberg-Marquardt stops on (whose
    other condition, a last step of at most ``STEP_LIMIT`` std, holds too: a step whose decrement is ``stop`` moves
    no coordinate by more than ``sqrt(stop)`` std). One evaluation then, instead of the two of an accepted step
    and its check. Otherwise Levenberg-Marquardt goes on from the start, that evaluation reused.
    """
    z0 = start.copy()
    z0[i] = phi_i
    free = np.ones(len(z0), bool)
    free[i] = False
    m = ref.objective.setup.model
    for h in ref.held:
        free[m.parameters.index(h)] = False
    for s in ref.known:  # a known initial state is never fitted
        free[m.np + m.states.index(s)] = False
    z0 = np.clip(z0, ref.lower, ref.upper)
    first = ref.objective.evaluate(z0)
    r, J = first
    if np.all(np.isfinite(r)) and np.all(np.isfinite(J)):
        g = J.T @ r
        # as levenberg_marquardt: a coordinate on a bound whose gradient pushes it outwards stays there
        blocked = ((z0 <= ref.lower) & (g > 0)) | ((z0 >= ref.upper) & (g < 0))
        move = free & ~blocked
        P, _ = covariance(J[:, move], mark_flat=False)
        if float(g[move] @ P @ g[move]) <= stop:
            return float(r @ r), z0, 1

    def evaluate(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return first if np.array_equal(z, z0) else ref.objective.evaluate(z)

    fit = levenberg_marquardt(evaluate, z0, ref.lower, ref.upper, free=free, max_iter=20, max_evals=30, stop=stop)
    return fit.chi2, fit.z, fit.evaluations


def profile(ref: Refinement, name: str, *, search: float = SEARCH, tolerance: float = TOLERANCE) -> Profile:
    """The profile likelihood of parameter ``name`` around the estimate of ``ref``.

    Parameters
    ----------
    ref : Refinement
        The maximum-likelihood estimate (:func:`obsnl.identification.refine.refine`).
    name : str
        The parameter (not held).
    search : float
        How far to follow the profile on each side, in ``log|theta|``.
    tolerance : float
        How close to ``THRESHOLD`` (chi2 units) an interval end must be.

    Returns
    -------
    Profile

    References
    ----------
    .. [1] A. Raue, C. Kreutz, T. Maiwald, J. Bachmann, M. Schilling, U. Klingmueller and J. Timmer, "Structural and
       practical identifiability analysis of partially observed dynamical models by exploiting the profile
       likelihood", Bioinformatics 25(15), 1923-1929, 2009. doi:10.1093/bioinformatics/btp358
    """
    m = ref.objective.setup.model
    i = m.parameters.index(name)
    z_hat, C = ref.fit.z, ref.cov
    chi2_min = ref.chi2
    level = THRESHOLD * ref.widening(i) ** 2  # noise on the measured inputs widens the interval (module docstring)
    sd = math.sqrt(C[i, i]) if math.isfinite(C[i, i]) and C[i, i] > 0 else math.inf
    slope = np.where(np.isfinite(C[:, i]), C[:, i], 0.0) / C[i, i] if math.isfinite(sd) else np.zeros(len(z_hat))
    slope[i] = 1.0
    lo_edge, hi_edge = ref.lower[i], ref.upper[i]
    declared = declared_bounds(ref.objective.setup)
    points = [(0.0, 0.0)]
    ends: list[float | None] = []
    stops: list[str] = []
    evals, better, better_z = 0, None, None
    peak = 0.0
    for side in (-1.0, 1.0):
        edge = (z_hat[i] - lo_edge) if side < 0 else (hi_edge - z_hat[i])
        limit = min(search, edge)
        inner, outer = (0.0, 0.0), None  # (distance, sqrt(Delta)) below / above the threshold
        d = min(math.sqrt(level) * sd, limit) if math.isfinite(sd) else min(0.05, limit)
        end = None
        stop = "points"  # the points' budget ran out below the threshold, unless another reason comes first
        start = z_hat.copy()
        for _ in range(POINTS):
            guess = z_hat + slope * side * d
            c2, z, n = _point(
                ref, i, z_hat[i] + side * d, np.where(np.isfinite(guess), guess, start), stop=min(1e-3, tolerance / 10)
            )
            evals += n
            delta = c2 - chi2_min
            if delta < -max(tolerance, FLAT) and (better is None or c2 < better):
                better, better_z, stop = c2, tuple(float(v) for v in z), "better"  # the estimate is not the optimum
                break
            delta = max(delta, 0.0)
            peak = max(peak, delta)
            points.append((side * d, delta))
            if abs(delta - level) <= tolerance:
                end, stop = side * d, "end"
                break
            if delta < level:
                inner, start = (d, math.sqrt(delta)), z
                if d >= limit - 1e-12:  # open on this side: followed to the full search, or stopped by the bound
                    declared_edge = (lo_edge if side < 0 else hi_edge) == declared[0 if side < 0 else 1][i]
                    stop = "search" if limit >= search - 1e-12 else "declared" if declared_edge else "bound"
                    break
                if outer is None:
                    grow = math.sqrt(level / delta) if delta > 1e-12 else 3.0
                    d = min(d * min(max(grow, 1.1), 3.0), limit)
                    continue
            else:
                outer = (d, math.sqrt(delta))
            (a, fa), (b, fb) = inner, outer
            d = a + (math.sqrt(level) - fa) * (b - a) / (fb - fa)
            d = min(max(d, a + 1e-3 * (b - a)), b - 1e-3 * (b - a))
        else:
            if outer is not None:  # the bracket is tight enough: take its interpolated end
                end, stop = side * d, "end"
        ends.append(end)
        stops.append(stop)
        if better is not None:
            break
    ends += [None] * (2 - len(ends))
    stops += [""] * (2 - len(stops))
    if better is not None:  # not the optimum: no interval is claimed on either side
        ends = [None, None]
    to_theta = lambda phi: float(ref.objective.theta(np.r_[z_hat[:i], phi, z_hat[i + 1 :]])[i])  # noqa: E731
    lo, hi = (None if e is None else to_theta(z_hat[i] + e) for e in ends)
    if ref.theta[i] < 0:  # theta = -exp(phi): the order flips
        lo, hi = hi, lo
        stops.reverse()
    shape = (
        "not-optimal"
        if better is not None
        else "closed"
        if lo is not None and hi is not None
        else "flat"
        if peak < FLAT
        else "open-low"
        if lo is None and hi is not None
        else "open-high"
        if hi is None and lo is not None
        else "open"
    )
    pts = tuple(sorted((to_theta(z_hat[i] + d), float(v)) for d, v in points))
    return Profile(
        name=name,
        estimate=float(ref.theta[i]),
        interval=(lo, hi),
        shape=shape,
        points=pts,
        evaluations=evals,
        better=better,
        threshold=level,
        sides=(stops[0], stops[1]),
        better_z=better_z,
    )


def profiles(
    ref: Refinement,
    names: tuple[str, ...] | None = None,
    *,
    progress: Any = None,
    max_seconds: float | None = MAX_SECONDS,
    executor: Executor | None = None,
) -> tuple[Profile, ...]:
    """:func:`profile` of every parameter that is not held (or of ``names``), within a time budget.

    A parameter whose profile was not started when ``max_seconds`` had passed gets no interval (shape
    ``not-computed``; :func:`judge` flags it with that reason): the work stays bounded on large models.
    The profiles are independent of each other: on an ``executor`` with several workers each worker
    rebuilds the objective once from plain data (the symbolic model, the record, the estimate and its
    covariance: never a compiled object) and profiles one parameter per task; every profile is the one
    this process would compute (the same start, the same iterations).

    Parameters
    ----------
    ref : Refinement
        The estimate.
    names : tuple of str or None
        The parameters to profile (default: every free one).
    progress : callable or None
        Called after each profile.
    max_seconds : float or None
        Time budget of all the profiles (None: none); on an executor, a profile not started by then
        (wall clock) is not computed.
    executor : Executor or None
        Where the profiles run (default: this process, one after the other). Fewer than
        ``PARALLEL_MIN`` profiles, or a compiled model that was not made by
        :func:`obsnl.estimation.codegen.to_casadi` (a worker cannot rebuild it), run in this process.

    Returns
    -------
    tuple of Profile

    Raises
    ------
    EstimatorError
        A profile point cannot be simulated.

    References
    ----------
    .. [1] A. Raue, C. Kreutz, T. Maiwald, J. Bachmann, M. Schilling, U. Klingmueller and J. Timmer, "Structural and
       practical identifiability analysis of partially observed dynamical models by exploiting the profile
       likelihood", Bioinformatics 25(15), 1923-1929, 2009. doi:10.1093/bioinformatics/btp358

    Examples
    --------
    >>> profiles.__name__
    'profiles'
    """
    names = names or tuple(p for p in ref.objective.setup.model.parameters if p not in ref.held)
    if (
        executor is not None
        and executor.kind != "serial"
        and len(names) >= PARALLEL_MIN
        and ref.objective.setup.model.source is not None
    ):
        deadline = None if max_seconds is None else time.time() + max_seconds
        spec = _spec(ref)
        done = (lambda i, _: progress()) if progress else None
        return tuple(
            executor.map(
                _profile_task,
                [(spec, p, deadline) for p in names],
                done=done,
                label=lambda task: f"the profile likelihood of {task[1]}",
            )
        )
    out = []
    t0 = time.perf_counter()
    for p in names:
        late = max_seconds is not None and time.perf_counter() - t0 > max_seconds
        out.append(_not_computed(ref, p) if late else _profile_or_say(ref, p))
        if progress:
            progress()
    return tuple(out)


def _not_computed(ref: Refinement, p: str) -> Profile:
    """The place-holder of a profile the time budget left out."""
    i = ref.objective.setup.model.parameters.index(p)
    return Profile(
        name=p,
        estimate=float(ref.theta[i]),
        interval=(None, None),
        shape="not-computed",
        points=((float(ref.theta[i]), 0.0),),
    )


def _profile_or_say(ref: Refinement, p: str) -> Profile:
    try:
        return profile(ref, p)
    except EstimatorError as exc:
        raise EstimatorError(f"the profile of {p} left the region where the model can be simulated: {exc}") from None


def _spec(ref: Refinement) -> dict[str, Any]:
    """What a worker needs to rebuild ``ref`` (plain data: the model's recipe, the record, the estimate)."""
    from obsnl.identification.replicates import recipe_of

    obj = ref.objective
    return {
        "recipe": recipe_of(obj.setup, "ukf", None),
        "u": np.asarray(obj.data.u),
        "y": np.asarray(obj.data.y),
        "substeps": obj.substeps,
        "scale": obj.scale,
        "sigma": obj.sigma,
        "theta": ref.theta,
        "x0": ref.x0,
        "std": ref.std,
        "cov": ref.cov,
        "chi2": ref.chi2,
        "z": ref.fit.z,
        "held": ref.held,
        "known": ref.known,
        "lower": ref.lower,
        "upper": ref.upper,
        "input_cov": ref.input_cov,
    }


def _rebuilt(spec: dict[str, Any]) -> Refinement:
    """The refinement of :func:`_spec`, its objective compiled in this process."""
    from obsnl.identification.likelihood import Fit, objective
    from obsnl.identification.replicates import compiled
    from obsnl.identification.setup import Data, Setup, coordinates

    recipe = spec["recipe"]
    num = compiled(recipe)
    setup = Setup(model=num, coordinates=coordinates(num, "log", reference=recipe.setup["guess"]), **recipe.setup)
    obj = objective(
        setup,
        Data(seed=None, u=spec["u"], y=spec["y"]),
        theta=spec["theta"],
        substeps=spec["substeps"],
        sigma=spec["sigma"],
        scale=spec["scale"],
    )
    fit = Fit(
        z=spec["z"],
        chi2=spec["chi2"],
        iterations=0,
        evaluations=0,
        decrement=0.0,
        last_step=0.0,
        at_bound=(),
        stalled=False,
        J=None,  # type: ignore[arg-type]  # a worker's profile reads z alone
        r=None,  # type: ignore[arg-type]
    )
    return Refinement(
        theta=spec["theta"],
        x0=spec["x0"],
        std=spec["std"],
        cov=spec["cov"],
        sigma=spec["sigma"],
        chi2=spec["chi2"],
        held=spec["held"],
        known=spec["known"],
        lower=spec["lower"],
        upper=spec["upper"],
        fit=fit,
        objective=obj,
        input_cov=spec["input_cov"],
    )


def _profile_task(task: tuple[dict[str, Any], str, float | None]) -> Profile:
    """One profile on a worker: ``(spec, name, deadline)``; past the deadline (wall clock), not computed."""
    spec, name, deadline = task
    ref = built_once(spec, lambda: _rebuilt(spec))
    if deadline is not None and time.time() > deadline:
        return _not_computed(ref, name)
    return _profile_or_say(ref, name)


#: The band within which an identified parameter's 95 % interval must lie (relative to the estimate).
BAND = 0.05


def judge(prof: Profile, *, band: float = BAND) -> str | None:
    """Why a parameter is flagged by its profile (None: its 95 % interval lies within ``+-band``).

    Parameters
    ----------
    prof : Profile
        The parameter's profile.
    band : float
        Relative half-width of the band.

    Returns
    -------
    str or None

    Examples
    --------
    >>> judge(Profile("k", 2.0, (1.99, 2.02), "closed", ())) is None
    True
    >>> judge(Profile("k", 2.0, (1.5, 2.6), "closed", ()))
    'its 95 % profile-likelihood interval [1.5, 2.6] is wider than +-5 % of the estimate 2'
    """
    lo, hi = prof.interval
    est = prof.estimate
    if prof.shape == "not-computed":
        return (
            f"no interval: the profiles' time budget ({MAX_SECONDS:g} s) ran out before this one; its std is "
            f"from the Fisher information alone"
        )
    if prof.shape == "not-optimal":
        return (
            "a point of its profile fits the data better than the estimate: the estimate is not the maximum "
            "of the likelihood along it, so no interval is claimed"
        )
    reach = (prof.points[0][0], prof.points[-1][0]) if prof.points else (est, est)  # the farthest points followed
    open_sides = [
        (s, why, th)
        for s, why, th, e in (("low", prof.sides[0], reach[0], lo), ("high", prof.sides[1], reach[1], hi))
        if e is None
    ]
    if lo is not None and hi is not None:  # closed on both sides (no open side)
        if lo < est - band * abs(est) or hi > est + band * abs(est):
            return (
                f"its 95 % profile-likelihood interval [{lo:.4g}, {hi:.4g}] is wider than +-{100 * band:g} % of "
                f"the estimate {est:.4g}"
            )
        return None
    full = all(why in ("search", "") for _, why, _ in open_sides)  # "": an old profile without the record
    if prof.shape == "flat" and full:
        return (
            f"flat profile likelihood (chi2 rises by less than {FLAT:g} within a factor "
            f"{math.exp(SEARCH):.0f} of the estimate): these data cannot identify it at all (a structural or "
            f"record-wide non-identifiability)"
        )
    said = "; ".join(_side_said(side, why, th) for side, why, th in open_sides)
    if prof.shape == "flat":
        return (
            f"its profile likelihood rises by less than {FLAT:g} as far as it was followed ({said}): the data "
            f"were not seen to bound it"
        )
    if full:
        return f"{said}: practically non-identifiable from these data"
    return f"{said}: no 95 % interval is claimed on that side"


def _side_said(side: str, why: str, theta: float) -> str:
    """Why the profile search stopped on one open ``side`` at ``theta`` (:attr:`Profile.sides`).

    >>> _side_said("low", "bound", 25.0)
    'on the low side the search stopped at the edge of the valid region (25, a factor 100 from the guess) with the profile still below the 95 % threshold: the bound, not the data, ended it; start from a guess nearer the estimate'
    """
    if why == "bound":
        return (
            f"on the {side} side the search stopped at the edge of the valid region ({theta:.4g}, a factor 100 "
            f"from the guess) with the profile still below the 95 % threshold: the bound, not the data, ended "
            f"it; start from a guess nearer the estimate"
        )
    if why == "declared":
        return (
            f"on the {side} side the search stopped at the bound the model file declares ({theta:.4g}, its [bounds]) "
            f"with the profile still below the 95 % threshold: the data do not bound it inside what the model allows"
        )
    if why == "points":
        return (
            f"on the {side} side the profile stays below the 95 % threshold as far as its {POINTS} points "
            f"followed it ({theta:.4g})"
        )
    return (
        f"its profile likelihood stays below the 95 % threshold up to a factor {math.exp(SEARCH):.0f} on the "
        f"{side} side ({theta:.4g})"
    )
