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
