"""Models without inputs, records from rest or in free decay, and known initial conditions (issue 41).

Every record here is made by scipy's DOP853 at tight tolerances (never by obsnl), with Gaussian output noise of a
fixed seed; the expected values are those the data were made with. The tolerances are several std of the
estimates (about 0.1 % for k, 0.4 % for c, 0.05 % for a here), so a seed changes none of the verdicts.

* A model with no input identifies a free decay (it gave an IndexError).
* A record whose force channel is zero throughout (a ring-down) is identified, not refused as "nothing to identify
  from": the unknown initial state is estimated with the parameters.
* Initial conditions declared known (the model's ``known_initial_conditions`` with ``initial_condition_values``, or
  ``known_initial=`` of ``obsnl.identify``) are held by the filter and the fit: in ``y = a x``, ``x' = -c x`` only
  the known ``x(0)`` separates ``a`` from the initial state; with it freed, ``a`` came out flat and wrong.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import obsnl
from obsnl.errors import OptionError

K, C = 25.0, 0.8
T = np.arange(400) * 0.02


def _ring_down(x0=(0.1, 0.0), seed=0):
    sol = solve_ivp(lambda t, s: [s[1], -K * s[0] - C * s[1]], (0, T[-1]), x0, method="DOP853", t_eval=T,
                    rtol=1e-11, atol=1e-13)
    x = sol.y[0]
    return x + 1e-3 * np.sqrt(np.mean(x ** 2)) * np.random.default_rng(seed).standard_normal(T.size)


FREE = obsnl.Model(name="free", states=["x", "v"], parameters=["k", "c"], equations={"x": "v", "v": "-k*x - c*v"},
                   outputs={"y": "x"})
FORCED = obsnl.Model(name="forced", states=["x", "v"], parameters=["k", "c"], inputs=["u"],
                     equations={"x": "v", "v": "u - k*x - c*v"}, outputs={"y": "x"})


def _check_kc(res):
    est = {p.name: p for p in res.parameters}
    assert res.converged, res.converged_reason
    assert est["k"].estimate == pytest.approx(K, rel=5e-3) and abs(est["k"].estimate - K) < 4 * est["k"].std
    assert est["c"].estimate == pytest.approx(C, rel=2e-2) and abs(est["c"].estimate - C) < 4 * est["c"].std
    x0 = res.refinement.x0
    assert x0["x"] == pytest.approx(0.1, rel=2e-3)  # the initial displacement, estimated


def test_a_model_without_inputs_identifies_a_free_decay():
    res = obsnl.identify(FREE, {"t": T, "y": _ring_down()}, guess={"k": 20.0, "c": 1.0}, progress=False, jit=False)
    _check_kc(res)


def test_a_record_whose_force_is_zero_is_a_ring_down_not_nothing():
    res = obsnl.identify(FORCED, {"t": T, "u": np.zeros(T.size), "y": _ring_down()}, guess={"k": 20.0, "c": 1.0},
                         progress=False, jit=False)
    _check_kc(res)
    assert any("free decay" in a for a in res.assumptions)


A, RATE = 2.0, 0.5  # y = A exp(-RATE t) from x(0) = 1
SCALED = obsnl.Model(name="scaled", states=["x"], parameters=["a", "c"], equations={"x": "-c*x"},
                     outputs={"y": "a*x"}, guess={"a": 1.5, "c": 0.7})


def _scaled_record(seed=1):
    t = np.arange(200) * 0.02
    sol = solve_ivp(lambda tt, s: [-RATE * s[0]], (0, t[-1]), [1.0], method="DOP853", t_eval=t, rtol=1e-12,
                    atol=1e-14)
    y = A * sol.y[0]
    return {"t": t, "y": y + 1e-3 * np.sqrt(np.mean(y ** 2)) * np.random.default_rng(seed).standard_normal(t.size)}


@pytest.mark.parametrize("how", ["model", "argument"])
def test_known_initial_conditions_are_held_by_the_filter_and_the_fit(how):
    if how == "model":
        model, kw = SCALED.replace(known_initial_conditions=["x"], initial_condition_values={"x": 1.0}), {}
    else:
        model, kw = SCALED, {"known_initial": {"x": 1.0}}
    res = obsnl.identify(model, _scaled_record(), progress=False, jit=False, **kw)
    est = {p.name: p for p in res.parameters}
    assert res.converged, res.converged_reason
    assert res.refinement.x0["x"] == 1.0  # held, not fitted
    for name, true in (("a", A), ("c", RATE)):
        p = est[name]
        assert p.estimate == pytest.approx(true, rel=5e-3) and abs(p.estimate - true) < 4 * p.std, (name, p)
        assert p.interval is not None and None not in p.interval and p.interval[0] < true < p.interval[1]
        assert not p.flagged, p.reason
    assert any("known initial states held: x = 1" in a for a in res.assumptions)


def test_known_initial_takes_states_and_numbers():
    with pytest.raises(OptionError, match=r"known_initial= names 'z', which is not a state of 'scaled'"):
        obsnl.identify(SCALED, _scaled_record(), known_initial={"z": 1.0}, progress=False, jit=False)
    with pytest.raises(OptionError, match=r"known_initial= gives x = 'one'; give a finite number"):
        obsnl.identify(SCALED, _scaled_record(), known_initial={"x": "one"}, progress=False, jit=False)
    with pytest.raises(OptionError, match=r"known_initial= takes \{state: value\}"):
        obsnl.identify(SCALED, _scaled_record(), known_initial=[1.0], progress=False, jit=False)
