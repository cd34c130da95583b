"""Practical identifiability at an estimate: is a parameter pinned within the 5 % band at 3 sigma by
these data? By the linearised Cramér-Rao bound (with the input noise), by the filter's posterior
against its prior, and (:class:`Spread`, from :func:`obsnl.identification.experiments.monte_carlo`) by the
Monte-Carlo spread of the whole protocol at the estimate."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from obsnl._text import block, names, one_line
from obsnl.errors import EstimatorError
from obsnl.estimation.records import rms
from obsnl.estimation.simulate import simulate, simulate_many
from obsnl.estimation.ukf import Trajectory
from obsnl.identification.likelihood import covariance
from obsnl.identification.setup import DIVERGED, Data, Setup, output_misfit

__all__ = [
    "Practical",
    "Spread",
    "crb",
    "fisher",
    "input_noise_crb",
    "practical_identifiability",
    "CRB_LIMIT",
    "POSTERIOR_LIMIT",
]

#: Threshold on the Cramér-Rao standard deviation of log(theta): a parameter whose 3-sigma bound is
#: wider than the 5 % goal cannot be pinned to it by any unbiased estimator on this record.
CRB_LIMIT = 0.05 / 3
#: A filter that kept more than this fraction of its prior standard deviation learnt (almost) nothing.
POSTERIOR_LIMIT = 0.5


@dataclass(frozen=True)
class Practical:
    """Practical identifiability of the parameters on one record, at one estimate.

    ``crb``: Cramér-Rao standard deviation of ``log|theta_i|`` (relative error), from the Fisher
    information of the output sensitivities (central differences of the simulated output in
    ``log|theta|``) and the output noise; ``sensitivity``: RMS of ``d y / d log|theta_i|`` over the
    noise std; ``posterior``: the filter's final std over its prior std (first pass). A parameter is
    flagged when ``crb > CRB_LIMIT`` or ``posterior > POSTERIOR_LIMIT``, and, once a Monte-Carlo spread
    is joined (:meth:`with_spread`), when the estimator's own spread exceeds the same limit (the
    linearised bound misses the spread along ridges of a non-smooth response). ``inconclusive`` (non-empty)
    says why nothing could be decided (the estimate diverged or cannot be simulated); then nothing
    is flagged and the numbers are NaN.
    """

    parameters: tuple[str, ...]
    crb: tuple[float, ...]
    sensitivity: tuple[float, ...]
    posterior: tuple[float, ...]
    flagged: tuple[str, ...]
    reasons: Mapping[str, str]
    inconclusive: str = ""
    spread: Spread | None = None
    undecided: Mapping[str, str] = field(default_factory=dict)
    linearised: tuple[str, ...] | None = None  # the flags before the Monte-Carlo criterion was joined

    def __repr__(self) -> str:
        mc = f"monte_carlo={self.spread.replicates} replicates" if self.spread is not None else ""
        return one_line(
            "Practical",
            f"parameters={len(self.parameters)}",
            f"flagged={names(self.flagged, 6)!r}",
            f"undecided={names(self.undecided, 4)!r}" if self.undecided else "",
            mc,
            f"inconclusive={self.inconclusive!r}" if self.inconclusive else "",
        )

    def summary(self) -> str:
        """A few lines of plain text: which parameters these data leave outside the 5 % band, and why."""
        if self.inconclusive:
            return block(
                f"practical identifiability of {len(self.parameters)} parameters: not decided ({self.inconclusive})"
            )
        n = len(self.flagged)
        return block(
            f"practical identifiability of {len(self.parameters)} parameters on these data: {n} flagged"
            f" (not pinned within 5 % at 3 sigma){': ' + names(self.flagged, 8) if n else ''}",
            *(f"{p}: {self.reasons[p]}" for p in self.flagged[:8]),
            *(f"{p} undecided: {why}" for p, why in list(self.undecided.items())[:2]),
            self.spread.summary().splitlines()[0] if self.spread is not None else "",
        )

    @property
    def flagged_linearised(self) -> tuple[str, ...]:
        """The parameters flagged by the Cramér-Rao and posterior criteria alone."""
        return self.flagged if self.linearised is None else self.linearised

    def to_dict(self) -> dict[str, Any]:
        return {
            "parameters": list(self.parameters),
            "crb_relative_std": _nums(self.crb),
            "sensitivity_over_noise": _nums(self.sensitivity),
            "posterior_over_prior_std": _nums(self.posterior),
            "flagged": list(self.flagged),
            "flagged_linearised": list(self.flagged_linearised),
            "reasons": dict(self.reasons),
            "inconclusive": self.inconclusive or None,
            "undecided": dict(self.undecided),
            "monte_carlo": self.spread.to_dict() if self.spread else None,
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Practical:
        """The verdict :meth:`to_dict` wrote (a number it wrote as None read as NaN; ``flagged_linearised`` kept
        where it differs from ``flagged``)."""
        flagged = tuple(map(str, d["flagged"]))
        linearised = tuple(map(str, d.get("flagged_linearised") or ()))
        mc = d.get("monte_carlo")
        return cls(
            parameters=tuple(map(str, d["parameters"])),
            crb=_floats(d["crb_relative_std"]),
            sensitivity=_floats(d["sensitivity_over_noise"]),
            posterior=_floats(d["posterior_over_prior_std"]),
            flagged=flagged,
            reasons={str(p): str(why) for p, why in (d.get("reasons") or {}).items()},
            inconclusive=str(d.get("inconclusive") or ""),
            spread=None if mc is None else Spread.from_dict(mc),
            undecided={str(p): str(why) for p, why in (d.get("undecided") or {}).items()},
            linearised=None if "flagged_linearised" not in d or linearised == flagged else linearised,
        )

    def with_spread(self, spread: Spread, *, limit: float = CRB_LIMIT) -> Practical:
        """These flags joined with the Monte-Carlo criterion (:class:`Spread`) at the same limit.

        A parameter is flagged when the lower confidence bound of its Monte-Carlo spread exceeds
        ``limit``; when the interval contains ``limit`` it is *undecided* for that criterion (named,
        not flagged). Parameters the protocol held at their guess have no spread and keep their flag.
        """
        if self.inconclusive:
            return replace(self, spread=spread)
        if spread.inconclusive:  # the other criteria stand; the 5 % band of the rest is not decided
            return replace(
                self,
                spread=spread,
                undecided={
                    p: f"no Monte-Carlo spread: {spread.inconclusive}" for p in self.parameters if p not in self.reasons
                },
            )
        reasons, undecided = dict(self.reasons), {}
        for p, sd, lo, hi in zip(self.parameters, spread.std, spread.lower, spread.upper):
            if p in spread.held:
                continue
            band = (
                f"Monte-Carlo std of the relative error {100 * sd:.2g} % ({100 * spread.confidence:g} % "
                f"interval {100 * lo:.2g}-{100 * hi:.2g} %, {spread.replicates} replicates)"
            )
            if lo > limit:
                reasons[p] = "; ".join(filter(None, [reasons.get(p), f"{band} > {100 * limit:.2g} %"]))
            elif hi > limit and p not in reasons:
                undecided[p] = f"{band} contains {100 * limit:.2g} %"
        return replace(
            self,
            spread=spread,
            reasons=reasons,
            undecided=undecided,
            linearised=self.flagged_linearised,
            flagged=tuple(p for p in self.parameters if p in reasons),
        )


def _nums(v: Sequence[float]) -> list[float | None]:
    """Finite numbers, None for NaN/inf (JSON has no NaN)."""
    return [float(x) if np.isfinite(x) else None for x in v]


def _floats(v: Sequence[float | None]) -> tuple[float, ...]:
    """The numbers :func:`_nums` wrote, None read as NaN."""
    return tuple(float("nan") if x is None else float(x) for x in v)


@dataclass(frozen=True)
class Spread:
    """Monte-Carlo spread of an estimator at an estimate (a parametric bootstrap).

    ``std``: sample standard deviation of ``log|theta_i|`` (the relative error) over the replicates
    that did not diverge; ``lower``/``upper``: its ``confidence`` interval (chi-square with
    ``replicates - 1`` degrees of freedom, Gaussian estimates assumed); ``held``: parameters the
    protocol held at their guess in every replicate (no spread). Replicate ``b`` draws its noise from
    ``numpy.random.default_rng([seed, b])``. ``inconclusive`` says why no spread could be given.
    """

    parameters: tuple[str, ...]
    std: tuple[float, ...]
    lower: tuple[float, ...]
    upper: tuple[float, ...]
    replicates: int
    diverged: int
    confidence: float
    seed: int
    held: tuple[str, ...] = ()
    inconclusive: str = ""

    def __repr__(self) -> str:
        sd = names([f"{p} {100 * s:.2g} %" for p, s in zip(self.parameters, self.std)], 5)
        return one_line(
            "Spread",
            f"replicates={self.replicates}",
            f"diverged={self.diverged}",
            f"relative_std='{sd}'",
            f"inconclusive={self.inconclusive!r}" if self.inconclusive else "",
        )

    def summary(self) -> str:
        """A few lines of plain text: the Monte-Carlo spread of each parameter's relative error."""
        if self.inconclusive:
            return block(f"Monte-Carlo spread over {self.replicates} replicates: not given ({self.inconclusive})")
        rows = [
            f"{p}: relative std {100 * s:.2g} % ({100 * self.confidence:g} % interval {100 * lo:.2g}-"
            f"{100 * hi:.2g} %)" + (" held" if p in self.held else "")
            for p, s, lo, hi in zip(self.parameters, self.std, self.lower, self.upper)
        ]
        return block(
            f"Monte-Carlo spread over {self.replicates} replicates ({self.diverged} diverged, seed {self.seed})",
            *rows[:10],
            f"... and {len(rows) - 10} more" if len(rows) > 10 else "",
        )

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Spread:
        """The spread :meth:`to_dict` wrote (a number it wrote as None read as NaN)."""
        return cls(
            parameters=tuple(map(str, d["parameters"])),
            std=_floats(d["relative_std"]),
            lower=_floats(d["lower"]),
            upper=_floats(d["upper"]),
            replicates=int(d["replicates"]),
            diverged=int(d["diverged"]),
            confidence=float(d["confidence"]),
            seed=int(d["seed"]),
            held=tuple(map(str, d.get("held") or ())),
            inconclusive=str(d.get("inconclusive") or ""),
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "parameters": list(self.parameters),
            "relative_std": _nums(self.std),
            "lower": _nums(self.lower),
            "upper": _nums(self.upper),
            "replicates": self.replicates,
            "diverged": self.diverged,
            "confidence": self.confidence,
            "seed": self.seed,
            "held": list(self.held),
            "inconclusive": self.inconclusive or None,
        }


