"""obsnl.design.ranking: the Cramer-Rao ranking of sensor sets and effective independence.

Every expected value is derived here: the bounds from finite differences of scipy solve_ivp simulations,
the order from the monotonicity and the scaling of the Fisher information, the effective-independence
choice from scipy's generalized eigenproblem of the chain and the projection computed with numpy.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import eigh

from obsnl import Model
from obsnl.design.ranking import effective_independence, mode_shapes, rank_sensor_sets
from obsnl.errors import OptionError

K, C, B = 4.0, 0.3, 2.0
DT, T = 0.05, 240
TIMES = np.arange(T) * DT
U = np.sin(1.3 * TIMES) + 0.5 * np.sin(3.1 * TIMES + 0.4)


def oscillator(output: str) -> Model:
    """x'' = b u - k x - c x', measured through ``output``."""
    return Model(name="osc", states=["x", "v"], parameters=["k", "c", "b"], inputs=["u"],
                 equations={"x": "v", "v": "b*u - k*x - c*v"}, outputs={"y": output},
                 values={"k": K, "c": C, "b": B})


def scipy_output(theta: np.ndarray, x0: np.ndarray, output: str) -> np.ndarray:
    """The output along the record by LSODA (input linear between samples, as obsnl assumes)."""
    k, c, b = theta

    def rhs(t, s):
        return [s[1], b * np.interp(t, TIMES, U) - k * s[0] - c * s[1]]

    sol = solve_ivp(rhs, (0.0, TIMES[-1]), x0, method="LSODA", t_eval=TIMES, rtol=1e-11, atol=1e-13, max_step=DT)
    x, v = sol.y
    return x if output == "x" else b * U - k * x - c * v


@pytest.mark.parametrize("output", ["x", "b*u - k*x - c*v"])
@pytest.mark.parametrize("estimate_x0", [False, True])
def test_the_bound_of_one_sensor_matches_finite_differences_of_scipy(output, estimate_x0):
    theta, x0 = np.array([K, C, B]), np.zeros(2)
    y = scipy_output(theta, x0, output)
    cols = []
    for i in range(3):  # d y / d log theta_i, central differences
        h = 1e-5
        up, dn = theta.copy(), theta.copy()
        up[i] *= np.exp(h)
        dn[i] *= np.exp(-h)
        cols.append((scipy_output(up, x0, output) - scipy_output(dn, x0, output)) / (2 * h))
    if estimate_x0:
        for i in range(2):
            e = np.eye(2)[i] * 1e-5
            cols.append((scipy_output(theta, x0 + e, output) - scipy_output(theta, x0 - e, output)) / 2e-5)
    S = np.column_stack(cols)
    sigma = 0.01 * np.sqrt(np.mean(y ** 2))
    crb = np.linalg.inv(S.T @ S / sigma ** 2)
    expected = np.sqrt(np.diag(crb))[:3]
    got = rank_sensor_sets(oscillator(output), [["y"]], t=TIMES, inputs=U, estimate_x0=estimate_x0).rows[0]
    assert np.allclose(got.relative_std, expected, rtol=1e-3), (got.relative_std, expected)
    assert got.worst_relative_std == max(got.relative_std)
    assert got.worst == ("k", "c", "b")[int(np.argmax(expected))]
    # the log det of the parameters' information, the nuisance initial state eliminated (Schur complement)
    assert got.log_det_fim == pytest.approx(-np.linalg.slogdet(crb[:3, :3])[1], rel=1e-3)


def two_oscillators() -> Model:
    """Two masses on springs, both driven by u; a product gain a*g that only the output p reveals."""
    return Model(name="two", states=["x1", "v1", "x2", "v2"], parameters=["k1", "c1", "k2", "c2", "a", "g"],
                 inputs=["u"], equations={"x1": "v1", "v1": "u - k1*x1 - c1*v1", "x2": "v2",
                                          "v2": "u - k2*x2 - c2*v2 - 0.2*(x2 - x1)"},
                 outputs={"d1": "x1", "d2": "x2", "p": "a*g*x2", "d1_twice": "2*x1"},
                 values={"k1": 4.0, "c1": 0.3, "k2": 9.0, "c2": 0.5, "a": 1.5, "g": 0.7})


def test_an_unidentifiable_parameter_gets_an_infinite_bound_not_an_error():
    m = two_oscillators()
    r = rank_sensor_sets(m, [["d1"], ["p"], ["d1", "d2"]], t=TIMES, inputs=U)
    by = {row.sensors: dict(zip(r.parameters, row.relative_std)) for row in r.rows}
    # a and g do not reach d1 or d2; through p only their product is seen (d p / d log a = d p / d log g)
    for s in (("d1",), ("p",), ("d1", "d2")):
        assert by[s]["a"] == np.inf and by[s]["g"] == np.inf
    row = r.rows[r.position(["p"])]
    assert row.worst_relative_std == np.inf and row.log_det_fim == -np.inf
    d = json.loads(json.dumps(r.to_dict(), allow_nan=False))  # JSON-ready: an infinite bound is written as null
    assert d["rows"][r.position(["p"])]["relative_std"]["a"] is None and d["nuisance"] == ["x1", "v1", "x2", "v2"]
    # with a and g known, d1 and d2 inform the four oscillator parameters (d1 sees oscillator 2: no coupling
    # back, so d1 alone misses k2, c2)
    r = rank_sensor_sets(m, [["d1"], ["d1", "d2"]], t=TIMES, inputs=U, parameters=["k1", "c1", "k2", "c2"])
    full = r.rows[r.position(["d1", "d2"])]
    assert np.all(np.isfinite(full.relative_std))
    assert np.isinf(r.rows[r.position(["d1"])].worst_relative_std)
    assert r.rows[0].sensors == ("d1", "d2")


