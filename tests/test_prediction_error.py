"""The prediction-error objective (``objective="prediction"``): a constant-gain predictor fitted with the parameters.

Expected answers come from derivations written here: the exact discrete solution of a drifting integrator (its input
linear between samples, so the trapezoid rule is exact), and the steady-state Kalman gain of a random walk measured
in white noise (the scalar Riccati equation solved in closed form).
"""

from __future__ import annotations

import json
import math
import subprocess
import sys

import casadi as ca
import numpy as np
import pytest

import obsnl
from obsnl.errors import OptionError
from obsnl.estimation.codegen import to_casadi
from obsnl.estimation.jitcache import compiler_available
from obsnl.estimation.simulate import call, residuals
from obsnl.identification.experiments import Tuning

DRIFT = obsnl.Model(
    name="drift", states=["x"], parameters=["b"], inputs=["u"], equations={"x": "b*u"}, outputs={"y": "x"}
)
OSCILLATOR = obsnl.Model(
    name="osc",
    states=["x", "v"],
    parameters=["k", "c"],
    inputs=["u"],
    equations={"x": "v", "v": "u - k*x - c*v"},
    outputs={"y": "x", "a": "u - k*x - c*v"},
)
T, DT, B, Q, R = 800, 0.01, 2.0, 0.5, 0.01  # samples, step, the integrator's gain, disturbance and noise levels
TUNING = Tuning(s0=0.3, q_theta=0.0, q_x=1.0)  # the filter only starts the fit: one fixed tuning, one pass


def _drifting(seed: int) -> dict[str, np.ndarray]:
    """``x' = b u + d``, ``d`` held over each step with std ``Q`` (a random walk of ``x``), ``y = x + e``, ``e`` of
    std ``R``. With ``u`` linear between samples the step is exact: ``x_{k+1} = x_k + b dt (u_k + u_{k+1}) / 2 +
    d_k dt``."""
    rng = np.random.default_rng(seed)
    t = np.arange(T) * DT
    u = np.sin(2 * np.pi * 0.7 * t) + 0.5 * np.sin(2 * np.pi * 2.3 * t)
    d = Q * rng.standard_normal(T - 1)
    x = np.r_[0.0, np.cumsum(B * DT * (u[:-1] + u[1:]) / 2 + d * DT)]
    return {"t": t, "u": u, "y": x + R * rng.standard_normal(T)}


def _kalman_gain() -> float:
    """The steady-state Kalman gain of the random walk ``x_{k+1} = x_k + w`` (``var w = q = (Q dt)^2``) measured
    as ``y = x + e`` (``var e = r = R^2``): the prior variance ``p`` solves ``p = p r / (p + r) + q``, i.e.
    ``p^2 - q p - q r = 0``, and ``K = p / (p + r)``."""
    q, r = (Q * DT) ** 2, R**2
    p = (q + math.sqrt(q * q + 4 * q * r)) / 2
    return p / (p + r)


def _forward() -> ca.Function:
    phi = ca.SX.sym("phi", 2)
    return ca.Function("forward", [phi], [ca.exp(phi)])


@pytest.mark.parametrize("jit", [False, True])
def test_predictor_jacobian_is_the_derivative_of_its_residuals(jit: bool) -> None:
    """The exact Jacobian (graph, or compiled forward sensitivities) against central differences, with a gap in
    one output (no correction there) and gains in both states from both outputs."""
    if jit and not compiler_available():
        pytest.skip("no C compiler")
    num = to_casadi(OSCILLATOR)
    n = 50
    rng = np.random.default_rng(0)
    u, y = rng.standard_normal((1, n)), rng.standard_normal((2, n))
    present = np.ones((2, n))
    present[1, 5:9] = 0.0
    args = [np.array([2.0, 0.5]), np.array([0.1, -0.2]), np.array([1.0, 3.0]), present, np.array([0.7, 1.3])]
    f = residuals(num, _forward(), 0.05, n, substeps=4, refine=2, jit=jit, predictor=True)
    z = np.r_[np.log([4.0, 0.3]), 0.2, -0.1, 0.3, -0.2, 0.1, 0.05]

    def r_at(zz: np.ndarray) -> np.ndarray:
        return np.asarray(call(f, [zz, u, y, *args])[0]).ravel()

    J = np.asarray(call(f, [z, u, y, *args])[1])
    h = 1e-6
    fd = np.column_stack([(r_at(z + h * e) - r_at(z - h * e)) / (2 * h) for e in np.eye(len(z))])
    assert np.max(np.abs(J - fd)) <= 1e-6 * max(1.0, float(np.max(np.abs(J))))


