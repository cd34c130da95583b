"""The noise of a record driven by a periodic input, measured from its periods.

Under a periodic input, the steady-state response repeats from period to period; what differs between periods is
the noise. Its level and its colour are therefore measured from the record alone, independently of any model
(the nonparametric noise estimate of periodic excitation: Pintelon and Schoukens [1]_, sections 2.4 and 7.2):
with ``P`` periods ``y_p`` of ``L`` samples and their mean ``ybar``, ``sigma^2 = sum_p |y_p - ybar|^2 / ((P - 1) L)``
(unbiased, ``(P - 1) L`` degrees of freedom), and the autocorrelation of the deviations ``y_p - ybar`` is that of
the noise (the mean removes the same share ``1/P`` at every lag). A coloured noise (a sensor's anti-alias filter
below the Nyquist frequency, the Bouc-Wen benchmark's band-limited noise) is then described by an autoregressive
model fitted to that autocorrelation (Yule-Walker, order by BIC), which whitens it.

The first period of a record that starts from rest holds a transient: with three periods or more it is left out.

References
----------
.. [1] R. Pintelon and J. Schoukens, *System Identification: A Frequency Domain Approach*, 2nd ed., Wiley-IEEE
   Press, 2012. doi:10.1002/9781118287422
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["PeriodicNoise", "input_period", "periodic_noise", "whiten", "levinson_bic", "REPEAT_TOLERANCE", "AR_MAX"]

#: An input repeats with period ``L`` when the RMS of ``u(k + L) - u(k)`` is at most this fraction of its RMS.
REPEAT_TOLERANCE = 1e-6
#: The largest order of the noise's autoregressive model.
AR_MAX = 10


@dataclass(frozen=True)
class PeriodicNoise:
    """The noise of each output, measured from the periods of a periodic input.

    Attributes
    ----------
    period
        Samples per period.
    first, periods
        The first period used (0, or 1 when the first was left out as a transient) and how many were used.
    std
        The noise standard deviation of each output.
    dof
        Its degrees of freedom, ``(periods - 1) * period``.
    ar
        For each output, the coefficients ``[1, a_1, ..., a_p]`` of the filter ``e(k) + a_1 e(k-1) + ...`` that
        whitens its noise (``[1.0]``: white).
    innovation_std, innovation_dof
        For each output, the standard deviation of its noise through that filter (the deviations of each period
        filtered, the first ``p`` samples of each dropped) and its degrees of freedom, ``(periods - 1) (period - p)``.
    """

    period: int
    first: int
    periods: int
    std: tuple[float, ...]
    dof: int
    ar: tuple[tuple[float, ...], ...]
    innovation_std: tuple[float, ...] = ()
    innovation_dof: tuple[int, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        return {
            "period": self.period,
            "first_period": self.first,
            "periods": self.periods,
            "std": list(self.std),
            "dof": self.dof,
            "ar": [list(a) for a in self.ar],
            "innovation_std": list(self.innovation_std),
            "innovation_dof": list(self.innovation_dof),
        }


def input_period(u: Any, *, min_periods: int = 2) -> int | None:
    """The smallest period (in samples) with which every input repeats, at least ``min_periods`` times in the record;
    None when there is none.

    Parameters
    ----------
    u : array_like
        The inputs, ``(T,)`` or ``(T, nu)``.
    min_periods : int
        Whole periods the record must hold.

    Returns
    -------
    int or None

    Examples
    --------
    >>> t = np.arange(600)
    >>> input_period(np.sin(2 * np.pi * t / 100) + np.cos(2 * np.pi * 3 * t / 100)), input_period(np.sin(0.1 * t))
    (100, None)
    """
    x = np.asarray(u, float).reshape(len(u), -1)
    T = len(x)
    if T < 2 * min_periods or not np.all(np.isfinite(x)):
        return None
    x = x - x.mean(axis=0)
    n = 1 << int(np.ceil(np.log2(2 * T)))
    F = np.fft.rfft(x, n=n, axis=0)
    corr = np.fft.irfft(np.abs(F) ** 2, n=n, axis=0)[:T].sum(axis=1)  # sum_k x(k) x(k + L)
    sq = np.cumsum((x**2).sum(axis=1))
    lags = np.arange(1, T // min_periods + 1)
    head = sq[T - 1 - lags]  # sum over k < T - L of x(k)^2
    tail = sq[-1] - sq[lags - 1]  # sum over k >= L of x(k)^2
    diff = head + tail - 2 * corr[lags]
    ok = diff <= (REPEAT_TOLERANCE**2) * np.maximum(head, 1e-300)
    hits = lags[ok & (head > 0)]
    return int(hits[0]) if hits.size else None


def levinson_bic(r: np.ndarray, n: int, most: int) -> np.ndarray:
    """The whitening filter ``[1, a_1, ..., a_p]`` (for :func:`whiten`) of the AR model of the autocorrelation ``r``
    (``r[0] = 1``) of ``n`` samples, the order chosen by BIC up to ``most`` (Levinson-Durbin).

    Parameters
    ----------
    r : numpy.ndarray
        The autocorrelation at lags ``0..most`` at least, ``r[0] = 1``.
    n : int
        The samples it was estimated from (the BIC's penalty).
    most : int
        The highest order tried.

    Returns
    -------
    numpy.ndarray
        ``[1, a_1, ..., a_p]``; ``[1]`` where no order lowers the BIC.

    Examples
    --------
    >>> levinson_bic(np.array([1.0, 0.5, 0.25, 0.125]), 10000, 3).round(12).tolist()  # AR(1), phi = 0.5
    [1.0, -0.5]
    """
    best, best_bic = np.array([1.0]), np.log(max(r[0], 1e-300))
    from scipy.linalg import solve_toeplitz

    for p in range(1, most + 1):
        a = solve_toeplitz(r[:p], r[1 : p + 1])
        var = r[0] - a @ r[1 : p + 1]
        if not var > 0:
            break
        bic = np.log(var) + p * np.log(n) / n
        if bic < best_bic:
            best, best_bic = np.concatenate([[1.0], -a]), bic
    return best


def whiten(e: Any, ar: Any) -> np.ndarray:
    """``e`` through the whitening filter ``ar`` (the first ``len(ar) - 1`` samples, which lack a past, dropped).

    Parameters
    ----------
    e : array_like
        A series.
    ar : sequence of float
        ``[1, a_1, ..., a_p]``.

    Returns
    -------
    numpy.ndarray

    Examples
    --------
    >>> whiten([1.0, 2.0, 4.0, 8.0], [1.0, -2.0]).tolist()
    [0.0, 0.0, 0.0]
    """
    x, a = np.asarray(e, float), np.asarray(ar, float)
    p = len(a) - 1
    out = x[p:].copy()
    for i in range(1, p + 1):
        out += a[i] * x[p - i : len(x) - i]
    return out


def periodic_noise(u: Any, y: Any, *, min_periods: int = 2) -> PeriodicNoise | None:
    """The noise of each output measured from the periods of a periodic input (module docstring); None when the
    input is not periodic, holds fewer than ``min_periods`` whole periods after a transient, or an output has gaps.

    Parameters
    ----------
    u : array_like
        The inputs, ``(T,)`` or ``(T, nu)``.
    y : array_like
        The outputs, ``(T,)`` or ``(T, ny)``.
    min_periods : int
        Whole periods needed (after the first is left out where there are three or more).

    Returns
    -------
    PeriodicNoise or None

    Examples
    --------
    Five periods of a response plus a noise of std 0.1, coloured by a first-order filter:

    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(5 * 400)
    >>> u = np.sin(2 * np.pi * t / 400) + np.sin(2 * np.pi * 7 * t / 400)
    >>> w = rng.normal(0, 0.1 * np.sqrt(1 - 0.5 ** 2), len(t))
    >>> n = np.array([w[: k + 1] @ 0.5 ** np.arange(k, -1, -1) for k in range(len(t))])
    >>> est = periodic_noise(u, 2 * u + n)
    >>> est.period, est.periods, round(est.std[0], 2), [round(a, 1) for a in est.ar[0]]
    (400, 4, 0.1, [1.0, -0.5])
    """
    ys = np.asarray(y, float).reshape(len(y), -1)
    if not np.all(np.isfinite(ys)):
        return None
    L = input_period(u, min_periods=min_periods)
    if L is None:
        return None
    P = len(ys) // L
    first = 1 if P >= 3 else 0
    used = P - first
    if used < min_periods:
        return None
    Y = ys[first * L : (first + used) * L].reshape(used, L, -1)
    E = Y - Y.mean(axis=0)
    dof = (used - 1) * L
    std, ar, istd, idof = [], [], [], []
    for j in range(ys.shape[1]):
        e = E[:, :, j]
        ss = float(np.sum(e**2))
        std.append(float(np.sqrt(ss / dof)))
        a = np.array([1.0])
        if ss > 0:
            r = np.array([np.sum(e[:, : L - k] * e[:, k:]) / ss for k in range(AR_MAX + 1)])
            a = levinson_bic(r, used * L, AR_MAX)
        ar.append(tuple(float(c) for c in a))
        w = np.concatenate([whiten(e[p], a) for p in range(used)])  # each period's deviations, filtered
        idof.append((used - 1) * (L - len(a) + 1))
        istd.append(float(np.sqrt(float(w @ w) / idof[-1])))
    return PeriodicNoise(L, first, used, tuple(std), dof, tuple(ar), tuple(istd), tuple(idof))