def test_the_order_follows_from_the_fisher_information():
    m = two_oscillators()
    params = ["k1", "c1", "k2", "c2"]
    r = rank_sensor_sets(m, [["d2"], ["d1", "d2"], ["d1_twice", "d2"]], t=TIMES, inputs=U, parameters=params)
    # a superset adds a positive semidefinite term to F: every bound shrinks, so it ranks first
    sup, sub = r.rows[r.position(["d1", "d2"])], r.rows[r.position(["d2"])]
    assert np.all(np.array(sup.relative_std) <= np.array(sub.relative_std) * (1 + 1e-9))
    assert r.position(["d2"]) == 2 and sup.log_det_fim > sub.log_det_fim
    # relative noise: an output scaled by 2 has twice the sensitivity and twice the noise std, the same bounds
    twice = r.rows[r.position(["d1_twice", "d2"])]
    assert np.allclose(twice.relative_std, sup.relative_std, rtol=1e-9)
    # ten times the noise on the only sensor: F / 100, every bound exactly 10 times larger
    loud = rank_sensor_sets(m, [["d2"]], t=TIMES, inputs=U, parameters=params, noise={"d2": 0.1}).rows[0]
    assert np.allclose(loud.relative_std, 10 * np.array(sub.relative_std), rtol=1e-9)
    assert loud.log_det_fim == pytest.approx(sub.log_det_fim - 4 * np.log(100.0))


def test_bad_requests_are_refused():
    m = two_oscillators()
    with pytest.raises(OptionError, match="not an output"):
        rank_sensor_sets(m, [["d3"]], t=TIMES, inputs=U)
    with pytest.raises(OptionError, match="choose among"):
        rank_sensor_sets(m, [["d1"]], t=TIMES, inputs=U, parameters=["kk"])
    with pytest.raises(OptionError, match="0 in"):
        rank_sensor_sets(m.replace(values={**m.values, "g": 0.0}), [["d1"]], t=TIMES, inputs=U)


# ---------------------------------------------------------------- effective independence
MASS = np.array([1.0, 1.2, 0.9, 1.1, 0.8, 1.0])
STIFF = np.array([50.0, 44.0, 40.0, 31.0, 27.0, 20.0])


def chain(kind: str, alpha: float = 0.0, beta: float = 0.0) -> tuple[Model, np.ndarray]:
    """An n-storey shear chain under a ground acceleration and its stiffness matrix; outputs the floor
    displacements (``kind="x"``) or absolute accelerations (``"a"``), Rayleigh damping C = alpha M + beta K."""
    n = len(MASS)
    Kmat = np.zeros((n, n))
    for i, k in enumerate(STIFF):  # storey i between floor i-1 (ground for i = 0) and floor i
        Kmat[i, i] += k
        if i > 0:
            Kmat[i - 1, i - 1] += k
            Kmat[i, i - 1] -= k
            Kmat[i - 1, i] -= k
    Cmat = alpha * np.diag(MASS) + beta * Kmat
    eqs, outs = {}, {}
    for i in range(n):
        force = " + ".join(f"({float(Kmat[i, j])!r})*x{j} + ({float(Cmat[i, j])!r})*v{j}" for j in range(n))
        eqs[f"x{i}"] = f"v{i}"
        eqs[f"v{i}"] = f"-({force})/{float(MASS[i])!r} - ag"
        outs[f"o{i}"] = f"x{i}" if kind == "x" else f"-({force})/{float(MASS[i])!r}"
    return Model(name="chain", states=[f"{s}{i}" for s in "xv" for i in range(n)], parameters=["unused"],
                 inputs=["ag"], equations=eqs, outputs=outs, values={"unused": 1.0}), Kmat


def numpy_efi(Psi: np.ndarray, size: int) -> tuple[list[int], list[np.ndarray]]:
    """Kammer's iteration written out: delete the smallest diagonal of the projection on the shapes' span."""
    live, history = list(range(len(Psi))), []
    while len(live) > size:
        P = Psi[live]
        E = np.diag(P @ np.linalg.inv(P.T @ P) @ P.T)
        history.append(E)
        live.pop(int(np.argmin(E)))
    return live, history


@pytest.mark.parametrize("size", [2, 3])
@pytest.mark.parametrize("kind, alpha, beta", [("x", 0.0, 0.0), ("a", 0.0, 0.0), ("a", 0.05, 0.002)])
def test_effective_independence_keeps_the_floors_of_the_projection_computed_here(size, kind, alpha, beta):
    model, Kmat = chain(kind, alpha, beta)
    w2, Phi = eigh(Kmat, np.diag(MASS))  # undamped modes; Rayleigh damping keeps these shapes
    Phi = Phi[:, :size]
    # displacement shapes are Phi; acceleration shapes are lambda^2 Phi, a scalar per mode: the span is the same
    live, history = numpy_efi(Phi, size)
    assert all(np.diff(np.sort(E))[0] > 1e-6 for E in history)  # no tie to break
    expected = tuple(f"o{i}" for i in live)
    assert effective_independence(model, size) == expected
    Psi, lam = mode_shapes(model, size)
    assert np.allclose(np.abs(lam), np.sqrt(w2[:size]), rtol=1e-8)
    cos = np.abs(np.sum(Psi * Phi, axis=0)) / (np.linalg.norm(Psi, axis=0) * np.linalg.norm(Phi, axis=0))
    assert np.allclose(cos, 1.0, atol=1e-9)


def test_effective_independence_limits():
    model, _ = chain("x")
    with pytest.raises(OptionError, match="between 1 and"):
        effective_independence(model, 7)
    assert effective_independence(model, 6) == tuple(f"o{i}" for i in range(6))
    assert effective_independence(model, 2, candidates=["o5", "o1"]) == ("o5", "o1")
