"""DUKF: the freezing rule of the branch table (no spread, no update, no process noise for frozen
coordinates), a covariance that stays positive semidefinite by construction, tables for other models
refused. The table is the seed paper's Table 1 (000_d24855f97fc8bdd4.txt) written by hand."""

from __future__ import annotations

import copy

import numpy as np
import pytest

import obsnl
from obsnl.observability.contract.branch_table import BranchTable
from obsnl.estimation.codegen import log_map, to_casadi
from obsnl.estimation.records import read_record
from obsnl.estimation.dukf import DUKF
from obsnl.estimation.ukf import UKF
from obsnl.errors import EstimatorError, TableError
from obsnl.identification.setup import coordinates
from obsnl.studies.seed_experiment import SEED_GUESS

from .conftest import MODELS
from .test_branch_table import paper_table1

MODEL = obsnl.read_model(MODELS / "damage_healing_reparam.toml")
NUM = to_casadi(MODEL)
TABLE = BranchTable.from_dict(paper_table1())
SCALE = np.array([5e-3, 0.1, 3e-3, 3e-5, 3e-5])
GUESS = np.array([SEED_GUESS[p] for p in NUM.parameters])


def _dukf(**kw):
    kw.setdefault("coordinates", log_map(NUM.parameters, signs={"Delta2": -1}))
    return DUKF(NUM, dt=0.01, table=TABLE, state_scale=SCALE, R=1e-10, **kw)


def test_frozen_coordinates_follow_the_table():
    f = _dukf()
    idx = {p: 5 + i for i, p in enumerate(NUM.parameters)}
    frozen_a = f.frozen_coordinates((1, 1))
    assert [i for i, v in enumerate(frozen_a) if v] == [idx["Delta2"]]
    frozen_b = f.frozen_coordinates((1, -1))
    assert sorted(i for i, v in enumerate(frozen_b) if v) == sorted([idx["Delta1"], idx["w_h"]])
    # yield coordinates: r_y1 freezes with Delta1, N (which also moves Delta2) stays active
    g = _dukf(coordinates=coordinates(NUM, "yield", reference=SEED_GUESS))
    names = [n for n, v in zip(g.names, g.frozen_coordinates((-1, 1))) if v]
    assert names == ["log_w_h", "log_ry_Delta1"]


def _state_in(branch_signs):
    r, x2 = 1e-3 * branch_signs[0], 0.05 * branch_signs[1]
    return np.array([1e-3, x2, r, 0.0, 0.0])


@pytest.mark.parametrize("signs, frozen", [((1, 1), ["Delta2"]), ((-1, 1), ["w_h", "Delta1"])])
def test_frozen_parameters_get_no_spread_update_or_noise(signs, frozen):
    f = _dukf().with_options(Q=np.diag(np.r_[np.full(5, 1e-8), np.full(9, 1e-6)]))
    rng = np.random.default_rng(0)  # a random full covariance, fixed seed
    M = rng.normal(size=(14, 14)) * 0.05
    est = f.initial(x0=_state_in(signs), theta0=GUESS, P0=M @ M.T + 0.01 * np.eye(14))
    nxt = f.step(est, y=[2e-3], u0=[0.5], u1=[0.6])
    idx = [5 + NUM.parameters.index(p) for p in frozen]
    active = [i for i in range(14) if i not in idx]
    assert nxt.active[idx].tolist() == [0.0] * len(idx) and nxt.active[active].min() == 1.0
    np.testing.assert_array_equal(nxt.z[idx], est.z[idx])                       # no update
    np.testing.assert_array_equal(nxt.P[np.ix_(idx, idx)], est.P[np.ix_(idx, idx)])  # no spread, no noise
    assert np.any(nxt.z[active] != est.z[active])
    # the same step with everything active (the UKF) does move them
    ukf = UKF(NUM, dt=0.01, coordinates=f.coordinates, state_scale=SCALE, R=1e-10, Q=f.Q)
    moved = ukf.step(est, y=[2e-3], u0=[0.5], u1=[0.6])
    assert np.any(moved.z[idx] != est.z[idx])


