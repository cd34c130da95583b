"""The noise of a record under a periodic input, measured from its periods (obsnl.estimation.periods), and the
adequacy tests that take its colour as the noise's (obsnl.identification.adequacy, noise=).

Expected answers: the noise is drawn here with a known std and a known first-order colour (an AR(1) filter with
coefficient 0.5), so the estimates are judged against the values that made it.
"""

from __future__ import annotations

import numpy as np
import pytest

from obsnl.estimation.periods import input_period, periodic_noise, whiten
from obsnl.identification.adequacy import adequacy

L, P = 512, 5


def coloured(n: int, std: float, phi: float, rng: np.random.Generator) -> np.ndarray:
    """An AR(1) noise of stationary std ``std``: n(k) = phi n(k-1) + w(k)."""
    w = rng.normal(0.0, std * np.sqrt(1 - phi ** 2), n + 200)
    x = np.zeros_like(w)
    for k in range(1, len(w)):
        x[k] = phi * x[k - 1] + w[k]
    return x[200:]


def periodic_input() -> np.ndarray:
    t = np.arange(P * L)
    rng = np.random.default_rng(11)
    return sum(np.sin(2 * np.pi * k * t / L + rng.uniform(0, 6.3)) for k in range(3, 120, 5))


def test_the_period_is_found_and_an_aperiodic_input_has_none():
    u = periodic_input()
    assert input_period(u) == L
    assert input_period(np.column_stack([u, np.roll(u, 7)])) == L  # every input repeats with it
    assert input_period(np.sin(0.0123 * np.arange(3000))) is None
    assert input_period(u + 1e-3 * np.random.default_rng(0).standard_normal(len(u))) is None  # a noisy input


def test_level_and_colour_of_the_noise():
    # std 0.02 coloured with phi = 0.5: the estimate of the std from 4 periods (one left out) has a relative
    # sampling spread of about 1/sqrt(2 * 3 * 512) = 1.8 % (a little more for the colour): within 8 % at 4 sigma;
    # phi's Yule-Walker estimate has std about sqrt((1 - phi^2) / 2048) = 0.019: within 0.08
    rng = np.random.default_rng(5)
    u = periodic_input()
    y = np.convolve(u, [0.3, 0.2, 0.1])[: len(u)] + coloured(len(u), 0.02, 0.5, rng)
    est = periodic_noise(u, y)
    assert (est.period, est.first, est.periods, est.dof) == (L, 1, P - 1, (P - 2) * L)
    assert abs(est.std[0] / 0.02 - 1) < 0.08
    assert abs(-est.ar[0][1] - 0.5) < 0.08
    # the innovations' std: 0.02 sqrt(1 - 0.25)
    assert abs(est.innovation_std[0] / (0.02 * np.sqrt(0.75)) - 1) < 0.08


def test_whiten_inverts_an_ar_filter():
    rng = np.random.default_rng(1)
    w = rng.standard_normal(400)
    x = np.zeros(400)
    for k in range(1, 400):
        x[k] = 0.5 * x[k - 1] + w[k]
    assert np.allclose(whiten(x, [1.0, -0.5]), w[1:])


@pytest.mark.slow
def test_a_right_model_under_coloured_noise_passes_with_the_periodic_noise():
    # the residual of a right model is the noise itself. Its colour fails the plain whiteness test on every seed;
    # with the noise measured from the periods, adequacy passes. Family-wise level 1 %: 40 seeds, the chance of
    # more than 3 failures for a calibrated test is below 1e-3 (binomial(40, 0.01))
    u = periodic_input()
    fails_plain, fails_periodic = 0, 0
    for seed in range(40):
        rng = np.random.default_rng(100 + seed)
        clean = np.convolve(u, [0.3, 0.2, 0.1])[: len(u)]
        noise = coloured(len(u), 0.02, 0.5, rng)
        y = clean + noise
        e = y - clean
        noise_model = periodic_noise(u, y)
        plain = adequacy(e[:, None], measured=y[:, None], inputs=u, outputs=["y"], input_names=["u"])
        periodic = adequacy(e[:, None], measured=y[:, None], inputs=u, outputs=["y"], input_names=["u"],
                            noise=noise_model)
        fails_plain += not plain.passed
        fails_periodic += not periodic.passed
    assert fails_plain == 40
    assert fails_periodic <= 3


@pytest.mark.parametrize("wrong", ["gain", "missing_tap"])
def test_a_wrong_model_fails_with_the_periodic_noise(wrong):
    # 3 % off in gain (a misfit of RMS about 0.3 of the noise's), or a missing term of the response (correlated
    # with the input): both fail
    rng = np.random.default_rng(7)
    u = periodic_input()
    clean = np.convolve(u, [0.3, 0.2, 0.1])[: len(u)]
    y = clean + coloured(len(u), 0.02, 0.5, rng)
    model = 1.03 * clean if wrong == "gain" else np.convolve(u, [0.3, 0.2])[: len(u)]
    a = adequacy((y - model)[:, None], measured=y[:, None], inputs=u, outputs=["y"], input_names=["u"],
                 noise=periodic_noise(u, y))
    assert not a.passed
