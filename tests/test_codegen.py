"""codegen: sympy -> casadi agrees with an independent sympy -> numpy path; discrete steps converge at
their order and stay finite where the model is stiff; parameter coordinates round-trip."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import obsnl
from obsnl.codegen import log_map, numpy_model, parameter_map, to_casadi
from obsnl.errors import ModelError, NotSupportedError, TableError

from .conftest import MODEL_FILES, MODELS


@pytest.mark.parametrize("path", MODEL_FILES, ids=lambda p: p.stem)
def test_casadi_equals_lambdify(path):
    model = obsnl.load_model(path)
    num = to_casadi(model)
    ref = numpy_model(model)
    rng = np.random.default_rng(0)  # random points, fixed seed
    for _ in range(5):
        x = rng.normal(size=num.nx) * 0.01
        p = np.abs(rng.normal(size=num.np)) + 0.5
        u = rng.normal(size=num.nu)
        a = np.asarray(num.f(x, p, u), float).ravel()
        b = np.asarray(ref["f"](list(x), list(p), list(u)), float).ravel()
        np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-300)
        np.testing.assert_allclose(np.asarray(num.jac_x(x, p, u), float),
                                   np.asarray(ref["jac_x"](list(x), list(p), list(u)), float), rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(np.asarray(num.h(x, p, u), float).ravel(),
                                   np.asarray(ref["h"](list(x), list(p), list(u)), float).ravel(), rtol=1e-12)


def test_nonsmooth_functions_translate():
    m = obsnl.Model(name="ns", states=["x"], parameters=["a"],
                    equations={"x": "Piecewise((a, x > 1), (-a, x < -1), (x, True)) + Heaviside(x) + Max(x, a, 0)"
                                    " + Min(x, 0) + Abs(x)*sign(x)"},
                    outputs={"y": "x"})
    num = to_casadi(m)
    for x in (-2.0, -0.5, 0.0, 0.5, 2.0):
        pw = 3.0 if x > 1 else (-3.0 if x < -1 else x)
        expect = pw + (1.0 if x > 0 else 0.0 if x < 0 else 0.5) + max(x, 3.0, 0.0) + min(x, 0.0) + abs(x) * np.sign(x)
        assert float(num.f([x], [3.0], [])) == pytest.approx(expect, abs=1e-15)


def test_switching_functions_follow_the_table_orientation():
    m = obsnl.load_model(MODELS / "damage_healing_reparam.toml")
    assert to_casadi(m).switching == ("r - eta_p", "x2")
    num = to_casadi(m, switching=["eta_p - r", "x2"])
    g = np.asarray(num.g([0, 2.0, 1.0, 3.0, 0], num.nominal(num.parameters), [0.0])).ravel()
    assert g.tolist() == [2.0, 2.0]
    with pytest.raises(TableError, match="not one of"):
        to_casadi(m, switching=["r + eta_p", "x2"])


def test_unknown_inputs_refused():
    m = obsnl.Model(name="ui", states=["x"], parameters=["a"], unknown_inputs=["w"],
                    equations={"x": "-a*x + w"}, outputs={"y": "x"})
    with pytest.raises(NotSupportedError, match="unknown inputs"):
        to_casadi(m)


def _oscillator():
    return obsnl.Model(name="osc", states=["x", "v"], parameters=["k", "c"], inputs=["u"],
                       equations={"x": "v", "v": "u - k*x - c*v"}, outputs={"y": "x"})


@pytest.mark.parametrize("method, order", [("rk4", 4), ("ros2", 2)])
def test_step_converges_at_its_order(method, order):
    num = to_casadi(_oscillator())
    p, x0, u0, u1, dt = [4.0, 0.3], [1.0, 0.0], [0.5], [-0.5], 0.5
    exact = solve_ivp(lambda t, x: np.asarray(num.f(x, p, [u0[0] + (u1[0] - u0[0]) * t / dt])).ravel(),
                      (0, dt), x0, rtol=1e-13, atol=1e-14).y[:, -1]
    errs = [np.abs(np.asarray(num.step(dt, method=method, substeps=n)(x0, p, u0, u1)[0]).ravel() - exact).max()
            for n in (8, 16)]
    assert np.log2(errs[0] / errs[1]) == pytest.approx(order, abs=0.3)


def test_stiff_step_falls_back_to_ros2():
    # a Bouc-Wen-like hysteretic variable with a tiny yield displacement (1e-5): at the yield onset
    # one RK4 substep overshoots the attracting branch and the next ones overflow
    m = obsnl.Model(name="stiff", states=["z"], parameters=["d"], inputs=["v"],
                    equations={"z": "v*(1 - d*Abs(z)**2)"}, outputs={"y": "z"})
    num = to_casadi(m)
    args = ([0.0], [1e10], [0.1], [0.1])
    rk4 = float(num.step(0.01, method="rk4", substeps=4)(*args)[0])
    assert not np.isfinite(rk4)
    z, flag = (float(v) for v in num.step(0.01, method="auto", substeps=4)(*args))
    assert flag == 1.0
    assert 0.0 < z <= 1e-5  # stable and monotone: approaches the branch z = 1e-5 from below, no overshoot
    easy = num.step(0.01, method="auto", substeps=4)([0.0], [1.0], [0.1], [0.1])
    assert float(easy[1]) == 0.0
    np.testing.assert_allclose(float(easy[0]), float(num.step(0.01, method="rk4", substeps=4)([0.0], [1.0], [0.1],
                                                                                                 [0.1])[0]))


def test_parameter_map_round_trip_and_dependencies():
    params = ["k", "Delta", "N"]
    pm = parameter_map(params, {"k": "exp(lk)", "Delta": "exp(-2*N_*lry)", "N": "N_"},
                       {"lk": "log(k)", "lry": "-log(Delta)/(2*N)", "N_": "N"},
                       check={"k": 2.0, "Delta": 1e10, "N": 2.0})
    th = np.array([2.0, 1e10, 2.0])
    np.testing.assert_allclose(pm.to_theta(pm.to_phi(th)), th, rtol=1e-12)
    assert pm.depends == (("k",), ("Delta",), ("Delta", "N"))
    with pytest.raises(ModelError, match="forward"):
        parameter_map(params, {"k": "lk"}, {"lk": "k"})
    with pytest.raises(ModelError, match="!= theta"):
        parameter_map(["k"], {"k": "exp(lk)"}, {"lk": "2*log(k)"}, check={"k": 3.0})
    lm = log_map(["a", "b"], signs={"b": -1})
    np.testing.assert_allclose(lm.to_theta(lm.to_phi([3.0, -5.0])), [3.0, -5.0])