def crb(F: np.ndarray) -> np.ndarray:
    """Cramér-Rao standard deviations from a Fisher matrix ``F``: ``sqrt(diag(F^+))`` with the inverse taken on
    the correlation form of ``F`` (:func:`~obsnl.identification.likelihood.covariance`), ``inf`` along a flat
    direction.

    A plain pseudo-inverse with a relative cut (``pinv(F, rcond)``) drops a coordinate whose information is
    small beside the others' as if it were none of it, and returned a bound near 0 for the least informed
    parameter: the opposite of the truth. Here the bound of a coordinate is never below ``1 / sqrt(F_ii)``.

    Examples
    --------
    >>> crb(np.diag([1e16, 4.0])).tolist()           # the weakly informed coordinate keeps its bound 1/2
    [1e-08, 0.5]
    >>> crb(np.array([[1.0, 1.0], [1.0, 1.0]])).tolist()   # only the sum is seen
    [inf, inf]
    """
    w, V = np.linalg.eigh((np.asarray(F, float) + np.asarray(F, float).T) / 2)
    C, _ = covariance(np.sqrt(np.clip(w, 0, None))[:, None] * V.T)  # a square root J of F: J'J = F
    return np.sqrt(np.clip(np.diag(C), 0, None))


def fisher(setup: Setup, theta: np.ndarray, u: np.ndarray, sigma: Any, *, step: float = 1e-2) -> np.ndarray:
    """Output sensitivities ``(T*ny, np)`` to ``log|theta|``, divided by the noise std ``sigma`` (a
    number, or one per output).

    Central differences with a 1 % step: the response of the non-smooth model is rough on finer
    scales (switching instants move), and smaller steps overstate the information several times.

    Parameters
    ----------
    setup : Setup
        The experiment.
    theta : numpy.ndarray
        Parameter values.
    u : numpy.ndarray
        Input record.
    sigma : float or array_like
        Output noise std.
    step : float
        Central-difference step in ``log|theta|``.

    Returns
    -------
    numpy.ndarray
    """
    m, dt = setup.model, setup.record.dt
    thetas = []
    for i in range(m.np):
        for s in (step, -step):
            th = np.array(theta, float)
            th[i] *= np.exp(s)
            thetas.append(th)
    sims = simulate_many(
        m, thetas=thetas, x0=setup.x0, u=u, dt=dt, substeps=setup.substeps, refine=setup.refine, jit=setup.jit
    )
    ys = []
    for got in sims:
        if isinstance(got, EstimatorError):
            raise got
        ys.append(got.y)
    cols = [((ys[2 * i] - ys[2 * i + 1]) / (2 * step) / np.asarray(sigma, float)).ravel() for i in range(m.np)]
    return np.array(cols).T


