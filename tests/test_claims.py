"""What a result claims must not exceed what it knows: the headline probability of an analysis, the printed
interval of an estimate, the Cramér-Rao bound of a weakly informed parameter, the holding of the Monte-Carlo
replicates. Exact checks on deterministic seeds: no error probability to state."""

from __future__ import annotations

import numpy as np
import pytest

import obsnl
from obsnl.identification import experiments, replicates
from obsnl.identification.practical import crb
from obsnl.report.identification.run import _digits

from .conftest import MODELS


def test_the_headline_probability_covers_the_joint_verdict_too():
    # "P(all verdicts right)" is a union bound over every verdict printed: each branch's and the joint one's. It
    # was the branches' alone (1 - 3.3e-15 on the Bouc-Wen spring while the joint line said 1 - 1.3e-13)
    model = obsnl.read_model(MODELS / "bouc_wen.toml")
    r = obsnl.analyze(model, seed=0)
    branches_alone = obsnl.analyze(model, seed=0, joint=False)  # the same branches, the same seed
    assert r.joint is not None and r.joint.probability < 1.0 and branches_alone.joint is None
    failures = (1 - r.joint.probability) + (1 - branches_alone.probability)
    assert r.probability <= min(r.joint.probability, branches_alone.probability)
    assert abs((1 - r.probability) - failures) <= 1e-15 + 1e-9 * failures


def test_printed_interval_ends_keep_their_side_of_the_truth():
    # [1321.12, 1329.986] printed to 4 digits reads [1321, 1330]: it would seem to hold the truth 1330 it misses
    assert _digits((1321.12, 1329.986), 1330.0) == 6
    d = _digits((1321.12, 1329.986), 1330.0)
    assert float(f"{1329.986:.{d}g}") < float(f"{1330.0:.{d}g}")
    # ends that 4 digits would merge are printed apart; an open end does not matter; no truth: 4 digits
    assert _digits((2.00001, 2.00003), None) == 6
    assert _digits((None, 5.0), 4.99999) == 6 and _digits((0.9, 1.1), None) == 4


def test_the_cramer_rao_bound_never_drops_a_weakly_informed_parameter():
    # two parameters with orthogonal sensitivities of very different size: F = diag(|S1|^2, |S2|^2) and the bound
    # of each is exactly 1/|S_i|. A pseudo-inverse with a relative cut of 1e-12 dropped the second as if it
    # carried no information and returned 0 for it: the least informed parameter looked the best known.
    S = np.zeros((600, 2))
    S[::2, 0] = 1e7
    S[1::2, 1] = 5e-3
    bound = crb(S.T @ S)
    assert bound == pytest.approx([1 / np.linalg.norm(S[:, 0]), 1 / np.linalg.norm(S[:, 1])], rel=1e-9)
    assert np.linalg.pinv(S.T @ S, rcond=1e-12)[1, 1] == 0.0  # the old way: the weak parameter lost
    # and for any Fisher matrix, the bound is at least 1 / sqrt(F_ii) (the information of i alone)
    rng = np.random.default_rng(4)
    for _ in range(20):
        A = rng.standard_normal((50, 4)) * 10.0 ** rng.uniform(-6, 6, 4)
        F = A.T @ A
        assert np.all(crb(F) >= (1 - 1e-9) / np.sqrt(np.diag(F)))
    # a direction nothing informs: infinite
    assert np.isinf(crb(np.array([[1.0, 2.0], [2.0, 4.0]]))).all()


def test_the_monte_carlo_replicates_hold_only_what_the_reported_run_holds(monkeypatch):
    # identify's replicates repeat the reported run's protocol: with hold=False (the default) they must not hold
    # a parameter after their first pass, as run_passes's own default (the seed paper's protocol) does
    from .test_likelihood import MSD, msd_data, setup_of

    u, y, sigma = msd_data(seed=0, T=50)
    setup, data = setup_of(MSD, u, y, 0.02, {"k": 18.0, "c": 1.2}, sigma)
    seen = []

    def spy(*args, **kwargs):
        seen.append((kwargs.get("fix_flagged"), kwargs.get("hold_below")))
        raise obsnl.errors.EstimatorError("stop here")

    monkeypatch.setattr(experiments, "run_passes", spy)
    for fix, below in ((False, None), (True, 1.5)):
        seen.clear()
        outcomes = experiments.mc_replicates(setup, None, data, data.y, None, passes=2, seed=0, indices=range(3),
                                             fix_flagged=fix, hold_below=below)
        assert seen == [(fix, below)] * 3 and outcomes == [(None, ())] * 3
    # the workers' task hands them on
    got = []
    monkeypatch.setattr(replicates, "rebuild", lambda recipe: (setup, None))
    monkeypatch.setattr(replicates, "mc_replicates", lambda *a, **kw: got.append((kw["fix_flagged"], kw["hold_below"])))
    replicates.replicates_task((None, (1.0, 1.0), data.u, data.y, data.y, None, 2, 0, (0,), False, 1.5))
    assert got == [(False, 1.5)]
