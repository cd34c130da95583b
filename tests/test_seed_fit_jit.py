"""The seed study compiles its maximum-likelihood fits only when that pays (``FIT_JIT_SAMPLES``): the quick form's
one fit of 300 samples runs uncompiled, the main job's five fits of 1999 samples compiled, the filters compiled in
both. This checks the wiring, without compiling anything: ``refine_task`` hands the fit a set-up whose ``jit`` is
the spec's ``fit_jit`` (the filters' set-up keeps ``jit=True``), and ``reproduce`` sets ``fit_jit`` from the
reported seeds' samples in all.
"""

from __future__ import annotations

import numpy as np

from obsnl.errors import EstimatorError
from obsnl.estimation.accelerogram import Record
from obsnl.estimation.codegen import to_casadi
from obsnl.identification.setup import Setup
from obsnl.model.files import read_model
from obsnl.studies import seed_paper, seed_tasks

from .conftest import MODELS


def _setup() -> Setup:
    num = to_casadi(read_model(MODELS / "coulomb_friction.toml"))
    t = np.arange(100) * 0.01
    truth = {p: float(num.values[p]) for p in num.parameters}
    return Setup(model=num, record=Record("sine", 5.0 * np.sin(7.0 * t), 0.01), truth=truth, guess=truth, jit=True)


def test_refine_task_runs_the_fit_with_the_specs_fit_jit(monkeypatch):
    setup, seen = _setup(), []

    def fake_refine(s, data, theta, **kw):  # records what the fit was given, then stops it (reported, not raised)
        seen.append(s.jit)
        raise EstimatorError("stopped by the test")

    monkeypatch.setattr(seed_tasks, "context", lambda spec: {"setup": setup})
    monkeypatch.setattr("obsnl.identification.refine.refine", fake_refine)
    theta = tuple(setup.theta_true)
    for fit_jit in (False, True):
        spec = seed_tasks.Spec(record=None, samples=None, jit=True, table_json="{}", fit_jit=fit_jit)
        out = seed_tasks.refine_task((spec, 0, theta, {"method": "test"}))
        assert out.error == "stopped by the test"
    assert seen == [False, True]
    assert setup.jit  # the filters' set-up is left as it was


def test_the_threshold_separates_the_quick_form_from_the_main_job():
    """The main job's defaults (its reported seeds, the whole Northridge record) compile; the quick form's do not."""
    import inspect

    from obsnl.studies.seed_experiment import seed_record

    seeds = inspect.signature(seed_paper.reproduce).parameters["seeds"].default
    main_job = seeds * len(seed_record().accel)
    quick = seed_paper.QUICK["seeds"] * len(seed_record(samples=seed_paper.QUICK["samples"]).accel)
    assert quick < seed_paper.FIT_JIT_SAMPLES <= main_job
