"""UKF: equals a plain Kalman filter on a linear model (the unscented transform is exact there);
shapes of its values; bad input refused with errors that name the fix."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

import obsnl
from obsnl.estimation.codegen import log_map, to_casadi
from obsnl.errors import DataError, EstimatorError
from obsnl.estimation.ukf import UKF

A = np.array([[0.0, 1.0], [-4.0, -0.4]])
B = np.array([[0.0], [1.0]])
C = np.array([[1.0, 0.0]])


def _linear_model():
    return obsnl.Model(name="lin", states=["x", "v"], parameters=[], inputs=["u"],
                       equations={"x": "v", "v": "-4*x - 2*v/5 + u"}, outputs={"y": "x"})


def _foh(dt):
    """Exact discretisation with the input linear between samples: x+ = Ad x + G0 u0 + G1 u1."""
    n, m = B.shape
    M = np.zeros((n + 2 * m, n + 2 * m))
    M[:n, :n], M[:n, n:n + m], M[n:n + m, n + m:] = A * dt, B * dt, np.eye(m)
    E = expm(M)
    Ad, g1, g2 = E[:n, :n], E[:n, n:n + m], E[:n, n + m:]
    return Ad, g1 - g2, g2


def _kalman(x0, P0, ys, us, Q, R, dt):
    Ad, G0, G1 = _foh(dt)
    x, P = x0.copy(), P0.copy()
    xs, Ps = [x], [P]
    for k in range(len(ys) - 1):
        x = Ad @ x + G0 @ us[k] + G1 @ us[k + 1]
        P = Ad @ P @ Ad.T + Q
        S = C @ P @ C.T + R
        K = P @ C.T @ np.linalg.inv(S)
        x = x + K @ (ys[k + 1] - C @ x)
        P = P - K @ S @ K.T
        xs.append(x)
        Ps.append(P)
    return np.array(xs), np.array(Ps)


@pytest.mark.parametrize("alpha, beta, kappa", [(1.0, 2.0, 0.0), (0.5, 2.0, 1.0)])
def test_ukf_equals_kalman_filter_on_a_linear_model(alpha, beta, kappa):
    rng = np.random.default_rng(7)  # simulated record, fixed seed
    dt, T = 0.05, 200
    us = rng.normal(size=(T, 1))
    Ad, G0, G1 = _foh(dt)
    x = np.zeros(2)
    ys = []
    for k in range(T):
        ys.append(C @ x + 0.01 * rng.normal(size=1))
        if k < T - 1:
            x = Ad @ x + G0 @ us[k] + G1 @ us[k + 1] + 1e-3 * rng.normal(size=2)
    ys = np.array(ys)
    Q, R = np.diag([1e-6, 1e-6]), np.array([[1e-4]])
    x0, P0 = np.array([0.1, -0.2]), np.diag([0.1, 0.2])
    f = UKF(to_casadi(_linear_model()), dt=dt, Q=Q, R=R, alpha=alpha, beta=beta, kappa=kappa,
            method="rk4", substeps=16)
    tr = f.run(f.initial(x0=x0, theta0=[], P0=P0), ys, us)
    xk, Pk = _kalman(x0, P0, ys, us, Q, R, dt)
    np.testing.assert_allclose(tr.x, xk, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(tr.P, Pk, rtol=1e-6, atol=1e-12)
    # the step-by-step API gives the same numbers as the compiled whole-record run
    est = f.initial(x0=x0, theta0=[], P0=P0)
    for k in range(5):
        est = f.step(est, y=ys[k + 1], u0=us[k], u1=us[k + 1])
    np.testing.assert_allclose(est.z, tr.z[5], rtol=1e-12, atol=1e-15)


def _osc_filter(**kw):
    m = obsnl.Model(name="osc", states=["x", "v"], parameters=["k", "c"], inputs=["u"],
                    equations={"x": "v", "v": "u - k*x - c*v"}, outputs={"y": "x"})
    return UKF(to_casadi(m), dt=0.05, coordinates=log_map(["k", "c"]), Q=1e-10, R=1e-6, **kw)


def test_trajectory_shapes_and_parameter_estimation():
    f = _osc_filter()
    rng = np.random.default_rng(3)  # simulated record, fixed seed
    from obsnl.estimation.simulate import simulate

    u = rng.normal(size=400)
    sim = simulate(f.model, theta=[4.0, 0.5], x0=[0.0, 0.0], u=u, dt=0.05)
    ys = sim.y + 1e-3 * rng.normal(size=sim.y.shape)
    est0 = f.initial(x0=[0.0, 0.0], theta0=[6.0, 1.0], P0=[1e-8, 1e-8, 0.25, 0.25])
    tr = f.run(est0, ys, u)
    T, L = 400, 4
    assert tr.z.shape == (T, L) and tr.P.shape == (T, L, L) and tr.theta.shape == (T, 2)
    assert tr.innovations.shape == (T, 1) and np.isnan(tr.innovations[0]).all()
    assert tr.repairs.shape == (T,) and tr.total_repairs == 0
    np.testing.assert_allclose(tr.theta[-1], [4.0, 0.5], rtol=0.02)
    assert set(tr.to_dict()) >= {"theta", "innovations", "repairs", "seconds"}
    assert np.all(np.linalg.eigvalsh(tr.P[-1]) > 0)


def test_bad_input_is_refused():
    f = _osc_filter()
    est0 = f.initial(x0=[0.0, 0.0], theta0=[6.0, 1.0], P0=[1e-8, 1e-8, 0.25, 0.25])
    ys, us = np.zeros((10, 1)), np.zeros((10, 1))
    bad = ys.copy()
    bad[4] = np.inf  # NaN in an output is a missing sample (tests/test_records_real.py); inf is refused
    with pytest.raises(DataError, match="NaN/inf at sample 4"):
        f.run(est0, bad, us)
    with pytest.raises(DataError, match="inputs contain NaN/inf at sample 4"):
        f.run(est0, ys, np.where(np.arange(10)[:, None] == 4, np.nan, us))
    with pytest.raises(DataError, match="shape"):
        f.run(est0, np.zeros((10, 2)), us)
    with pytest.raises(DataError, match="10 samples but inputs 9"):
        f.run(est0, ys, us[:9])
    with pytest.raises(EstimatorError, match="positive (semi)?definite"):
        f.initial(x0=[0.0, 0.0], theta0=[6.0, 1.0], P0=[1e-8, 1e-8, 0.25, -0.25])
    with pytest.raises(EstimatorError, match="domain"):
        f.initial(x0=[0.0, 0.0], theta0=[-6.0, 1.0], P0=[1e-8, 1e-8, 0.25, 0.25])
    with pytest.raises(EstimatorError, match="give the measurement noise"):
        UKF(f.model, dt=0.05)
    with pytest.raises(EstimatorError, match="Q must be"):
        _osc_filter().with_options(Q=np.ones(3))
    for bad_steps in ({"substeps": 0}, {"refine": 2.5}, {"refine": 0}):
        with pytest.raises(EstimatorError, match="whole number >= 1"):
            _osc_filter().with_options(**bad_steps)


def test_an_indefinite_covariance_is_repaired_and_counted():
    f = _osc_filter()
    est0 = f.initial(x0=[0.0, 0.0], theta0=[6.0, 1.0], P0=[1e-8, 1e-8, 0.25, 0.25])
    P = est0.P.copy()
    P[2, 3] = P[3, 2] = 0.3  # |correlation| > 1: not positive semidefinite
    broken = type(est0)(k=0, z=est0.z, P=P, x=est0.x, theta=est0.theta, active=est0.active)
    tr = f.run(broken, np.zeros((5, 1)), np.zeros((5, 1)))
    assert tr.repairs[1] >= 1
    assert np.all(np.isfinite(tr.P))


def test_bounds_keep_the_mean_in_the_valid_region_and_are_counted():
    f = _osc_filter()
    est0 = f.initial(x0=[0.0, 0.0], theta0=[6.0, 1.0], P0=[1e-8, 1e-8, 0.25, 0.25])
    lo, hi = np.r_[-np.inf, -np.inf, est0.z[2:] - 1e-3], np.r_[np.inf, np.inf, est0.z[2:] + 1e-3]
    g = f.with_options(bounds=(lo, hi))
    u = np.sin(np.arange(50) * 0.3)
    tr = g.run(est0, np.full((50, 1), 0.5), u)  # data far from the model: the update pushes the parameters
    assert np.all(tr.z[:, 2:] >= lo[2:] - 1e-15) and np.all(tr.z[:, 2:] <= hi[2:] + 1e-15)
    assert tr.total_repairs > 0
    with pytest.raises(EstimatorError, match="bounds"):
        f.with_options(bounds=(hi, lo))


def test_an_outlier_is_gated_or_rejected_never_nan():
    # one absurd measurement (1e150): without a gate the update throws the mean far out and the
    # following predictions overflow (rejected / held, counted); with the gate it moves 3 sigma at most
    f = _osc_filter()
    est0 = f.initial(x0=[0.0, 0.0], theta0=[6.0, 1.0], P0=[1e-8, 1e-8, 0.25, 0.25])
    u = np.sin(np.arange(40) * 0.3)
    ys = np.zeros((40, 1))
    ys[10] = 1e150
    for gate in (np.inf, 3.0):
        g = f.with_options(gate=gate)
        tr, clean = g.run(est0, ys, u), g.run(est0, np.zeros((40, 1)), u)
        assert np.all(np.isfinite(tr.z)) and np.all(np.isfinite(tr.P))
        c = tr.counts()
        if np.isinf(gate):
            assert c["gated"] == 0 and c["rejected"] + c["held"] + c["sigma"] + c["pivot"] > 0
        else:
            assert tr.interventions[10, 2] == 1 and c["rejected"] + c["held"] == 0
            np.testing.assert_array_equal(tr.z[:10], clean.z[:10])
            assert np.all(np.abs(tr.z[-1] - clean.z[-1]) < 1.0)  # recovered: near the run without the outlier
    with pytest.raises(EstimatorError, match="gate"):
        f.with_options(gate=0.0)


def test_the_covariance_ceiling_keeps_psd_and_is_counted():
    f = _osc_filter()
    est0 = f.initial(x0=[0.0, 0.0], theta0=[6.0, 1.0], P0=[1e-8, 1e-8, 0.25, 0.25])
    g = f.with_options(cap=[np.inf, np.inf, 0.1, 0.1])  # below the prior std 0.5: capped from step 1
    tr = g.run(est0, np.zeros((20, 1)), np.sin(np.arange(20) * 0.3))
    assert np.all(np.sqrt(np.diagonal(tr.P[1:], axis1=1, axis2=2))[:, 2:] <= 0.1 * (1 + 1e-12))
    assert tr.counts()["capped"] > 0
    assert all(np.linalg.eigvalsh(P).min() > 0 for P in tr.P[1:])
