"""Many filter runs in one compiled call (``UKF.run_batch``: casadi ``map`` over runs) give the
numbers of the runs one at a time (to 1e-9), for the UKF and the DUKF, with runs that differ in
noise seed, start, process noise, gate and fixed parameters.

Data: the seed model's response to the first 150 samples of the Northridge record from scipy's
LSODA (an integrator independent of obsnl's), plus Gaussian noise with fixed seeds.
"""

from __future__ import annotations

import numpy as np
import pytest

from obsnl.errors import EstimatorError
from obsnl.estimation.codegen import log_map
from obsnl.estimation.records import read_record
from obsnl.estimation.ukf import UKF

from .conftest import ROOT
from .test_dukf import GUESS, MODEL, NUM, SCALE, _dukf
from .test_seed_models import _simulate

T = 150


def _data():
    rec = read_record(ROOT / "obsnl" / "studies" / "data" / "northridge1994_LOS270_ngawest2_accel.csv").head(T)
    t = np.arange(T) * rec.dt
    ag = lambda s: float(np.interp(s, t, rec.accel))  # noqa: E731 - linear input between samples, as the filter
    truth = {s.name: float(MODEL.values[s.name]) for s in MODEL.parameters}
    sol = _simulate(MODEL, truth, np.zeros(len(MODEL.states)), ag, t[-1])
    y = sol.sol(t)[0][:, None]
    return rec.accel[:, None], y


def _runs(f0):
    u, y = _data()
    L = f0.size
    ests, ys, us, filters = [], [], [], []
    for i, (q, gate, fixed) in enumerate([(1e-6, np.inf, ()), (1e-4, 3.0, ()), (1e-5, np.inf, ("w_h", "c_p"))]):
        rng = np.random.default_rng([11, i])
        f = f0.with_options(Q=np.diag(np.full(L, q)), R=1e-10 * (1 + i), gate=gate, fixed=fixed)
        theta0 = GUESS * np.exp(0.05 * rng.standard_normal(len(GUESS)))
        ests.append(f.initial(x0=np.zeros(5), theta0=theta0, P0=np.full(L, 0.04)))
        ys.append(y + 1e-3 * np.std(y) * rng.standard_normal(y.shape))
        us.append(u + 1e-3 * np.std(u) * rng.standard_normal(u.shape))
        filters.append(f)
    return ests, ys, us, filters


@pytest.mark.parametrize("kind", ["ukf", "dukf"])
def test_batched_runs_equal_single_runs(kind):
    coords = log_map(NUM.parameters, signs={"Delta2": -1})
    f0 = _dukf() if kind == "dukf" else UKF(NUM, dt=0.01, coordinates=coords, state_scale=SCALE, R=1e-10)
    ests, ys, us, filters = _runs(f0)
    batch = f0.run_batch(ests, ys, us, filters=filters)
    for tr, e, y, u, f in zip(batch, ests, ys, us, filters):
        one = f.run(e, y, u)
        assert not isinstance(tr, EstimatorError)
        for name in ("z", "P", "theta", "innovations", "active", "interventions", "implicit"):
            a, b = getattr(tr, name), getattr(one, name)
            np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12 * max(1.0, np.nanmax(np.abs(b))), err_msg=name)
    assert not np.allclose(batch[0].z, batch[1].z)  # the runs are really different runs


def test_batch_refuses_filters_with_another_compiled_step():
    coords = log_map(NUM.parameters, signs={"Delta2": -1})
    f0 = UKF(NUM, dt=0.01, coordinates=coords, state_scale=SCALE, R=1e-10)
    ests, ys, us, filters = _runs(f0)
    with pytest.raises(EstimatorError, match="share this filter's compiled step"):
        f0.run_batch(ests, ys, us, filters=[filters[0], filters[1], f0.with_options(substeps=8)])


def test_buffered_call_equals_casadi_call():
    """The buffer evaluation (numpy in, numpy out) returns casadi's own numbers, bit for bit, row-major."""
    import casadi as ca

    from obsnl.estimation.simulate import call

    x, P = ca.SX.sym("x", 3), ca.SX.sym("P", 3, 3)
    f = ca.Function("f", [x, P], [ca.mtimes(P, x) ** 2, ca.exp(P) * x[0], ca.tril(P)])  # a sparse output too
    rng = np.random.default_rng(1)
    xv, Pv = rng.standard_normal(3), rng.standard_normal((3, 3))
    got, want = call(f, [xv, Pv]), [np.asarray(o) for o in f(xv, Pv)]
    assert all(np.array_equal(g, w) for g, w in zip(got, want))
    assert all(g.flags.c_contiguous for g in got)
    with pytest.raises(EstimatorError, match="needs 3x3"):
        call(f, [xv, Pv[:2]])


def test_simulate_many_equals_one_at_a_time():
    """Several parameter vectors in one compiled call give the single simulations, bit for bit; a vector
    whose simulation blows up comes back as its error, the others are unaffected."""
    from obsnl.estimation.simulate import simulate, simulate_many

    u, _ = _data()
    theta = np.array([float(MODEL.values[p]) for p in NUM.parameters])
    thetas = [theta, theta * 1.05, theta * np.r_[1e12, np.ones(len(theta) - 1)]]
    x0 = np.zeros(NUM.nx)
    many = simulate_many(NUM, thetas=thetas, x0=x0, u=u, dt=0.01, substeps=4)
    for th, got in zip(thetas, many):
        try:
            one = simulate(NUM, theta=th, x0=x0, u=u, dt=0.01, substeps=4)
        except EstimatorError as exc:
            assert isinstance(got, EstimatorError) and str(got) == str(exc)
            continue
        assert np.array_equal(got.x, one.x) and np.array_equal(got.y, one.y)
    assert not isinstance(many[0], EstimatorError) and not isinstance(many[1], EstimatorError)
