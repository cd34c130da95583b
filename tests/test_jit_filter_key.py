"""One compiled filter serves records of every length: the state scaling that an identification measures
on its record (the RMS of the states simulated at the guess, :func:`obsnl.identification.setup.make_filter`)
is an input of the compiled step, not a constant of its code, so the code and the key of its library in the
disk cache (:mod:`obsnl.estimation.jitcache`) depend on the model and the filter only.

The experiment: the Coulomb-friction oscillator (Den Hartog 1931; ``models/coulomb_friction.toml``) under a
force made of two sines, identified on the first 200 and on the first 300 samples. The two set-ups measure
different scalings (checked, else the test would prove nothing); the second filter must load the library the
first one compiled, and each compiled filter must give the numbers of the uncompiled casadi Function bit for
bit (the flags of the cache keep every rounding of casadi's own evaluation; ``tests/test_compiled_numbers.py``).
"""

from __future__ import annotations


import numpy as np
import pytest

import obsnl
from obsnl.estimation import jitcache
from obsnl.estimation.accelerogram import Record
from obsnl.estimation.codegen import to_casadi
from obsnl.identification.setup import Setup, make_data, make_filter

from .conftest import MODELS, needs_cc

pytestmark = needs_cc

DT = 0.01
FIELDS = ("z", "P", "active", "innovations", "interventions", "implicit", "refined")


def _setup(num, samples: int) -> Setup:
    t = np.arange(samples) * DT
    force = 20.0 * np.sin(2 * np.pi * 1.3 * t) * np.minimum(1.0, t / 1.5) + 8.0 * np.sin(2 * np.pi * 3.1 * t)
    truth = {p: float(num.values[p]) for p in num.parameters}
    guess = {p: 1.2 * v for p, v in truth.items()}
    return Setup(model=num, record=Record("two_sines", force, DT), truth=truth, guess=guess, jit=True)


def _run(filt, setup: Setup):
    data = make_data(setup, seed=7)
    L = filt.size
    f = filt.with_options(Q=np.diag(np.r_[np.full(setup.model.nx, 1e-6), np.full(L - setup.model.nx, 1e-7)]),
                          R=(1e-3 * np.std(data.y)) ** 2)
    est = f.initial(x0=setup.x0, theta0=setup.theta_guess, P0=np.r_[np.full(setup.model.nx, 1e-4),
                                                                    np.full(L - setup.model.nx, 0.04)])
    return f.run(est, data.y, data.u)


def test_records_of_two_lengths_share_one_compiled_filter(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    monkeypatch.setenv("OBSNL_CACHE_DIR", str(cache))
    monkeypatch.setattr(jitcache, "_LOADED", {})  # as a new process: nothing loaded yet
    built = []
    real_build = jitcache._build
    monkeypatch.setattr(jitcache, "_build", lambda name, *a: built.append(name) or real_build(name, *a))
    num = to_casadi(obsnl.read_model(MODELS / "coulomb_friction.toml"))
    short, long_ = _setup(num, 200), _setup(num, 300)
    f_short, f_long = make_filter(short, "ukf"), make_filter(long_, "ukf")
    assert not np.allclose(f_short.state_scale, f_long.state_scale, rtol=1e-3)  # two different scalings

    first = _run(f_short, short)
    assert built == ["filter_step"]  # the first record compiles the filter
    libraries = sorted(p.name for p in cache.glob("filter_step_*.so"))
    assert len(libraries) == 1
    monkeypatch.setattr(jitcache, "_LOADED", {})  # a new process again: the library must come from the disk
    second = _run(f_long, long_)
    assert built == ["filter_step"]  # the second record compiled nothing
    assert sorted(p.name for p in cache.glob("filter_step_*.so")) == libraries

    for setup, filt, fast in ((short, f_short, first), (long_, f_long, second)):
        plain = _run(filt.with_options(jit=False), setup)
        assert len(fast.z) == len(setup.record.accel)
        for name in FIELDS:
            assert getattr(fast, name).tobytes() == getattr(plain, name).tobytes(), name  # every bit
        assert np.all(np.isfinite(fast.theta)) and fast.interventions[:, 3:5].sum() == 0  # nothing rejected or held
