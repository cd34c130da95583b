"""Profiles that report what the search did (issue 41): a bound reached, a side left open, no interval claimed.

With a guess exactly 100x the truth, the estimate lies on the edge of the valid region (the guess / 100): the
profile's low side can go no further, which is the bound, not the data; it must never be called "practically
non-identifiable ... up to a factor 10". A profile point that fits better than the estimate claims no interval,
so none is printed. Data: a mass-spring-damper by scipy's DOP853 (tests/test_likelihood.py), 1 % noise, seed 7
(the assertions hold for any seed: the std of k is about 0.05 %, the bound and the better point are exact).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import obsnl
from obsnl.identification.profile import judge, profile
from obsnl.identification.refine import refine
from obsnl.report.identification.run import identify_text

from .test_likelihood import MSD, K, msd_data, setup_of


def test_a_profile_stopped_by_the_valid_region_says_so_not_non_identifiable():
    u, y, _ = msd_data(seed=7)
    t = np.arange(len(u)) * 0.02
    res = obsnl.identify(MSD, {"t": t, "u": u, "y": y}, guess={"k": 100 * K, "c": 1.0}, progress=False, jit=False)
    k = next(p for p in res.parameters if p.name == "k")
    prof = next(p for p in res.profiles if p.name == "k")
    assert k.estimate == pytest.approx(K, rel=2e-3)  # the truth, on the guess / 100 bound
    assert k.std / k.estimate < 2e-3  # well informed: 1 % noise on 300 samples
    assert "non-identifiable" not in k.reason and "up to a factor 10 " not in k.reason, k.reason
    assert "the bound, not the data, ended it" in k.reason
    line = next(s for s in identify_text(res).splitlines() if s.strip().startswith("k "))
    assert "non-identifiable" not in line
    assert prof.sides[0] == "bound"  # the low side stopped at the edge of the valid region


def test_a_profile_that_finds_a_better_point_claims_no_interval():
    u, y, sigma = msd_data(seed=7)
    setup, data = setup_of(MSD, u, y, 0.02, {"k": 18.0, "c": 1.2}, sigma)
    ref = refine(setup, data, setup.theta_guess)
    # an "estimate" 2 std of c below the optimum: going down, the profile rises past the threshold (a low end is
    # found); going up, it passes the optimum, about 4 below the stated chi2 (quadratic: (2 std)^2 / std^2)
    i = list(MSD.parameters).index(next(s for s in MSD.parameters if s.name == "c"))
    z = ref.fit.z.copy()
    z[i] -= 2.0 * np.sqrt(ref.cov[i, i])
    r, _ = ref.objective.evaluate(z)
    off = dataclasses.replace(ref, chi2=float(r @ r), theta=ref.objective.theta(z), fit=dataclasses.replace(ref.fit, z=z))
    prof = profile(off, "c")
    assert prof.shape == "not-optimal" and prof.better is not None
    assert prof.interval == (None, None)  # no end of an interval next to "no interval is claimed"
    assert "no interval is claimed" in judge(prof)
    assert prof.better < off.chi2 - 3.0  # the optimum, about 4 lower
    assert prof.better_z is not None and len(prof.better_z) == len(ref.fit.z)  # where a refit starts
