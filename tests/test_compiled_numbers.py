"""The compiled filter gives casadi's uncompiled numbers bit for bit, and the shortcut that does not
propagate the sigma points of frozen coordinates changes no bit.

- Compiled vs uncompiled: the C code is compiled without floating-point contraction
  (``-ffp-contract=off``), so every operation is rounded as casadi's virtual machine rounds it.
  Checked on whole UKF and DUKF runs (the DUKF freezes coordinates by branch, one run holds two
  parameters fixed, the records cross the switching surfaces, so the refined substeps run too), and
  on the simulations behind the misfits and the sensitivities (one parameter vector so far off that
  every step needs the implicit fallback).
- Frozen sigma points: the Cholesky factor of ``A P A + U`` has the unit vector as the column of a
  frozen coordinate (its row and column of ``A P A`` are zero, its diagonal is 1), the mask
  ``A`` zeroes it, so that coordinate's two sigma points are the mean plus and minus an exact zero:
  the mean point. The step that copies the mean point's propagation to them is compared with the
  step that propagates them, on random means and covariances with random frozen sets.

Data: the seed model's response to the first 150 samples of the Northridge record from scipy's
LSODA (an integrator independent of obsnl's), plus Gaussian noise with fixed seeds.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from obsnl.estimation.codegen import log_map
from obsnl.estimation.ukf import UKF
from obsnl.estimation.ukf_step import build_step

from .conftest import needs_cc
from .test_batched_filter import _data, _runs
from .test_dukf import NUM, SCALE, _dukf

FIELDS = ("z", "P", "active", "innovations", "interventions", "implicit", "refined")


@pytest.mark.slow
@needs_cc
@pytest.mark.parametrize("kind", ["ukf", "dukf"])
def test_compiled_filter_runs_equal_uncompiled_runs_bit_for_bit(kind, tmp_path, monkeypatch):
    monkeypatch.setenv("OBSNL_CACHE_DIR", str(tmp_path / "cache"))
    coords = log_map(NUM.parameters, signs={"Delta2": -1})
    make = (lambda **kw: _dukf(**kw)) if kind == "dukf" else (  # noqa: E731
        lambda **kw: UKF(NUM, dt=0.01, coordinates=coords, state_scale=SCALE, R=1e-10, **kw))
    ests, ys, us, filters = _runs(make(jit=False))
    compiled = make(jit=True)
    for e, y, u, f in zip(ests, ys, us, filters):
        plain = f.run(e, y, u)
        fast = compiled.with_options(Q=f.Q, R=f.R, gate=f.gate, fixed=f.fixed).run(e, y, u)
        for name in FIELDS:
            a, b = getattr(fast, name), getattr(plain, name)
            assert a.tobytes() == b.tobytes(), name  # every bit, the sign of a zero included
    assert plain.refined.sum() > 0  # the records cross a watched switching surface inside a step


@needs_cc
def test_compiled_simulations_equal_uncompiled_ones_bit_for_bit(tmp_path, monkeypatch):
    """The simulations behind the misfits and the sensitivities: several parameter vectors at once,
    one of them far off (stiff: the implicit fallback runs)."""
    from obsnl.estimation.simulate import simulate_many

    monkeypatch.setenv("OBSNL_CACHE_DIR", str(tmp_path / "cache"))
    u, _ = _data()
    theta = np.array([float(NUM.values[p]) for p in NUM.parameters])
    thetas = [theta, theta * 1.01, theta * np.r_[np.ones(len(theta) - 3), 1e3, 1.0, 0.3]]
    runs = {jit: simulate_many(NUM, thetas=thetas, x0=np.zeros(NUM.nx), u=u, dt=0.01, substeps=4, jit=jit)
            for jit in (True, False)}
    for a, b in zip(runs[True], runs[False]):
        assert type(a) is type(b)
        if not isinstance(a, Exception):
            assert a.x.tobytes() == b.x.tobytes() and a.y.tobytes() == b.y.tobytes()
    step, x, implicit = NUM.step(0.01, substeps=4), np.zeros(NUM.nx), 0
    for k in range(len(u) - 1):  # the third vector takes the implicit fallback (tiny yield displacement)
        x, flag, _ = step(x, thetas[2], u[k], u[k + 1])
        implicit += int(flag)
    assert implicit > 0 and runs[True][0].x.any()


def test_frozen_sigma_points_are_copied_without_changing_a_bit():
    coords = log_map(NUM.parameters, signs={"Delta2": -1})
    L = NUM.nx + len(coords.names)
    steps = {skip: build_step(NUM, coords, 0.01, method="auto", substeps=4, skip_frozen=skip)
             for skip in (True, False)}
    rng = np.random.default_rng(2026)
    guess = np.log(np.abs([float(NUM.values[p]) for p in NUM.parameters]))
    copied = 0
    for trial in range(12):
        z = np.concatenate([rng.normal(0.0, 0.5, NUM.nx), guess + rng.normal(0.0, 0.2, L - NUM.nx)])
        B = rng.normal(size=(L, L))
        P = 1e-3 * (B @ B.T / L + np.eye(L))
        active = np.ones(L)
        frozen = rng.choice(np.arange(NUM.nx, L), size=int(rng.integers(0, 5)), replace=False)
        active[frozen] = 0.0
        copied += len(frozen)
        u0, u1, y = rng.normal(0.0, 2.0, 1), rng.normal(0.0, 2.0, 1), rng.normal(0.0, 0.1, 1)
        args = [z, P, u0, u1, y, active, 1e-8 * np.eye(L), 1e-6 * np.eye(1), np.array([1.0, 2.0, 0.0, np.inf]),
                np.full(L, -np.inf), np.full(L, np.inf), np.full(L, np.inf), SCALE]
        a, b = (steps[s](*[ca.DM(v) for v in args]) for s in (True, False))
        for x, w in zip(a, b):
            assert np.asarray(x).tobytes() == np.asarray(w).tobytes()
    assert copied > 0  # the shortcut was taken