def input_noise_crb(setup: Setup, theta: np.ndarray | None = None, *, u: np.ndarray | None = None) -> dict[str, Any]:
    """Cramér-Rao std of ``log|theta_i|`` with the input noise counted (a diagnostic, not a flag).

    The filters and fits see the *measured* input ``u + w``; to first order the output they should
    reproduce is off by ``-J_u w`` (``J_u = dy/du``, one column per input sample, by central
    differences of the simulation), so the effective output noise has covariance
    ``Sigma = sigma_y^2 I + sigma_u^2 J_u J_u^T`` and the Fisher information is ``S^T Sigma^-1 S``
    (``S = dy/dlog|theta|``). ``crb_output_only`` is the bound with ``sigma_u = 0`` (the one the
    practical-identifiability flag uses). Costs two simulations per input sample (about a minute).

    Parameters
    ----------
    setup : Setup
        The experiment.
    theta : numpy.ndarray or None
        Parameter values (None: the truth).
    u : numpy.ndarray or None
        Input record (None: the record's).

    Returns
    -------
    dict
        The two bounds per parameter and the input noise's share.
    """
    m, dt = setup.model, setup.record.dt
    theta = setup.theta_true if theta is None else np.asarray(theta, float)
    u = setup.record.accel if u is None else np.asarray(u, float)
    su, sy = setup.noise * rms(u), setup.noise * rms(setup.y_true)
    S = fisher(setup, theta, u, 1.0)  # raw sensitivities dy/dlog|theta|
    sim = lambda uu: simulate(
        m,
        theta=theta,
        x0=setup.x0,
        u=uu,
        dt=dt,
        substeps=setup.substeps,  # noqa: E731
        refine=setup.refine,
        jit=setup.jit,
    ).y.ravel()
    Ju = np.zeros((len(S), len(u)))
    for k in range(len(u)):
        e = np.zeros_like(u)
        e[k] = su
        Ju[:, k] = (sim(u + e) - sim(u - e)) / (2 * su)
    out: dict[str, Any] = {}
    for name, cov in (
        ("crb_output_only", sy**2 * np.eye(len(S))),
        ("crb_with_input_noise", sy**2 * np.eye(len(S)) + su**2 * Ju @ Ju.T),
    ):
        F = S.T @ np.linalg.solve(cov, S)
        out[name] = dict(zip(m.parameters, crb(F).tolist()))
    out["input_noise_output_rms_over_sigma_y"] = float(su * np.sqrt(np.trace(Ju @ Ju.T) / len(S)) / sy)
    return out


