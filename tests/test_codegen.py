"""codegen: sympy -> casadi agrees with an independent sympy -> numpy path; discrete steps converge at
their order and stay finite where the model is stiff; parameter coordinates round-trip."""

from __future__ import annotations

import tempfile

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import obsnl
from obsnl.estimation.codegen import log_map, numpy_model, parameter_map, to_casadi
from obsnl.errors import ModelError, NotSupportedError, TableError

from .conftest import MODEL_FILES, MODELS, needs_cc


@pytest.mark.parametrize("path", MODEL_FILES, ids=lambda p: p.stem)
def test_casadi_equals_lambdify(path):
    model = obsnl.read_model(path)
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
    m = obsnl.read_model(MODELS / "damage_healing_reparam.toml")
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
    z, flag, refined = (float(v) for v in num.step(0.01, method="auto", substeps=4)(*args))
    assert flag == 1.0 and refined == 0.0
    assert 0.0 < z <= 1e-5  # stable and monotone: approaches the branch z = 1e-5 from below, no overshoot
    easy = num.step(0.01, method="auto", substeps=4)([0.0], [1.0], [0.1], [0.1])
    assert float(easy[1]) == 0.0
    np.testing.assert_allclose(float(easy[0]), float(num.step(0.01, method="rk4", substeps=4)([0.0], [1.0], [0.1],
                                                                                                 [0.1])[0]))


def test_step_across_a_jump_of_the_vector_field_is_refined():
    # x' = a + b*(1 + sign(x - c))/2: the rate jumps from a to a + b where x crosses c; the exact
    # solution is piecewise linear. Plain RK4 is first order across the jump; "auto" redoes the
    # crossing substep with refine x finer substeps and flags it.
    m = obsnl.Model(name="jump", states=["x"], parameters=["a", "b", "c"], inputs=[],
                    equations={"x": "a + b*(1 + sign(x - c))/2"}, outputs={"y": "x"}, switching=["x - c"])
    num = to_casadi(m)
    a, b, x0, dt = 1.0, 3.0, 0.0, 0.01
    steps = {k: num.step(dt, method=mth, substeps=n) for k, (mth, n) in
             {"rk4": ("rk4", 4), "auto": ("auto", 4), "rk4_32": ("rk4", 32)}.items()}
    cs = (np.arange(40) + 0.5) / 40 * dt * a * 0.999  # the jump anywhere inside the step
    err = {k: np.mean([abs(float(f([x0], [a, b, c], [], [])[0]) - (c + (a + b) * (dt - c / a))) for c in cs])
           for k, f in steps.items()}
    assert err["auto"] < err["rk4"] / 6  # first order across the jump: 8x finer there
    assert err["auto"] == pytest.approx(err["rk4_32"], rel=0.05)  # only the crossing substep at 8x: as fine as 32
    c = 0.00437
    out = num.step(dt, method="auto", substeps=4)([x0], [a, b, c], [], [])
    assert (float(out[1]), float(out[2])) == (0.0, 1.0)
    calm = num.step(dt, method="auto", substeps=4)([0.5], [a, b, c], [], [])  # no crossing: plain RK4, not flagged
    assert float(calm[2]) == 0.0
    assert float(calm[0]) == pytest.approx(0.5 + (a + b) * dt, abs=1e-14)
    with pytest.raises(ModelError, match="refine"):
        num.step(dt, refine=0)
    # a kink (continuous field) is not refined: RK4 loses little there
    kink = to_casadi(obsnl.Model(name="kink", states=["x"], parameters=["a"], inputs=[],
                                 equations={"x": "1 - a*Abs(x)"}, outputs={"y": "x"}))
    assert kink.jumps == (False,)
    assert float(kink.step(dt, method="auto", substeps=4)([-0.005], [1.0], [], [])[2]) == 0.0


def test_perron_bound_bounds_the_spectral_radius():
    # Collatz-Wielandt: an upper bound of rho(|J|) >= rho(J), never above the infinity norm (of
    # |J| + eps) it starts from; deterministic random matrices (seed 3), exact property, no error probability
    from obsnl.estimation.numeric import _perron_bound
    A = ca.SX.sym("A", 5, 5)
    bound = ca.Function("b", [A], [_perron_bound(A, 5)])
    rng = np.random.default_rng(3)
    for _ in range(50):
        J = rng.normal(size=(5, 5)) * rng.lognormal(sigma=2.0, size=(5, 1))
        J[rng.random((5, 5)) < 0.3] = 0.0
        b = float(bound(np.abs(J)))
        assert b >= max(abs(np.linalg.eigvals(J))) * (1 - 1e-9)
        assert b >= max(abs(np.linalg.eigvals(np.abs(J)))) * (1 - 1e-9)
        assert b <= np.abs(J).sum(axis=1).max() + 5 * 1e-6 * np.abs(J).max() + 1e-12  # ||A + eps||_inf


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


@needs_cc
def test_jit_scratch_files_stay_out_of_the_working_directory(tmp_path, monkeypatch):
    # casadi's shell compiler writes its C source to the working directory unless told otherwise;
    # a user's folder must not collect jit_tmp*.c files (a killed run would leave them behind)
    from obsnl.estimation.jitcache import jit_directory, jit_options

    monkeypatch.chdir(tmp_path)
    x = ca.SX.sym("x")
    f = ca.Function("sq", [x], [x * x + 1.0], jit_options())
    assert float(f(3.0)) == 10.0  # compiled code computes what the expression says
    assert list(tmp_path.iterdir()) == []
    assert jit_directory().startswith(tempfile.gettempdir())
