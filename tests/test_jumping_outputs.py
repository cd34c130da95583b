"""An output that jumps with the vector field: a friction oscillator measured by an accelerometer.

The acceleration ``(u - k x - c v - F sign(v)) / m`` jumps by ``2 F / m`` wherever the velocity changes sign, so a
sample next to a reversal hangs on the reversal's time to within a sample: the likelihood jumps wherever a reversal
passes a sample, and before the fit left those samples out, the profiles stopped at the estimate and the fit was
never converged. Data from scipy's ``solve_ivp`` (an independent integrator), the input linear between samples as
obsnl assumes by default.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import obsnl
from obsnl.estimation.codegen import to_casadi
from obsnl.identification.experiments import Tuning

TRUTH = {"k": 40.0, "c": 0.4, "F": 0.3}
GUESS = {"k": 35.0, "c": 0.5, "F": 0.25}
ACCELEROMETER = obsnl.Model(
    name="friction_accelerometer",
    states=["x", "v"],
    parameters=["k", "c", "F"],
    inputs=["u"],
    equations={"x": "v", "v": "u - k*x - c*v - F*sign(v)"},
    outputs={"a": "u - k*x - c*v - F*sign(v)"},
)
T, DT = 1000, 0.01
TUNING = Tuning(s0=0.3, q_theta=0.0, q_x=1.0)


def _record(seed: int, v0: float) -> dict[str, np.ndarray]:
    """The oscillator from ``x = 0.05, v = v0`` under two sines (no sticking: the force always beats friction at a
    reversal), acceleration sampled at 100 Hz with white noise of 1 % of its RMS."""
    t = np.arange(T) * DT
    u = 3 * np.sin(2 * np.pi * 0.8 * t) + 1.5 * np.sin(2 * np.pi * 1.9 * t)
    k, c, F = TRUTH["k"], TRUTH["c"], TRUTH["F"]

    def field(tt: float, s: np.ndarray) -> list[float]:
        return [s[1], float(np.interp(tt, t, u)) - k * s[0] - c * s[1] - F * np.sign(s[1])]

    sol = solve_ivp(field, (0, t[-1]), [0.05, v0], t_eval=t, rtol=1e-10, atol=1e-12, max_step=DT / 4)
    x, v = sol.y
    a = u - k * x - c * v - F * np.sign(v)
    rng = np.random.default_rng(seed)
    return {"t": t, "u": u, "a": a + 0.01 * np.std(a) * rng.standard_normal(T)}


def test_an_accelerometer_under_coulomb_friction_is_known_to_jump() -> None:
    """The structural fact the fit relies on: the acceleration jumps where the friction force does, a displacement
    does not."""
    assert to_casadi(ACCELEROMETER).output_jumps == (True,)
    both = obsnl.Model(
        name="friction_both",
        states=["x", "v"],
        parameters=["k", "c", "F"],
        inputs=["u"],
        equations={"x": "v", "v": "u - k*x - c*v - F*sign(v)"},
        outputs={"x_m": "x", "a": "u - k*x - c*v - F*sign(v)"},
    )
    assert to_casadi(both).output_jumps == (False, True)


def test_where_the_model_jumps_is_proved_in_one_split(monkeypatch) -> None:
    """The compilation asked the field's jumps, its slides and each output's jumps in separate passes, each splitting
    the model again (three splits and one more per output: 7 here); now one. The answers, derived by hand for a mass
    with Coulomb friction and a kink spring ``s max(x, 0)``: the friction force jumps across ``v = 0`` with a
    component along ``v`` (the field jumps there and a sliding mode may form); ``s max(x, 0)`` is continuous across
    ``x = 0`` (no jump, no slide); a displacement and the spring's force never jump, the acceleration and the friction
    force jump with ``sign(v)``."""
    import obsnl.model.branching.jumps as jumps

    model = obsnl.Model(
        name="friction_kink",
        states=["x", "v"],
        parameters=["k", "c", "F", "s"],
        inputs=["u"],
        equations={"x": "v", "v": "u - k*x - c*v - F*sign(v) - s*Max(x, 0)"},
        outputs={"x_m": "x", "a": "u - k*x - c*v - F*sign(v) - s*Max(x, 0)", "f": "F*sign(v)", "h": "s*Max(x, 0)"},
    )
    splits = []
    real = jumps.split_branches
    monkeypatch.setattr(jumps, "split_branches", lambda m, *a, **k: splits.append(m.name) or real(m, *a, **k))
    num = to_casadi(model)
    assert len(splits) == 1
    on_v = [i for i, g in enumerate(num.signature.switching) if g in ("v", "-v")]
    on_x = [i for i, g in enumerate(num.signature.switching) if g in ("x", "-x")]
    assert len(on_v) == len(on_x) == 1 and len(num.jumps) == 2
    assert (num.jumps[on_v[0]], num.slides[on_v[0]]) == (True, True)
    assert (num.jumps[on_x[0]], num.slides[on_x[0]]) == (False, False)
    assert num.output_jumps == (False, True, True, False)


@pytest.mark.slow
def test_intervals_close_and_cover_on_an_accelerometer_under_coulomb_friction() -> None:
    """Four noise seeds, three parameters each: every fit converged, every interval closed, and the intervals cover
    the truth. Error probability: for calibrated 95 % intervals, fewer than 9 of 12 covering has probability 0.0022
    (binomial; the seeds are independent, the parameters of one seed are not, which the bound ignores)."""
    covered = 0
    for seed in range(4):
        res = obsnl.identify(ACCELEROMETER, _record(seed, 0.5), guess=GUESS, progress=False, passes=1, tuning=TUNING)
        assert res.converged, res.converged_reason
        assert res.adequacy is not None and res.adequacy.passed
        for p in res.parameters:
            lo, hi = p.interval or (None, None)
            assert lo is not None and hi is not None and lo < p.estimate < hi, (seed, p.name, p.interval)
            covered += lo <= TRUTH[p.name] <= hi
        assert res.to_dict()["refinement"]["left_out_near_jumps"]["a"] > 0
    assert covered >= 9, f"{covered} of 12 intervals cover the truth"


@pytest.mark.slow
def test_released_from_rest_with_the_velocity_known() -> None:
    """Released at ``v = 0``, the record starts on the switching surface: declared known, the initial velocity is
    held there and the fit converges with closed intervals around the truth."""
    res = obsnl.identify(
        ACCELEROMETER,
        _record(7, 0.0),
        guess=GUESS,
        progress=False,
        passes=1,
        tuning=TUNING,
        known_initial={"v": 0.0},
    )
    assert res.converged, res.converged_reason
    for p in res.parameters:
        lo, hi = p.interval or (None, None)
        assert lo is not None and hi is not None
        assert lo <= TRUTH[p.name] <= hi or abs(p.estimate / TRUTH[p.name] - 1) < 0.02, (p.name, p.interval)