def test_a_zero_gain_or_no_sample_measured_is_the_output_error() -> None:
    """``kappa = 0``, or every sample missing (no correction anywhere), gives the free simulation's residuals."""
    num = to_casadi(OSCILLATOR)
    n = 40
    rng = np.random.default_rng(1)
    u, y = rng.standard_normal((1, n)), rng.standard_normal((2, n))
    w, x0, sc, ys = np.array([2.0, 0.5]), np.array([0.1, -0.2]), np.array([1.0, 3.0]), np.array([0.7, 1.3])
    oe = residuals(num, _forward(), 0.05, n, substeps=4, refine=2)
    pe = residuals(num, _forward(), 0.05, n, substeps=4, refine=2, predictor=True)
    phi_s = np.r_[np.log([4.0, 0.3]), 0.2, -0.1]
    expected = np.asarray(call(oe, [phi_s, u, y, w, x0, sc])[0]).ravel()
    zero_gain = np.asarray(call(pe, [np.r_[phi_s, np.zeros(4)], u, y, w, x0, sc, np.ones((2, n)), ys])[0]).ravel()
    no_sample = np.asarray(call(pe, [np.r_[phi_s, 0.3, 0.1, 0.2, 0.4], u, y, w, x0, sc, np.zeros((2, n)), ys])[0])
    np.testing.assert_allclose(zero_gain, expected, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(no_sample.ravel(), expected, rtol=1e-12, atol=1e-12)


def test_a_drifting_integrator_is_fitted_by_its_prediction_error_and_not_by_its_output_error() -> None:
    """Over 20 noise seeds: the prediction-error intervals cover the truth, adequacy passes, and the fitted gain is
    the steady-state Kalman gain; the output-error fit of the same records fails adequacy (said first).

    Error probability: for calibrated 95 % intervals, fewer than 16 of 20 covering has probability 0.0026
    (binomial); adequacy at the 1 % level failing on more than 3 of 20 right models has probability 4e-5."""
    covered = adequate = 0
    gains = []
    failed_output_error = 0
    for seed in range(20):
        data = _drifting(seed)
        res = obsnl.identify(
            DRIFT, data, guess={"b": 1.5}, objective="prediction", progress=False, passes=1, tuning=TUNING
        )
        lo, hi = res.parameters[0].interval or (None, None)
        covered += lo is not None and hi is not None and lo <= B <= hi
        adequate += bool(res.adequacy is not None and res.adequacy.passed)
        gains.append(res.refinement.predictor_gain["x"]["y"])
        if seed < 5:
            oe = obsnl.identify(DRIFT, data, guess={"b": 1.5}, progress=False, passes=1, tuning=TUNING)
            failed_output_error += bool(oe.adequacy is not None and not oe.adequacy.passed)
            assert oe.summary().splitlines()[0].startswith("NOT adequate")
    assert covered >= 16, f"{covered} of 20 intervals cover the truth"
    assert adequate >= 17, f"adequacy passed {adequate} of 20"
    # the gain's spread over seeds is about 6 %: the mean of 20 is within 5 % of the Riccati gain
    assert abs(np.mean(gains) / _kalman_gain() - 1) < 0.05, (np.mean(gains), _kalman_gain())
    assert failed_output_error == 5


def test_a_known_initial_state_is_not_refitted_by_the_prediction_error_fit() -> None:
    res = obsnl.identify(
        DRIFT,
        _drifting(3),
        guess={"b": 1.5},
        objective="prediction",
        progress=False,
        passes=1,
        tuning=TUNING,
        known_initial={"x": 0.0},
    )
    assert res.refinement.x0["x"] == 0.0
    assert res.refinement.objective == "prediction"


@pytest.mark.parametrize("bad", ["pem", 5, None, "Prediction"])
def test_objective_takes_output_or_prediction(bad: object) -> None:
    with pytest.raises(OptionError, match="objective= takes one of 'output', 'prediction'"):
        obsnl.identify(DRIFT, _drifting(0), guess={"b": 1.5}, objective=bad, progress=False)  # type: ignore[arg-type]


def test_the_command_line_takes_the_objective(tmp_path) -> None:
    data = _drifting(1)
    csv = tmp_path / "drift.csv"
    np.savetxt(csv, np.c_[data["t"], data["u"], data["y"]], delimiter=",", header="t,u,y", comments="")
    model = tmp_path / "drift.toml"
    model.write_text(
        'name = "drift"\nstates = ["x"]\nparameters = ["b"]\ninputs = ["u"]\n[equations]\nx = "b*u"\n'
        '[outputs]\ny = "x"\n[guess]\nb = 1.5\n'
    )
    run = [sys.executable, "-m", "obsnl", "identify", str(model), "--data", str(csv), "--passes", "1"]
    bad = subprocess.run([*run, "--objective", "innovations"], capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert "--objective" in bad.stderr
    good = subprocess.run(
        [*run, "--objective", "prediction", "--out", str(tmp_path / "fit")], capture_output=True, text=True, timeout=300
    )
    assert good.returncode == 0, good.stderr
    out = json.loads((tmp_path / "fit" / "identify.json").read_text())
    assert out["refinement"]["objective"] == "prediction"
    assert out["adequacy"]["passed"] is True
    (b,) = [p for p in out["parameters"] if p["name"] == "b"]
    lo, hi = b["interval"]
    assert lo <= B <= hi
