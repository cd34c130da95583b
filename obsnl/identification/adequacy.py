"""Model adequacy: does the fitted model explain the data to the noise level? Residual tests at a stated level.

After a maximum-likelihood fit the residual ``e = y - y_model`` of a right model is the measurement noise (up to
the few directions the fit removed). Three tests per output channel ask whether it is:

- **whiteness**: the Ljung-Box portmanteau ``Q = N (N + 2) sum_k r_k^2 / (N - k)`` over lags ``1..M`` against
  ``chi2(M)`` (L. Ljung, System Identification: Theory for the User, 2nd ed., 1999, section 16.6; G. M. Ljung
  and G. E. P. Box, On a measure of lack of fit in time series models, 1978). Samples where the output is missing
  are skipped and the others closed up: any subsequence of a white noise is white.
- **cross-correlation** with each input over lags ``0..M``: under the hypothesis that the residual is independent
  of the input, ``sqrt(N) r_eu(tau)`` is Gaussian with covariance ``P = sum_k r_e(k) r_u(k)`` (Ljung 1999, eq.
  16.62). The vector of correlations is whitened by that covariance: the residual is prewhitened by an AR model
  (order by BIC, at most :data:`AR_MAX`; none where samples are missing) and the input filtered alike, so that
  ``r_e`` is a unit pulse; the input's own autocorrelation then enters through the lagged-input matrix ``U``.
  The statistic ``n R^2`` of the regression of the residual on ``U`` is ``N sum r_eu(tau)^2`` for a white input;
  its p-value is from ``F(rank U, n - rank U - 1)``, exact for a Gaussian white residual given the input.
- **misfit** against the noise level estimated from the raw record
  (:func:`obsnl.estimation.measured.estimate_noise`, from the record's differences: independent of the model and
  of the fit): ``F = (RSS / dof) / s^2``. With a known noise std ``RSS / sigma^2 ~ chi2(dof)``; the estimate
  ``s`` has its own sampling spread, so the null distribution of ``log F`` is calibrated by :data:`DRAWS` draws of
  white Gaussian noise with the record's gaps put through the same estimator (mean and std of ``log F``, taken
  Gaussian; beyond :data:`CALIBRATED` samples both scaled as ``1 / sqrt(N)``), with a fixed seed per record.
  One-sided: only a misfit above the noise is a failure. The share of the residual variance attributed to model
  error, ``1 - s^2 / (RSS / dof)`` floored at 0, is reported per output so that a user can judge a failure on a
  long record (where a tiny model error is significant). Without a noise estimate (gaps that leave too few evenly
  spaced samples) the misfit is not judged, and the assumptions say so.

``level`` is the family-wise level: each of the ``k`` tests is judged at ``level / k`` (Bonferroni), so that a
right model fails at most with probability ``level``.

Assumptions, stated in every result: the measurement noise is white (its band reaches the Nyquist frequency: a
sensor whose anti-alias filter colours the noise below Nyquist makes a right model fail whiteness and the misfit),
Gaussian, independent of the inputs and between channels; the inputs' noise passed through the model is small
beside it (an input's noise reaches the output filtered, coloured: on a long record a right model fails on it); the
inputs are measured without feedback from the residual (negative lags are not tested); the channel is oversampled
(else the noise estimate is only an upper bound and the misfit test is weak: its detail says so).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Any

import numpy as np

from obsnl._text import block, names, number, one_line
from obsnl.errors import DataError, OptionError
from obsnl.estimation.measured import MIN_SAMPLES, UPPER_BOUND, estimate_noise
from obsnl.estimation.periods import PeriodicNoise, levinson_bic, whiten

__all__ = [
    "AR_MAX",
    "CALIBRATED",
    "DRAWS",
    "FLAG_REASON",
    "INADEQUATE",
    "INPUT_NOISE_SHARE",
    "LEVEL",
    "MAX_LAGS",
    "Adequacy",
    "AdequacyTest",
    "adequacy",
    "cross_correlation",
    "lags_for",
    "misfit",
    "periodic_misfit",
    "whiteness",
]

#: The default family-wise level of the adequacy tests.
LEVEL = 0.01
#: Lags of the whiteness and cross-correlation tests: ``min(MAX_LAGS, N // 5)``.
MAX_LAGS = 25
#: The highest order of the AR model that prewhitens the residual in the cross-correlation test.
AR_MAX = 10
#: The highest order of the AR model that whitens a right model's residual under noisy inputs (:func:`adequacy`).
NULL_AR_MAX = 40
#: Draws of white noise that calibrate the misfit test's null distribution.
DRAWS = 400
#: The longest record the calibration draws: beyond it the mean and std of ``log F`` are scaled by
#: ``sqrt(CALIBRATED / N)`` (both fall as ``1 / sqrt(N)``: the noise estimate's error and the chi2's).
CALIBRATED = 8192
#: The share of the residual variance made by the inputs' noise above which a failed verdict says that it may be
#: the cause (the tests take the residual of a right model as the output noise alone).
INPUT_NOISE_SHARE = 0.1
#: What a failed adequacy means, said first.
INADEQUATE = "the model does not explain the data to the noise level"
#: The reason every parameter is flagged with when the model fails adequacy.
FLAG_REASON = (
    f"{INADEQUATE} (adequacy failed): its std and interval assume a right model and do not cover the model error"
)

_ASSUMPTIONS = (
    (
        "adequacy: the measurement noise is white (its band reaches the Nyquist frequency; noise coloured below it, "
        "e.g. by a sensor's anti-alias filter, makes a right model fail whiteness), Gaussian, independent of the inputs "
        "and between channels; the inputs' own noise, passed through the model, small beside it (else it adds a coloured "
        "error that a right model fails on, on a long record)"
    ),
    (
        "adequacy: whiteness by Ljung-Box Q over lags 1..M, M = min(25, N/5), against chi2(M) (Ljung 1999, sec. 16.6), "
        "on the residual samples present"
    ),
    (
        "adequacy: residual-input cross-correlation over lags 0..M per input, the residual prewhitened by an AR model "
        "(BIC, order <= 10; none with missing samples) and the input filtered alike, the correlations whitened by the "
        "input's own autocorrelation (Ljung 1999, eq. 16.62): n R^2 of the regression on the lagged input, p-value "
        "from F(rank, n - rank - 1); no feedback from the residual to the input (negative lags not tested)"
    ),
    (
        "adequacy: misfit RSS/dof over the noise variance estimated from the raw record's differences (independent "
        "of the model); the estimate's own spread counted by calibrating log F on draws of white Gaussian noise of "
        "the same length and gaps (at most 8192, scaled as 1/sqrt(N) beyond) through the same estimator; one-sided"
    ),
    "adequacy: the level is family-wise; each of the k tests is judged at level/k (Bonferroni)",
)


@dataclass(frozen=True)
class AdequacyTest:
    """One residual test on one output channel.

    ``name``: ``"whiteness"``, ``"cross-correlation"`` (then ``input`` names the input) or ``"misfit"``;
    ``statistic`` and ``p_value`` (the probability of a statistic at least as large under a right model);
    ``passed``: ``p_value`` above the level the test was judged at; ``detail``: the statistic's distribution
    and what it rests on, in words.
    """

    name: str
    output: str
    statistic: float
    p_value: float
    passed: bool
    detail: str
    input: str | None = None

    def __repr__(self) -> str:
        return one_line(
            "AdequacyTest",
            f"{self.name}",
            f"output={self.output!r}",
            f"input={self.input!r}" if self.input else "",
            f"statistic={number(self.statistic)}",
            f"p={number(self.p_value)}",
            "passed" if self.passed else "FAILED",
        )

    def label(self) -> str:
        """``whiteness of y``, ``cross-correlation of y with u``, ``misfit of y``."""
        return f"{self.name} of {self.output}" + (f" with {self.input}" if self.input else "")

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> AdequacyTest:
        """The test :meth:`to_dict` wrote (a number it wrote as None read as NaN)."""
        return cls(
            name=str(d["name"]),
            output=str(d["output"]),
            statistic=_nan(d["statistic"]),
            p_value=_nan(d["p_value"]),
            passed=bool(d["passed"]),
            detail=str(d.get("detail") or ""),
            input=None if d.get("input") is None else str(d["input"]),
        )

    def to_dict(self) -> dict[str, Any]:
        d = {
            "name": self.name,
            "output": self.output,
            "statistic": _finite(self.statistic),
            "p_value": _finite(self.p_value),
            "passed": self.passed,
            "detail": self.detail,
        }
        if self.input is not None:
            d["input"] = self.input
        return d


@dataclass(frozen=True)
class Adequacy:
    """The verdict of the residual tests: ``passed`` when every test passed at its share of ``level``.

    ``tests``: one :class:`AdequacyTest` per output and test; ``model_error``: per output, the share of the
    residual variance attributed to model error, ``1 - s^2 / (RSS / dof)`` floored at 0 (``s``: the independent
    noise estimate); ``input_noise_share``: per output, the share of the residual variance that the inputs' noise
    passed through the model would make (where it was gauged); ``input_noise_counted``: the tests count it in a
    right model's residual (draws of it were given, ``input_effect`` of :func:`adequacy`); where it was only gauged
    and is large, a right model can fail them, and the headline says so; ``assumptions``: what the verdict rests on.
    """

    passed: bool
    level: float
    tests: tuple[AdequacyTest, ...]
    assumptions: tuple[str, ...]
    model_error: Mapping[str, float] = field(default_factory=dict)
    input_noise_share: Mapping[str, float] = field(default_factory=dict)
    input_noise_counted: bool = False

    @property
    def failed(self) -> tuple[AdequacyTest, ...]:
        """The tests that failed."""
        return tuple(t for t in self.tests if not t.passed)

    def __repr__(self) -> str:
        return one_line(
            "Adequacy",
            f"passed={self.passed}",
            f"level={self.level:g}",
            f"tests={len(self.tests)}",
            f"failed={names([t.label() for t in self.failed], 3)!r}" if self.failed else "",
        )

    def headline(self) -> str:
        """One sentence: adequate or not, what a failure means, the failed tests."""
        k = len(self.tests)
        if self.passed:
            kinds = dict.fromkeys(t.name for t in self.tests)
            return f"adequate: the residuals pass {k} tests ({', '.join(kinds)}) at the {100 * self.level:g} % level"
        loud = {
            o: v for o, v in self.input_noise_share.items() if v >= INPUT_NOISE_SHARE and not self.input_noise_counted
        }
        return (
            f"NOT adequate: {INADEQUATE}; the std and intervals assume a right model (failed at "
            f"{100 * self.level:g} %: {names([t.label() for t in self.failed], 2)})"
            + (
                f"; but the inputs' noise makes {names([f'{100 * v:.2g} %' for v in loud.values()], 2)} of the "
                f"residual variance of {names(loud, 2)}, which the tests take as absent"
                if loud
                else ""
            )
        )

    def summary(self) -> str:
        """A few lines of plain text: the headline, each test, the share of model error per output."""
        share = names([f"{o} {100 * v:.3g} %" for o, v in self.model_error.items()])
        return block(
            self.headline(),
            *(
                f"{t.label()}: statistic {number(t.statistic)}, p = {t.p_value:.3g}, "
                f"{'passed' if t.passed else 'FAILED'}"
                for t in self.tests[:9]
            ),
            f"share of the residual variance attributed to model error: {share}" if self.model_error else "",
        )

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Adequacy:
        """The verdict :meth:`to_dict` wrote (``per_test_level`` follows from ``level`` and the tests; a number
        written as None read as NaN).

        Examples
        --------
        >>> a = Adequacy(passed=False, level=0.01, tests=(AdequacyTest("misfit", "y", 3.0, 1e-4, False, "F"),),
        ...              assumptions=("white noise",), model_error={"y": 0.5})
        >>> Adequacy.from_dict(a.to_dict()) == a
        True
        """
        return cls(
            passed=bool(d["passed"]),
            level=float(d["level"]),
            tests=tuple(AdequacyTest.from_dict(t) for t in d["tests"]),
            assumptions=tuple(map(str, d.get("assumptions") or ())),
            model_error={str(o): _nan(v) for o, v in (d.get("model_error_share") or {}).items()},
            input_noise_share={str(o): _nan(v) for o, v in (d.get("input_noise_share") or {}).items()},
            input_noise_counted=bool(d.get("input_noise_counted", False)),
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "passed": self.passed,
            "level": self.level,
            "per_test_level": self.level / max(len(self.tests), 1),
            "tests": [t.to_dict() for t in self.tests],
            "model_error_share": {o: _finite(v) for o, v in self.model_error.items()},
            "input_noise_share": {o: _finite(v) for o, v in self.input_noise_share.items()},
            "input_noise_counted": self.input_noise_counted,
            "assumptions": list(self.assumptions),
        }


def _finite(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _nan(x: float | None) -> float:
    """A number :func:`_finite` wrote, None read as NaN."""
    return float("nan") if x is None else float(x)


def lags_for(n: int) -> int:
    """The lags ``M`` of the whiteness and cross-correlation tests on ``n`` samples: ``min(MAX_LAGS, n // 5)``,
    at least 1.

    Examples
    --------
    >>> lags_for(400), lags_for(60)
    (25, 12)
    """
    return max(1, min(MAX_LAGS, n // 5))


def _column(x: Any, what: str) -> np.ndarray:
    a = np.asarray(x, float)
    if a.ndim != 1:
        raise OptionError(f"{what} must be one series, got shape {a.shape}")
    return a


def _enough(n: int, output: str) -> None:
    """Refuse a residual with fewer samples present than the tests need."""
    if n < MIN_SAMPLES:
        raise OptionError(
            f"the residual of {output!r} has {n} samples present; the adequacy tests need at least {MIN_SAMPLES}"
        )


def _paired(e: Any, x: Any, output: str, what: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """The residual and a series beside it (``what``: "the output", "the input 'u'") sample by sample: both as
    columns, the mask of the samples where both are present, and their count (refused below the tests' need)."""
    e, x = _column(e, "the residual"), _column(x, what)
    if len(e) != len(x):
        raise OptionError(
            f"the residual of {output!r} has {len(e)} samples, {what} {len(x)}; give them sample by sample"
        )
    present = np.isfinite(e) & np.isfinite(x)
    n = int(present.sum())
    _enough(n, output)
    return e, x, present, n


def _check_level(level: float) -> None:
    if isinstance(level, bool) or not (isinstance(level, (int, float)) and 0 < level < 0.5):
        raise OptionError(f"level={level!r} must be a number in (0, 0.5), e.g. 0.01 (the chance a right model fails)")


def whiteness(e: Any, *, output: str = "y", lags: int | None = None, level: float = LEVEL) -> AdequacyTest:
    """Ljung-Box test of the residual ``e`` for whiteness (module docstring); NaN samples are skipped.

    Parameters
    ----------
    e : array_like
        The residual of one output.
    output : str
        Its name.
    lags : int or None
        ``M`` (default :func:`lags_for` of the samples present).
    level : float
        The level the test is judged at.

    Returns
    -------
    AdequacyTest

    Raises
    ------
    OptionError
        Fewer than ``MIN_SAMPLES`` samples present, or a bad level.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> whiteness(rng.standard_normal(500)).passed
    True
    >>> x = np.zeros(500); w = rng.standard_normal(500)
    >>> for t in range(1, 500): x[t] = 0.5 * x[t - 1] + w[t]
    >>> whiteness(x).passed
    False
    """
    from scipy import stats  # loaded when a test runs (start-up kept short)

    _check_level(level)
    e = _column(e, "the residual")
    e = e[np.isfinite(e)]
    n = len(e)
    _enough(n, output)
    m = lags_for(n) if lags is None else int(lags)
    if not 1 <= m < n:
        raise OptionError(f"lags={lags!r} must be an integer from 1 to {n - 1}")
    e = e - e.mean()
    c0 = float(e @ e)
    if c0 == 0:
        return AdequacyTest("whiteness", output, 0.0, 1.0, True, "the residual is constant: nothing to correlate")
    r = np.array([float(e[k:] @ e[:-k]) / c0 for k in range(1, m + 1)])
    q = float(n * (n + 2) * np.sum(r**2 / (n - np.arange(1, m + 1))))
    p = float(stats.chi2.sf(q, m))
    return AdequacyTest(
        "whiteness",
        output,
        q,
        p,
        p > level,
        f"Ljung-Box Q over lags 1..{m} on {n} samples, chi2({m}); largest |r_k| "
        f"{np.max(np.abs(r)):.3g} at lag {int(np.argmax(np.abs(r))) + 1} (white: within "
        f"{1.96 / math.sqrt(n):.3g} at 95 %)",
    )


def _input_noise_null(
    e: np.ndarray, y: np.ndarray, draws: Sequence[np.ndarray]
) -> tuple[np.ndarray, tuple[float, float]] | None:
    """A right model's residual when the measured inputs are noisy: ``(ar, (mean, std))``, the whitening filter
    ``[1, a_1, ..., a_p]`` of the output noise plus the inputs' noise through the model (Levinson-Durbin on their
    autocovariance, the order by BIC up to :data:`NULL_AR_MAX`), and the mean and std over the draws of the variance
    that noise adds; None where the draws move nothing or the output's noise cannot be
    estimated. The output noise's level is the raw record's (:func:`~obsnl.estimation.measured.estimate_noise`),
    the draws' seed fixed by the record."""
    ok = np.isfinite(e) & np.isfinite(y)
    moved = [np.where(ok, np.asarray(d, float), 0.0) for d in draws]
    variances = np.array([float(np.mean(d[ok] ** 2)) for d in moved]) if ok.any() else np.zeros(0)
    if not variances.size or not np.all(np.isfinite(variances)) or not variances.max() > 0:
        return None
    try:
        ratio, _ = estimate_noise(np.where(ok, y, np.nan))
    except DataError:
        return None
    s = ratio * math.sqrt(float(np.mean(y[ok] ** 2)))
    n = int(ok.sum())
    lags = min(NULL_AR_MAX, n // 5)
    # the sum's autocovariance: the draws' (averaged) plus the white output noise's at lag 0
    seen = [d[ok] for d in moved]
    gamma = np.mean([[float(x[k:] @ x[: n - k]) / n for k in range(lags + 1)] for x in seen], axis=0)
    gamma[0] += s * s
    ar = levinson_bic(gamma / gamma[0], n * len(draws), lags)
    spread = float(np.std(variances, ddof=1)) if len(variances) > 1 else float(variances[0])
    return ar, (float(np.mean(variances)), spread)


def _ar_order(e: np.ndarray, most: int) -> tuple[int, np.ndarray]:
    """The AR model of ``e`` (mean removed) with the lowest BIC among orders ``0..most``, by least squares on the
    same samples: ``(order, coefficients)``."""
    n = len(e)
    rows = np.arange(most, n)
    best = (n * math.log(max(float(np.mean(e[rows] ** 2)), 1e-300)), 0, np.zeros(0))
    for p in range(1, most + 1):
        X = np.column_stack([e[rows - i] for i in range(1, p + 1)])
        a = np.linalg.lstsq(X, e[rows], rcond=None)[0]
        s2 = float(np.mean((e[rows] - X @ a) ** 2))
        bic = len(rows) * math.log(max(s2, 1e-300)) + p * math.log(len(rows))
        if bic < best[0]:
            best = (bic, p, a)
    return best[1], best[2]


def _filtered(x: np.ndarray, a: np.ndarray) -> np.ndarray:
    """``x(t) - sum_i a_i x(t - i)``, NaN for ``t < len(a)``."""
    out = np.full(len(x), np.nan)
    out[len(a) :] = whiten(x, np.r_[1.0, -np.asarray(a, float)])  # the one AR filter (obsnl.estimation.periods)
    return out


def cross_correlation(
    e: Any, u: Any, *, output: str = "y", input: str = "u", lags: int | None = None, level: float = LEVEL
) -> AdequacyTest:
    """Test of the residual ``e`` against the input ``u`` over lags ``0..M`` (module docstring); NaN residual
    samples are skipped.

    Parameters
    ----------
    e, u : array_like
        The residual of one output and one input, sample by sample (the same length).
    output, input : str
        Their names.
    lags : int or None
        ``M`` (default :func:`lags_for` of the residual samples present).
    level : float
        The level the test is judged at.

    Returns
    -------
    AdequacyTest
        ``statistic`` is ``n R^2`` (``N sum r_eu(tau)^2`` for a white input).

    Raises
    ------
    OptionError
        Series of different lengths, too few samples, or a bad level.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> u = rng.standard_normal(600)
    >>> cross_correlation(rng.standard_normal(600), u).passed
    True
    >>> cross_correlation(rng.standard_normal(600) + 0.3 * np.r_[0.0, 0.0, u[:-2]], u).passed   # u two samples late
    False
    """
    from scipy import stats

    _check_level(level)
    e, u, present, n_present = _paired(e, u, output, f"the input {input!r}")
    m = lags_for(n_present) if lags is None else int(lags)
    if not 0 <= m < n_present // 2:
        raise OptionError(f"lags={lags!r} must be an integer from 0 to {n_present // 2 - 1}")
    order, a = (0, np.zeros(0))
    if present.all():
        ec = e - e.mean()
        order, a = _ar_order(ec, min(AR_MAX, max(len(e) // 20, 0)))
        ew, uw = _filtered(ec, a), _filtered(u - u.mean(), a)
    else:
        ew, uw = np.where(present, e, np.nan), np.where(np.isfinite(u), u, np.nan)
    t = np.arange(m + order, len(e))
    U = np.column_stack([uw[t - k] for k in range(m + 1)])
    keep = np.isfinite(ew[t]) & np.all(np.isfinite(U), axis=1)
    y, U = ew[t][keep], U[keep]
    n = len(y)
    y, U = y - y.mean(), U - U.mean(axis=0)
    lam, V = np.linalg.eigh(U.T @ U) if U.size else (np.zeros(0), np.zeros((0, 0)))
    live = lam > 1e-12 * lam.max() if lam.size and lam.max() > 0 else np.zeros(len(lam), bool)
    rank = int(live.sum())  # the directions the lagged input spans (fewer than the lags for a few sines)
    yy = float(y @ y)
    if rank == 0 or yy == 0 or n - rank - 1 < 1:
        return AdequacyTest(
            "cross-correlation",
            output,
            0.0,
            1.0,
            True,
            "nothing to correlate (a constant input or residual)",
            input=input,
        )
    c = V[:, live].T @ (U.T @ y)
    proj2 = float(np.sum(c**2 / lam[live]))  # |P_U y|^2 with P_U the projection on the lagged input
    r2 = min(proj2 / yy, 1.0)
    f = (r2 / rank) / (max(1.0 - r2, 1e-300) / (n - rank - 1))
    p = float(stats.f.sf(f, rank, n - rank - 1))
    how = f"the residual prewhitened by AR({order}) (BIC)" if present.all() else "the residual not prewhitened (gaps)"
    return AdequacyTest(
        "cross-correlation",
        output,
        n * r2,
        p,
        p > level,
        f"n R^2 of the residual on input {input} at lags 0..{m} ({n} samples, rank {rank}), "
        f"F({rank}, {n - rank - 1}); {how}",
        input=input,
    )


def _misfit_null(present: np.ndarray, fitted: float) -> tuple[float, float]:
    """Mean and std of ``log F`` for a right model: white Gaussian noise on the samples ``present`` (a boolean
    mask: the gaps of the record kept, since the noise estimate's spread grows with them), ``fitted`` coordinates
    removed (an independent ``chi2(fitted)`` subtracted from the sum of squares), the noise estimated by
    :func:`~obsnl.estimation.measured.estimate_noise`. Beyond :data:`CALIBRATED` samples, drawn on the first
    ``CALIBRATED`` and scaled by the square root of the ratio of the samples measured."""
    n = int(present.sum())
    if len(present) > CALIBRATED:
        head = present[:CALIBRATED]
        mu, sd = _misfit_null(head, fitted)
        shrink = math.sqrt(head.sum() / n)
        return mu * shrink, sd * shrink
    return _null_of(np.packbits(present).tobytes(), len(present), fitted)


@lru_cache(maxsize=16)
def _null_of(packed: bytes, length: int, fitted: float) -> tuple[float, float]:
    """:func:`_misfit_null` of a packed mask (hashable: the same record, the same calibration; seeded by it)."""
    present = np.unpackbits(np.frombuffer(packed, np.uint8), count=length).astype(bool)
    n = int(present.sum())
    rng = np.random.default_rng([length, n, DRAWS])
    logs = np.empty(DRAWS)
    for b in range(DRAWS):
        w = np.where(present, rng.standard_normal(length), np.nan)
        ratio, _ = estimate_noise(w)
        seen = w[present]
        s2 = ratio**2 * float(np.mean(seen**2))
        rss = float(seen @ seen) - (float(rng.chisquare(fitted)) if fitted > 0 else 0.0)
        logs[b] = math.log(max(rss, 1e-300) / (n - fitted) / s2)
    return float(np.mean(logs)), float(np.std(logs, ddof=1))


def misfit(
    e: Any,
    y: Any,
    *,
    output: str = "y",
    dof: float | None = None,
    level: float = LEVEL,
    input_variance: tuple[float, float] = (0.0, 0.0),
) -> tuple[AdequacyTest, float]:
    """Test of the residual's size against the noise level estimated from the raw record ``y`` (module docstring).

    Parameters
    ----------
    e : array_like
        The residual of one output (NaN: a missing sample).
    y : array_like
        The measured output, raw: its noise std is estimated from its differences (NaN: a missing sample; the
        differences of evenly spaced samples measured).
    output : str
        Its name.
    dof : float or None
        The residual degrees of freedom, the samples present less the fitted coordinates this output carries
        (default: the samples present).
    level : float
        The level the test is judged at.
    input_variance : tuple of float
        ``(mean, std)`` of the variance the measured inputs' noise adds to a right model's residual (its draws
        through the model at the estimate, :func:`adequacy`): the null is then ``s^2 + mean``, its spread widened by
        ``std``. The fit absorbs part of that drift, so the test is conservative there.

    Returns
    -------
    tuple
        ``(AdequacyTest, share)``: the test, and the share of the residual variance attributed to model error
        (``1 - (s^2 + mean) / (RSS / dof)``, floored at 0).

    Raises
    ------
    OptionError
        Too few samples, a ``dof`` out of range, a bad level, or no noise estimate (a zero output, or gaps that
        leave too few evenly spaced samples).

    Examples
    --------
    >>> rng = np.random.default_rng(2)
    >>> t = np.arange(2000) * 0.01
    >>> y = np.sin(2 * np.pi * 0.3 * t) + 0.01 * rng.standard_normal(2000)
    >>> test, share = misfit(y - np.sin(2 * np.pi * 0.3 * t), y)
    >>> test.passed, share < 0.1
    (True, True)
    >>> test, share = misfit(y - 1.01 * np.sin(2 * np.pi * 0.3 * t), y)    # 1 % off in amplitude: RMS 0.0071
    >>> test.passed, abs(share - 1 / 3) < 0.05      # its share: 0.0071^2 / (0.0071^2 + 0.01^2) = 1/3
    (False, True)
    """
    from scipy import stats

    _check_level(level)
    e, y, ok, n = _paired(e, y, output, "the output")
    dof = float(n if dof is None else dof)
    if not 1 <= dof <= n:
        raise OptionError(f"dof={dof!r} must lie in [1, {n}] (the samples present less the fitted coordinates)")
    try:  # its gaps as they are: the differences of evenly spaced samples measured
        ratio, note = estimate_noise(np.where(ok, y, np.nan))
    except DataError as exc:
        raise OptionError(f"no noise estimate for the misfit of {output!r}: {exc}") from None
    s2 = ratio**2 * float(np.mean(y[ok] ** 2))
    if not s2 > 0:
        raise OptionError(f"no noise estimate for the misfit of {output!r}: the output is zero throughout")
    var = float(e[ok] @ e[ok]) / dof
    extra, extra_sd = (float(v) for v in input_variance)
    null = s2 + max(extra, 0.0)
    ratio_f = var / null
    mu, sd = _misfit_null(ok, round(n - dof, 3))
    sd = math.hypot(sd, extra_sd / null)  # the input noise's drift over one record is few-dof: its variance spreads
    p = float(stats.norm.sf((math.log(max(ratio_f, 1e-300)) - mu) / sd))
    share = max(0.0, 1.0 - null / var) if var > 0 else 0.0
    weak = (
        "; the noise estimate is only an upper bound (the channel is not oversampled): a misfit below it goes unseen"
        if UPPER_BOUND in note
        else ""
    )
    return AdequacyTest(
        "misfit",
        output,
        ratio_f,
        p,
        p > level,
        f"(RSS/dof) / s^2 with dof {dof:.6g} and s = {math.sqrt(s2):.3g} estimated from the raw "
        f"record's differences; log F against its spread under a right model (mean {mu:.3g}, std "
        f"{sd:.3g}, {DRAWS} draws of white noise); RMS residual / s = {math.sqrt(var / s2):.4g}"
        + (
            f"; the null adds the inputs' noise through the model at the estimate, variance {extra:.3g} "
            f"(std {extra_sd:.2g} over its draws): {math.sqrt(null / s2):.4g} s"
            if extra > 0
            else ""
        )
        + weak,
    ), share


def periodic_misfit(
    e: Any, noise: PeriodicNoise, j: int, *, output: str = "y", dof: float | None = None, level: float = LEVEL
) -> tuple[AdequacyTest, float]:
    """The misfit of one output against the noise measured from the periods of a periodic input.

    The residual goes through the noise's whitening filter (``noise.ar[j]``); under a right model it is then white
    with the variance of the noise's innovations, which the periods measured independently
    (``noise.innovation_std[j]`` with ``noise.innovation_dof[j]`` degrees of freedom). ``F = (RSS_w / dof_w) / s_w^2``
    is then ``F(dof_w, innovation_dof)`` for Gaussian noise; one-sided.

    Parameters
    ----------
    e : array_like
        The residual of output ``j`` (no missing sample).
    noise : PeriodicNoise
        The noise measured from the periods.
    j : int
        The output's column.
    output : str
        Its name.
    dof : float or None
        The residual's degrees of freedom (default: its samples).
    level : float
        The level the test is judged at.

    Returns
    -------
    tuple
        ``(AdequacyTest, share)``, the share of the residual variance attributed to model error (floored at 0).

    Examples
    --------
    >>> from obsnl.estimation.periods import periodic_noise
    >>> rng = np.random.default_rng(4)
    >>> t = np.arange(4 * 500)
    >>> u = np.sin(2 * np.pi * 3 * t / 500)
    >>> y = 2 * u + 0.1 * rng.standard_normal(len(t))
    >>> noise = periodic_noise(u, y)
    >>> test, share = periodic_misfit(y - 2 * u, noise, 0)
    >>> test.passed
    True
    >>> periodic_misfit(y - 2.1 * u, noise, 0)[0].passed     # 5 % off: RMS 0.071 beside the noise's 0.1
    False
    """
    from scipy import stats

    _check_level(level)
    x = _column(e, "the residual")
    if not np.all(np.isfinite(x)):
        raise OptionError(f"the residual of {output!r} has missing samples; the periodic noise needs none")
    a = noise.ar[j]
    w = whiten(x, a)
    n = len(w)
    dof_w = float(n if dof is None else dof) - (len(a) - 1)
    if not 1 <= dof_w <= n:
        raise OptionError(f"dof={dof!r} leaves {dof_w:g} degrees of freedom after the whitening filter")
    s2 = noise.innovation_std[j] ** 2
    var = float(w @ w) / dof_w
    f = var / s2 if s2 > 0 else math.inf
    p = float(stats.f.sf(f, dof_w, noise.innovation_dof[j]))
    share = max(0.0, 1.0 - s2 / var) if var > 0 else 0.0
    return AdequacyTest(
        "misfit",
        output,
        f,
        p,
        p > level,
        f"(RSS/dof) / s^2 through the noise's whitening filter (AR {len(a) - 1}), dof {dof_w:.6g}, s "
        f"= {math.sqrt(s2):.3g} the noise innovations' std measured from {noise.periods} periods "
        f"({noise.innovation_dof[j]} degrees of freedom); against F({dof_w:.6g}, "
        f"{noise.innovation_dof[j]}); RMS residual / noise std = "
        f"{float(np.sqrt(np.mean(x**2))) / noise.std[j]:.4g}",
    ), share


def adequacy(
    residuals: Any,
    *,
    measured: Any,
    inputs: Any,
    outputs: Sequence[str],
    input_names: Sequence[str] = (),
    dof: Sequence[float] | None = None,
    level: float = LEVEL,
    lags: int | None = None,
    input_noise_share: Mapping[str, float] | None = None,
    noise: PeriodicNoise | None = None,
    innovations: bool = False,
    input_effect: Sequence[Any] = (),
) -> Adequacy:
    """Judge whether a fitted model explains the data to the noise level (module docstring).

    Parameters
    ----------
    residuals : array_like
        ``(N, ny)``: measured minus modelled output; NaN where the output is missing (skipped).
    measured : array_like
        ``(N, ny)``: the measured outputs, raw (their noise level is estimated from their differences).
    inputs : array_like
        ``(N, nu)``: the measured inputs (``(N,)`` for one, ``(N, 0)`` for none).
    outputs, input_names : sequence of str
        The channels' names.
    dof : sequence of float or None
        Per output, the residual degrees of freedom (default: the samples present).
    level : float
        The family-wise level (default 1 %): each of the ``k`` tests is judged at ``level / k``.
    lags : int or None
        ``M`` of the whiteness and cross-correlation tests (default :func:`lags_for` of the samples present).
    input_noise_share : mapping of str to float or None
        Per output, the share of the residual variance the inputs' noise makes through the model, where the caller
        gauged it (:func:`obsnl.identification.refine.adequacy_of`); carried into the verdict.
    noise : PeriodicNoise or None
        The noise measured from the periods of a periodic input (:func:`obsnl.estimation.periods.periodic_noise`),
        independent of the model: then its colour is the noise's, not the model's. The whiteness test runs on the
        residual through the noise's whitening filter, and the misfit compares the filtered residual's variance with
        the filtered noise's (:func:`periodic_misfit`).
    input_effect : sequence of array_like
        Draws ``(N, ny)`` of what the measured inputs' noise moves the model's output by (the model simulated at
        the estimate under the measured input plus a draw of its noise, less under the measured input:
        :func:`obsnl.identification.refine.adequacy_of`). A right model's residual is then the output noise plus that
        coloured part: the whiteness test runs on the residual through the whitening filter of that sum (an AR model
        fitted to draws of it, BIC, at most :data:`AR_MAX`), and the misfit's null adds its variance. Empty: the
        inputs are exact, or their noise is negligible.
    innovations : bool
        The residuals are a predictor's innovations (the prediction-error objective): they carry the unmeasured
        disturbances by design, so their level is no test of the model and the misfit is not judged; whiteness and
        the cross-correlation with the inputs are the tests of a prediction-error model (Ljung 1999, section 16.6).

    Returns
    -------
    Adequacy

    Raises
    ------
    OptionError
        Shapes that do not match the names, too few samples, a bad level.

    Examples
    --------
    >>> rng = np.random.default_rng(3)
    >>> t = np.arange(1000) * 0.01
    >>> u = np.sin(2 * np.pi * 0.7 * t) + 0.5 * np.sin(2 * np.pi * 1.9 * t)
    >>> y = np.sin(2 * np.pi * 0.2 * t) + 0.01 * rng.standard_normal(1000)
    >>> a = adequacy(y - np.sin(2 * np.pi * 0.2 * t), measured=y, inputs=u, outputs=["y"], input_names=["u"])
    >>> a.passed, [t.name for t in a.tests]
    (True, ['whiteness', 'cross-correlation', 'misfit'])
    """
    _check_level(level)
    r = np.asarray(residuals, float)
    r = r.reshape(len(r), -1)
    y = np.asarray(measured, float).reshape(len(r), -1) if np.size(measured) == r.size else None
    u = np.asarray(inputs, float)
    u = u.reshape(len(u), -1) if u.ndim == 1 or u.size else np.zeros((len(r), 0))
    if y is None or r.shape[1] != len(outputs) or len(u) != len(r) or u.shape[1] != len(input_names):
        raise OptionError(
            f"adequacy: residuals {r.shape}, measured outputs {np.shape(measured)} and inputs "
            f"{np.shape(inputs)} do not match {len(outputs)} output(s) and {len(input_names)} input(s); "
            "give them sample by sample, one column per channel"
        )
    if dof is not None and len(dof) != len(outputs):
        raise OptionError(f"dof= has {len(dof)} values for {len(outputs)} outputs; give one per output")
    k = len(outputs) * ((1 if innovations else 2) + len(input_names))
    each = level / k
    tests: list[AdequacyTest] = []
    share: dict[str, float] = {}
    notes: list[str] = []
    if innovations:
        noise = None  # a predictor's innovations are white themselves: the measured noise's colour is not theirs
    effect = [np.asarray(d, float).reshape(len(r), -1) for d in input_effect] if noise is None else []
    for j, o in enumerate(outputs):
        null = _input_noise_null(r[:, j], y[:, j], [d[:, j] for d in effect]) if effect and not innovations else None
        if null is not None:
            ar, variance = null
            white = whiteness(np.r_[np.full(len(ar) - 1, np.nan), whiten(r[:, j], ar)], output=o, lags=lags, level=each)
            tests.append(
                dataclasses.replace(
                    white,
                    detail=white.detail
                    + (
                        f"; on the residual through the whitening filter (AR {len(ar) - 1}) of the output noise plus "
                        "the inputs' noise through the model at the estimate"
                    ),
                )
            )
        elif noise is not None:
            white = whiteness(whiten(r[:, j], noise.ar[j]), output=o, lags=lags, level=each)
            tests.append(
                dataclasses.replace(
                    white,
                    detail=white.detail
                    + (
                        f"; on the residual through the whitening filter of the noise measured from the periods (AR "
                        f"{len(noise.ar[j]) - 1})"
                    ),
                )
            )
        else:
            tests.append(whiteness(r[:, j], output=o, lags=lags, level=each))
        tests += [
            cross_correlation(r[:, j], u[:, i], output=o, input=c, lags=lags, level=each)
            for i, c in enumerate(input_names)
        ]
        if innovations:
            continue
        if noise is not None:
            test, share[o] = periodic_misfit(
                r[:, j], noise, j, output=o, dof=None if dof is None else dof[j], level=each
            )
            tests.append(test)
            continue
        try:
            test, share[o] = misfit(
                r[:, j],
                y[:, j],
                output=o,
                dof=None if dof is None else dof[j],
                level=each,
                input_variance=(0.0, 0.0) if null is None else null[1],
            )
        except OptionError as exc:  # the other tests stand; this one is said not judged
            notes.append(f"adequacy: misfit of {o} not judged ({exc})")
        else:
            tests.append(test)
    if noise is not None:
        notes.append(
            f"adequacy: the noise measured from {noise.periods} periods of {noise.period} samples of the "
            f"periodic input{' (the first period left out: a transient)' if noise.first else ''}, independent "
            "of the model; the whiteness and misfit tests take its colour (an AR filter fitted to its "
            "autocorrelation, Yule-Walker, BIC) as the noise's, so a coloured measurement noise is not blamed "
            "on the model"
        )
    if effect and not innovations:
        notes.append(
            f"adequacy: a right model's residual is taken as the output noise plus the measured inputs' noise passed "
            f"through the model at the estimate ({len(effect)} seeded draws of it): the whiteness test runs on the "
            "residual through that sum's whitening filter and the misfit's null adds its variance; the fit absorbs "
            "part of that drift, so these two tests are conservative"
        )
    if innovations:
        notes.append(
            "adequacy: the residuals are the predictor's innovations, which carry the unmeasured disturbances by "
            "design: their level against the measurement noise is not judged, only their whiteness and their "
            "independence of the inputs"
        )
    return Adequacy(
        passed=all(t.passed for t in tests),
        level=float(level),
        tests=tuple(tests),
        assumptions=_ASSUMPTIONS + tuple(notes),
        model_error=share,
        input_noise_share=dict(input_noise_share or {}),
        input_noise_counted=bool(effect) and not innovations,
    )
