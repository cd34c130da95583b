"""Issue 25, item 6: every result value has a one-line ``repr`` (at most 160 characters, the class name and
its headline) and a short ``summary()`` (at most 12 lines, the answer first). Before, ``repr`` was the
dataclass dump: 2.5-6 kB for an analysis, every array of a filter run.

Cheap results come from the functions that make them; the expensive ones (a filter run, an identification,
a maximum-likelihood fit) are built by hand with the fields such runs fill, many parameters included, so
that the cut to one line and to a dozen lines is exercised too.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import obsnl
from obsnl.estimation.measured import measured
from obsnl.estimation.accelerogram import Record
from obsnl.estimation.simulate import Simulation
from obsnl.estimation.trajectory import Estimate, Trajectory
from obsnl.estimation.ukf_step import INTERVENTIONS
from obsnl.identification.refine import Refinement
from obsnl.identification.practical import Practical, Spread
from obsnl.identification.profile import Profile
from obsnl.identification.results import Identification, ParameterEstimate, RecordSummary
from obsnl.identification.setup import Tuning
from obsnl.linear.bank import BankDecision, Detection
from obsnl.linear.systems import LinearSystem, claim
from obsnl.observability.results import AnalysisResult
from obsnl.observability.verdicts import BranchResult, Verdict
from obsnl.recombination.fields import same_field

BILINEAR = obsnl.Model(
    name="bilinear", states=["x", "v"], parameters=["c", "k", "alpha", "x_y"], inputs=["u"],
    equations={"x": "v", "v": "u - c*v - k*x + (1 - alpha)*k*Max(x - x_y, 0)"}, outputs={"y": "x"})
# x' = -a b x, y = x: x and a*b are identifiable, a and b apart are not (the scaling a d/da - b d/db)
PRODUCT = obsnl.Model(name="product", states=["x"], parameters=["a", "b"], equations={"x": "-a*b*x"},
                      outputs={"y": "x"})
MANY = [f"p{i}" for i in range(40)]  # a result over many parameters must still fit one line / a dozen lines


def _check(value: object, headline: str, first: str) -> None:
    """One line of at most 160 characters naming the class and ``headline``; a summary of at most 12
    lines whose first line holds ``first``."""
    r = repr(value)
    assert "\n" not in r and len(r) <= 160, r
    assert r.startswith(f"{type(value).__name__}("), r
    assert headline in r, r
    s = value.summary()
    lines = s.splitlines()
    assert s.endswith("\n") and 1 <= len(lines) <= 12, s
    assert all(len(line) <= 160 for line in lines), s
    assert first in lines[0], s


@pytest.fixture(scope="module")
def bilinear() -> AnalysisResult:
    return obsnl.analyze(BILINEAR, seed=0)


def test_analysis_branch_and_joint(bilinear):
    _check(bilinear, "joint='jointly identifiable: all; only jointly: alpha, x_y'", "bilinear: 2 branches")
    assert bilinear.summary().splitlines()[1] == "jointly identifiable: all; only jointly: alpha, x_y"
    assert repr(bilinear).endswith("branches=2, P=1)")
    (elastic,) = [b for b in bilinear.branches if "alpha" in b.absent]
    _check(elastic, "unobservable='alpha, x_y'", f"branch ({elastic.label})")
    _check(bilinear.joint, "'jointly identifiable: all'", "bilinear: jointly identifiable: all")


def test_a_big_analysis_is_cut_to_one_line_and_a_dozen():
    names = tuple(f"q{i}" for i in range(300))
    branches = tuple(BranchResult(label=f"b{i}", guard=f"q{i} > 0", observable=names[:10], unobservable=names[10:],
                                  absent=(), rank=10, size=300, transcendence_degree=290, seconds=0.1)
                     for i in range(20))
    big = AnalysisResult(model="big", method="orc", seed=None, probability=None, seconds=1.0, branches=branches,
                         variables=names, parameters=names)
    assert len(repr(big)) <= 160 and big.summary().count("\n") <= 12
    _check(big, "model='big'", "big: 20 branches")
    _check(branches[0], "label='b0'", "branch (b0) q0 > 0")


def test_symmetries_and_recombination():
    sym = obsnl.symmetries(PRODUCT, seed=0)
    _check(sym, "missing=0", "product: 1 unobservable direction, every one generated (complete)")
    (g,) = sym.generators
    _check(g, "'a*d/da - b*d/db'", "scaling a*d/da - b*d/db")
    rep = obsnl.reparametrize(PRODUCT, seed=0)
    _check(rep, "original='product'", "product -> product_reparam: every new coordinate observable")
    f = obsnl.identifiable_functions(PRODUCT, seed=0)
    _check(f, "functions='x, a*b'", "product: 2 identifiable functions of rank 2")
    same = same_field(["a*b", "x"], ["2*a*b", "x"], ["a", "b", "x"], seed=0)
    _check(same, "same=True", "the same field")
    _check(same_field(["a*b"], ["a", "b"], ["a", "b"], seed=0), "same=False", "B contains A")


def test_estimation_values():
    t = np.arange(50) * 0.1
    sim = Simulation(t=t, x=np.c_[np.sin(t), np.cos(t)], y=np.c_[2 * np.sin(t)], states=("x", "v"), outputs=("y",))
    _check(sim, "samples=50", "simulation of 50 samples")
    assert "peak |output|: y 2" in sim.summary()
    L = 2 + len(MANY)
    est = Estimate(k=49, z=np.zeros(L), P=np.eye(L), x=np.zeros(2), theta=np.arange(len(MANY), dtype=float),
                   active=np.ones(L, bool))
    _check(est, "k=49", "estimate after step 49")
    T = len(t)
    traj = Trajectory(t=t, z=np.zeros((T, L)), P=np.tile(np.eye(L), (T, 1, 1)), x=np.zeros((T, 2)),
                      theta=np.ones((T, len(MANY))), y_pred=np.zeros((T, 1)), innovations=np.zeros((T, 1)),
                      S=np.zeros((T, 1, 1)), signs=np.zeros((T, 1)), active=np.ones((T, L), bool),
                      interventions=np.zeros((T, len(INTERVENTIONS)), int), implicit=np.zeros(T, int),
                      refined=np.zeros(T, int), seconds=0.5, names=("x", "v", *(f"log_{p}" for p in MANY)),
                      parameters=tuple(MANY), states=("x", "v"))
    _check(traj, "samples=50", "filter run over 50 samples")
    rec = Record("quake", np.sin(t), 0.1, source="quake.csv")
    _check(rec, "name='quake'", "record quake: 50 samples at dt = 0.1 s")
    data = measured({"t": t, "f": np.ones(50), "x": t}, inputs=["f"], outputs=["x"], name="lab")
    _check(data, "inputs='f'", "measured lab: 50 samples")


def test_linear_values():
    sys = LinearSystem([[0, 1], [-4, 0]], [[0], [1]], [[1, 0]])
    _check(sys, "states=2", "linear system: 2 states")
    _check(obsnl.kalman_rank([[-1, 0], [0, -2]], [[1, 0]]), "rank=1/2", "unobservable: Kalman rank 1 of 2")
    # the second mode of diag(-1, -2) never reaches y = x1: unobservable, but stable (detectable)
    _check(obsnl.hautus([[-1, 0], [0, -2]], [[1, 0]]), "verdict='unobservable'", "unobservable: some mode")
    for v in Verdict:
        assert v.summary().startswith(f"{v.value}:") and "\n" not in v.summary()
    for v in (Verdict.OBSERVABLE, Verdict.WEAK, Verdict.UNOBSERVABLE):  # what the linear tests answer
        assert claim(v).startswith(f"{v.value}:") and "mode" in claim(v)
    for v in Detection:
        assert v.summary().startswith(f"{v.value}:") and "\n" not in v.summary()
    d = BankDecision(labels=("c1", "c2"), detected=True, false_alarm=False, t_detect=1.5, time_to_detection=0.5,
                     by_magnitude="c1", by_residual="c1", margin=3.2, rms_force=(2.0, 0.6), rms_residual=(0.1, 0.3),
                     outcome=Detection.LOCATED, reason="largest force at c1 (margin 3.20), residual rule agrees")
    _check(d, "located_at='c1'", "located:")


def _estimates() -> tuple[ParameterEstimate, ...]:
    return tuple(ParameterEstimate(name=p, guess=1.0, estimate=None if i == 1 else 1.0 + i, std=0.1,
                                   held=i == 1, flagged=i == 2, reason="Cramer-Rao std 9 %" if i == 2 else None,
                                   true=1.0, error=100.0 * i, error_kind="percent") for i, p in enumerate(MANY))


def test_identification_values():
    p = _estimates()
    _check(p[0], "p0=1 (std 0.1)", "p0 = 1 (std 0.1); true 1, error 0 %")
    _check(p[1], "p1=held at 1", "p1 held at its guess 1")
    _check(p[2], "flagged", "flagged: Cramer-Rao std 9 %")
    run = Identification(model="storey", mode="simulation", method="dukf", parameters=p, fit={"a": 1.2}, passes=3,
                         passes_run=3, seconds=12.0, converged=True, output_misfit=1.1, noise={}, tuning=Tuning(0.3, 0.0, 1.0),
                         tuning_scores=(), data=RecordSummary(name="d", dt=0.01, samples=100), practical=None,
                         assumptions=())
    _check(run, "model='storey'", "storey: simulation, dukf, 3 of 3 passes, converged")
    assert "flagged (poorly informed by these data): p2" in run.summary()
    n = len(MANY)
    practical = Practical(parameters=tuple(MANY), crb=(0.1,) * n, sensitivity=(1.0,) * n, posterior=(0.9,) * n,
                          flagged=tuple(MANY), reasons={q: "posterior std 90 % of the prior" for q in MANY})
    _check(practical, "flagged='p0, p1, p2, p3, p4, p5, ... (+34 more)'", "40 flagged")
    spread = Spread(parameters=tuple(MANY), std=(0.02,) * n, lower=(0.01,) * n, upper=(0.03,) * n, replicates=20,
                    diverged=1, confidence=0.95, seed=0)
    _check(spread, "replicates=20", "Monte-Carlo spread over 20 replicates (1 diverged")
    _check(practical.with_spread(spread), "monte_carlo=20 replicates", "practical identifiability of 40 parameters")
    ref = Refinement(theta=np.ones(n), x0=np.zeros(2), std=np.full(n, 0.01), cov=np.eye(n + 2), sigma=np.ones(1),
                     misfit={"a": 1.01}, chi2=98.5, converged=True, reason="Newton decrement below 1e-8", iterations=7)
    _check(ref, "chi2=98.5", "maximum likelihood: converged (Newton decrement below 1e-8)")
    prof = Profile(name="c", estimate=0.3, interval=(0.29, None), shape="open-high", points=((0.3, 0.0),),
                   evaluations=40)
    _check(prof, "interval=[0.29, open]", "c = 0.3, 95 % profile-likelihood interval [0.29, open] (open-high")


def test_equality_is_unchanged(bilinear):
    # a repr of its own changes nothing else: equality still compares the fields
    assert replace(bilinear) == bilinear and replace(bilinear, model="other") != bilinear
    a = ParameterEstimate("c", 1.0, 2.0, 0.1, False, False)
    assert a == replace(a) and a != replace(a, estimate=2.5) and hash(a) == hash(replace(a))