@pytest.mark.parametrize("cross", ["regression", "zero"])
def test_covariance_stays_positive_semidefinite_by_construction(cross):
    f = _dukf(cross=cross).with_options(Q=np.diag(np.r_[np.full(5, 1e-8), np.full(9, 1e-8)]))
    rng = np.random.default_rng(1)  # random covariances and branches, fixed seed
    for trial in range(6):
        signs = [(1, 1), (1, -1), (-1, -1), (-1, 1)][trial % 4]
        M = rng.normal(size=(14, 14))
        C = M @ M.T + 0.1 * np.eye(14)
        d = np.r_[np.full(5, 1e-3), np.full(9, rng.uniform(0.05, 0.3))] / np.sqrt(np.diag(C))
        P0 = C * np.outer(d, d)  # random correlations, realistic spreads
        est = f.initial(x0=_state_in(signs), theta0=GUESS, P0=P0)
        for _ in range(3):
            est = f.step(est, y=[est.x[0] + 1e-5 * rng.normal()], u0=[0.5], u1=[-0.5])
            lam = np.linalg.eigvalsh(est.P)
            assert lam.min() > -1e-12 * lam.max()


def test_a_record_with_many_switches_needs_no_repair():
    rec = read_record(MODELS.parent / "obsnl" / "studies" / "data" / "northridge1994_LOS270_ngawest2_accel.csv").head(700)
    from obsnl.estimation.simulate import simulate

    sim = simulate(NUM, theta=NUM.nominal(NUM.parameters), x0=np.zeros(5), u=rec.accel, dt=rec.dt)
    f = _dukf().with_options(R=1e-11, Q=np.diag(np.r_[np.full(5, 1e-8), np.zeros(9)]))
    est = f.initial(x0=np.zeros(5), theta0=GUESS, P0=np.r_[np.full(5, 1e-8), np.full(9, 0.04)])
    tr = f.run(est, sim.y, rec.accel)
    labels = f.branch_labels(tr.signs)
    assert {"a", "b", "c", "d"} <= set(labels)  # every branch visited at the estimated mean
    assert tr.total_repairs == 0
    assert min(np.linalg.eigvalsh(P).min() for P in tr.P) > 0


def test_with_options_refuses_a_name_that_is_not_an_option():
    # dataclasses.replace raised a TypeError for a misspelt option; the filter's class is named, and its options
    with pytest.raises(EstimatorError, match=r"^DUKF\.with_options takes the filter's options \(model, dt, .*\); 'QQ' is none$"):
        _dukf().with_options(QQ=np.eye(14))


def test_tables_for_another_model_are_refused():
    with pytest.raises(TableError, match="needs a branch table"):
        DUKF(NUM, dt=0.01, R=1.0)
    other = copy.deepcopy(paper_table1())
    other["fingerprint"] = "0" * 32
    with pytest.raises(TableError, match="fingerprint"):
        _dukf().with_options(table=BranchTable.from_dict(other))
    bw = obsnl.read_model(MODELS / "bouc_wen.toml")
    with pytest.raises(TableError, match="states"):
        DUKF(to_casadi(bw), dt=0.01, R=1.0, table=TABLE)
    swapped = to_casadi(MODEL, switching=["eta_p - r", "x2"])
    with pytest.raises(TableError, match="switching functions"):
        DUKF(swapped, dt=0.01, R=1.0, table=TABLE)
    with pytest.raises(EstimatorError, match="cross"):
        _dukf(cross="put-back")


def test_putting_frozen_rows_back_is_not_positive_semidefinite():
    """Negative control of the test above: the naive rule (update everything, then restore the frozen
    rows and columns of the old covariance) breaks positive semidefiniteness in the same trials."""
    ukf = UKF(NUM, dt=0.01, coordinates=log_map(NUM.parameters, signs={"Delta2": -1}), state_scale=SCALE,
                    R=1e-10, Q=np.diag(np.r_[np.full(5, 1e-8), np.full(9, 1e-8)]))
    f = _dukf()
    rng = np.random.default_rng(1)
    worst = np.inf
    for trial in range(6):
        signs = [(1, 1), (1, -1), (-1, -1), (-1, 1)][trial % 4]
        M = rng.normal(size=(14, 14))
        C = M @ M.T + 0.1 * np.eye(14)
        d = np.r_[np.full(5, 1e-3), np.full(9, rng.uniform(0.05, 0.3))] / np.sqrt(np.diag(C))
        est = ukf.initial(x0=_state_in(signs), theta0=GUESS, P0=C * np.outer(d, d))
        frozen = np.flatnonzero(f.frozen_coordinates(signs))
        nxt = ukf.step(est, y=[est.x[0] + 1e-5 * rng.normal()], u0=[0.5], u1=[-0.5])
        P = nxt.P.copy()
        P[frozen, :], P[:, frozen] = est.P[frozen, :], est.P[:, frozen]
        lam = np.linalg.eigvalsh(P)
        worst = min(worst, lam.min() / lam.max())
    assert worst < -1e-6
