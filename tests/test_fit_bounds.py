"""The likelihood fit honours the model's declared bounds (``[bounds]``, ``Model(bounds=...)``), issue 41.

Data from scipy's ``solve_ivp``: an oscillator ``x'' = u - k x - c x'`` measured in displacement, ``k = 25``,
``c = 0.4``.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import obsnl
from obsnl.errors import OptionError
from obsnl.identification.experiments import Tuning

K, C = 25.0, 0.4
T, DT = 800, 0.02
TUNING = Tuning(s0=0.3, q_theta=0.0, q_x=1.0)


def _model(bounds: dict[str, tuple[float, float]] | None = None) -> obsnl.Model:
    return obsnl.Model(
        name="oscillator",
        states=["x", "v"],
        parameters=["k", "c"],
        inputs=["u"],
        equations={"x": "v", "v": "u - k*x - c*v"},
        outputs={"y": "x"},
        bounds=bounds or {},
    )


def _record() -> dict[str, np.ndarray]:
    t = np.arange(T) * DT
    u = np.sin(2 * np.pi * 0.6 * t) + 0.7 * np.sin(2 * np.pi * 1.3 * t)
    x = solve_ivp(
        lambda tt, s: [s[1], float(np.interp(tt, t, u)) - K * s[0] - C * s[1]],
        (0, t[-1]),
        [0.0, 0.0],
        t_eval=t,
        rtol=1e-10,
        atol=1e-12,
        max_step=DT,
    ).y[0]
    rng = np.random.default_rng(4)
    return {"t": t, "u": u, "y": x + 0.005 * np.std(x) * rng.standard_normal(T)}


def _identify(model: obsnl.Model, guess: dict[str, float]) -> obsnl.Identification:
    return obsnl.identify(model, _record(), guess=guess, progress=False, passes=1, tuning=TUNING)


def test_a_guess_outside_the_declared_bounds_is_refused() -> None:
    with pytest.raises(OptionError, match=r"the guess of c is 0.2, outside its declared bounds \[0.5, 2\]"):
        _identify(_model({"c": (0.5, 2.0)}), {"k": 20.0, "c": 0.2})


def test_a_binding_bound_holds_the_estimate_and_says_so() -> None:
    """The data pull c to 0.4, below the declared 0.5: the estimate rests on 0.5, is not called converged, and the
    reason and the profile name the declared bound, not the factor-100 search region."""
    res = _identify(_model({"c": (0.5, 2.0)}), {"k": 20.0, "c": 1.0})
    c = next(p for p in res.parameters if p.name == "c")
    assert c.estimate == pytest.approx(0.5, rel=1e-9)
    assert not res.converged
    assert "declared bound" in res.converged_reason and "factor 100" not in res.converged_reason
    prof = next(p for p in res.to_dict()["profiles"] if p["name"] == "c")
    assert prof["stopped"]["low"] == "declared"


def test_a_bound_that_does_not_bind_changes_nothing() -> None:
    """With the truth well inside the declared bounds, the fit ends where the unbounded fit ends and keeps its
    interval."""
    free = _identify(_model(), {"k": 20.0, "c": 1.0})
    bounded = _identify(_model({"c": (0.1, 2.0), "k": (1.0, 100.0)}), {"k": 20.0, "c": 1.0})
    assert bounded.converged and free.converged
    for p, q in zip(free.parameters, bounded.parameters):
        assert q.estimate == pytest.approx(p.estimate, rel=1e-6)
        assert q.interval == pytest.approx(p.interval, rel=1e-4)
    c = next(p for p in bounded.parameters if p.name == "c")
    lo, hi = c.interval
    assert lo <= C <= hi