def practical_identifiability(
    setup: Setup, theta: np.ndarray, data: Data, *, first: Trajectory, prior_std: float, misfit: float | None = None
) -> Practical:
    """Flag the parameters this record cannot pin down (see :class:`Practical`).

    Parameters
    ----------
    setup : Setup
        The experiment.
    data : Data
        The measured record.
    theta : ndarray
        The estimate at which the output sensitivities are taken.
    first : Trajectory
        The first pass of the filter (its final covariance against ``prior_std``).
    prior_std : float
        The filter's prior std of the log-parameters.
    misfit : float or None
        The free-run output misfit of ``theta`` if already computed (else computed here). Above
        ``DIVERGED`` x the noise level, or when ``theta`` cannot be simulated, the result is
        inconclusive: sensitivities of a diverged estimate say nothing about these data.
    """
    m = setup.model
    misfit = output_misfit(setup, theta, data) if misfit is None else float(misfit)
    why_not = ""
    if not np.isfinite(misfit):
        why_not = "the estimate cannot be simulated (the filter diverged)"
    elif misfit > DIVERGED * setup.noise_level:
        why_not = (
            f"the estimate's output misfit {misfit:.3g} is above {DIVERGED:g}x the noise level "
            f"{setup.noise_level:.3g} (the filter did not converge on these data)"
        )
    if not why_not:
        try:
            S = fisher(setup, theta, data.u, setup.noise_std(data)[1])
            S[np.isnan(np.asarray(data.y, float)).ravel()] = 0.0  # a missing output sample informs nothing
        except EstimatorError:
            why_not = "a perturbed estimate cannot be simulated (no sensitivities)"
    if why_not:
        nan = (float("nan"),) * m.np
        return Practical(
            parameters=m.parameters,
            crb=nan,
            sensitivity=nan,
            posterior=nan,
            flagged=(),
            reasons={},
            inconclusive=why_not,
        )
    bound = crb(S.T @ S)
    sens = np.sqrt(np.mean(S**2, axis=0))
    nx = m.nx
    post = np.sqrt(np.clip(np.diag(first.P[-1])[nx:], 0, None)) / prior_std
    # posterior ratios are per filter coordinate; with log coordinates they are per parameter
    post = post if len(post) == m.np else np.full(m.np, np.nan)
    reasons = {}
    for p, c, r in zip(m.parameters, bound, post):
        why = []
        if c > CRB_LIMIT:
            why.append(
                f"Cramér-Rao std of the relative error {100 * c:.3g} % > {100 * CRB_LIMIT:.3g} %"
                if np.isfinite(c)
                else "no information in the output sensitivities (a flat direction of the "
                "Fisher matrix: the Cramér-Rao bound is infinite)"
            )
        if r > POSTERIOR_LIMIT:
            why.append(f"the filter kept {100 * r:.0f} % of its prior std")
        if why:
            reasons[p] = "; ".join(why)
    return Practical(
        parameters=m.parameters,
        crb=tuple(float(c) for c in bound),
        sensitivity=tuple(float(s) for s in sens),
        posterior=tuple(float(r) for r in post),
        flagged=tuple(p for p in m.parameters if p in reasons),
        reasons=reasons,
    )
