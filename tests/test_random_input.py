"""The noise of a random input (issue 41): a white-noise force is an excitation, never read as noise.

Its samples differ as white noise does, so the differences that estimate a channel's noise read it as about 100 %
noise (for white noise of std s, every k-th difference has std s sqrt(C(2k, k)): the estimator's exact case). Read
so, the input's noise widened every std about 530x and flagged every parameter. Such an estimate is only an upper
bound: the input is taken as exact, and the result says so. Data: a mass-spring-damper (k = 25, c = 0.8) driven by
seeded white noise, integrated by scipy's DOP853, 1 % output noise (seed 3). The bounds below hold with a wide
margin (the Fisher std of k is about 0.1 % here, against 50 % and more when the force was read as noise).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import obsnl

from .test_likelihood import MSD

K, C = 25.0, 0.8


def _white_noise_record(n: int = 600, dt: float = 0.02, seed: int = 3) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(n) * dt
    u = rng.standard_normal(n)
    sol = solve_ivp(lambda tt, s: [s[1], np.interp(tt, t, u) - K * s[0] - C * s[1]], (0, t[-1]), [0.0, 0.0],
                    method="DOP853", t_eval=t, rtol=1e-11, atol=1e-13, max_step=dt / 4)
    x = sol.y[0]
    return {"t": t, "u": u, "y": x + 0.01 * np.sqrt(np.mean(x ** 2)) * rng.standard_normal(n)}


def test_a_white_noise_force_is_taken_as_exact_not_as_noise():
    res = obsnl.identify(MSD, _white_noise_record(), guess={"k": 20.0, "c": 1.0}, progress=False, jit=False)
    u = res.noise["u"]
    assert u.estimate > 0.5  # RANDOM_INPUT: the differences see the excitation itself (about 1 for white noise)
    assert u.upper_bound and u.origin == "upper bound" and "taken as exact" in u.source
    assert any("input u: taken as exact" in a for a in res.assumptions)
    est = {p.name: p for p in res.parameters}
    assert est["k"].estimate == pytest.approx(K, rel=0.01) and est["c"].estimate == pytest.approx(C, rel=0.05)
    assert est["k"].std / est["k"].estimate < 0.01  # not widened by a noise that is the signal
    assert not est["k"].flagged, est["k"].reason
