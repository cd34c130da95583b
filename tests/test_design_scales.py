"""The scale search of an experiment design (``obsnl.design.experiment.design``, ``obsnl design``) where a scale's
simulation blows up, and where some targets are unidentifiable at every scale.

Every expected answer is derived here, not read from obsnl:

* **the threshold.** The gap spring is linear until the gap first closes, and under a unit step from rest its
  largest displacement is the first overshoot ``(1 + exp(-c/2 * TP)) / k`` at ``TP = pi / omega_d``; sampled so
  that ``TP`` falls on a sample, the smallest scale at which the record reaches the contact branch (where ``kc`` and
  ``g`` act) is ``g`` over that overshoot. The contact spring here is cubic, ``kc * Max(x - g, 0)**3``: negligible
  right after the gap closes (so the threshold stays the linear one), stiff far beyond it.
* **the blow-up.** The model is defined for ``x < L = 0.47`` only: its right-hand side carries
  ``1e-12*log(L - x)``, a force below 1e-10 wherever ``L - x > 1e-40`` (so the motion is the cubic gap's), not a
  number beyond ``L``. :func:`first_blow_up` integrates the cubic gap with ``solve_ivp`` (adaptive, LSODA, an event
  at ``x = L``) at every grid scale: the first scale whose motion reaches ``L`` (its peak 8 % beyond, the scale below
  peaks 10 % short) is where the simulation must leave the finite numbers, within the fine interval (a sample over
  :data:`~obsnl.design.continuous.GRID`) that follows the event's time.
* **the structural targets.** ``k1`` and ``k2`` enter the model only as the product ``k1*k2``: the flow
  ``(k1, k2) -> (l*k1, k2/l)`` leaves the equations and the output unchanged (checked with sympy below), so
  no scale of any record makes ``k1`` or ``k2`` identifiable, while the other targets keep the threshold above.
"""

from __future__ import annotations

import functools
import json

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

from obsnl import Model
from obsnl.cli import main
from obsnl.design.continuous import GRID
from obsnl.design.experiment import DEFAULT_SCALES, ScaleVisit, VisitedBranch, _search, design
from obsnl.design.experiment_search import BlowUp, ScaleBlewUp
from obsnl.errors import AnalysisError
from obsnl.report.experiment import render_design, undecided_line

VALS = {"c": 0.5, "k": 4.0, "kc": 1000.0, "g": 0.1}
TP = np.pi / np.sqrt(VALS["k"] - VALS["c"] ** 2 / 4)  # time of the first peak of the step response
T = TP / 2 * np.arange(41)  # two samples per half period: the first peak on sample 2; 10 periods
U = np.ones_like(T)
THRESHOLD = VALS["g"] / ((1 + np.exp(-VALS["c"] / 2 * TP)) / VALS["k"])  # g over the step's first overshoot
L = 0.47  # the end of the model's domain
FIELD = "u - c*v - k*x - kc*Max(x - g, 0)**3 + 1e-12*log(0.47 - x)"


def cubic_gap() -> Model:
    return Model(name="cubic_gap", states=["x", "v"], parameters=list(VALS), inputs=["u"],
                 equations={"x": "v", "v": FIELD}, outputs={"y": "x"}, values=dict(VALS))


def rhs(state: np.ndarray, u: float) -> np.ndarray:
    x, v = state
    return np.array([v, u - VALS["c"] * v - VALS["k"] * x - VALS["kc"] * max(x - VALS["g"], 0.0) ** 3])


def reaches_the_end(scale: float) -> tuple[float | None, float]:
    """The time at which the cubic gap's motion under the step ``scale`` reaches ``L`` (None: never), and its peak."""
    def at_end(t: float, z: np.ndarray) -> float:
        return z[0] - L
    sol = solve_ivp(lambda t, z: rhs(z, scale), (T[0], T[-1]), [0.0, 0.0], method="LSODA", rtol=1e-9, atol=1e-12,
                    events=at_end, dense_output=True)
    assert sol.status == 0
    hit = sol.t_events[0]
    return (float(hit[0]) if len(hit) else None), float(np.max(sol.sol(np.linspace(T[0], T[-1], 20001))[0]))


@functools.lru_cache
def first_blow_up(grid: tuple[float, ...]) -> tuple[float, float]:
    """The first grid scale whose motion reaches ``L``, and when; the premise: no scale near the edge."""
    below = None
    for s in grid:
        when, peak = reaches_the_end(s)
        if when is not None:
            assert below is not None and below < 0.95 * L < 1.05 * L < peak  # clear of the edge on both sides
            return s, when
        below = peak
    raise AssertionError("no grid scale reaches the end of the domain: the premise of the test")


def blew_up_then(time: float, when: float) -> bool:
    """Whether a blow-up reported at ``time`` is the end of the fine interval in which the motion reaches ``L``."""
    return when - 1e-9 <= time <= when + (T[1] - T[0]) / GRID + 1e-9


def test_a_scale_that_blows_up_stops_the_grid_and_the_answer_comes_from_the_scales_below() -> None:
    blown, when = first_blow_up(DEFAULT_SCALES)
    assert 1.0 < blown < DEFAULT_SCALES[-1]  # inside the default grid, well above the threshold
    d = design(cubic_gap(), [("step", T, {"u": U})])
    # the answer, from the scales that ran: the threshold within the bisection's width and the simulation's accuracy
    assert d.status == "found"
    lo, hi = d.bracket
    assert (hi - lo) / hi <= d.tol
    assert lo <= THRESHOLD * (1 + 1e-5) and THRESHOLD * (1 - 1e-5) <= hi
    # the blow-up: named with its scale, record and time; the larger grid scales not tried; no verdict for them
    (b,) = d.blowups
    assert (b.scale, b.record) == (blown, "step") and blew_up_then(b.time, when)
    assert d.skipped == tuple(s for s in DEFAULT_SCALES if s > blown)
    assert [v.scale for v in d.visits if not v.bisection] == [s for s in DEFAULT_SCALES if s < blown]
    assert d.sufficient_records == (("step",),) and d.unjudged_records == ()
    doc = json.loads(json.dumps(d.to_dict()))
    assert doc["blowups"] == [{"scale": blown, "record": "step", "time": b.time, "reason": b.reason}]
    assert doc["skipped"] == list(d.skipped) and doc["status"] == "found"
    text = render_design(d, "text")
    assert f"blew up: scale {blown:g}: the simulation of record step blew up at t = {b.time:.4g}" in text
    assert "larger scales not tried" in text and "fixed step" in text
    assert any(r.split()[:4] == [f"{blown:g}", "blew", "up", "at"] for r in text.splitlines())  # its table row
    for fmt in ("md", "tex"):
        assert f"{blown:g}" in render_design(d, fmt) and "blew up" in render_design(d, fmt)
    assert undecided_line(d) is None


def test_a_search_cut_by_a_blow_up_is_inconclusive_above_the_last_scale_that_ran() -> None:
    blown, when = first_blow_up(DEFAULT_SCALES)
    below = [0.01, 0.1]  # both below the threshold: not sufficient
    assert max(below) < THRESHOLD
    d = design(cubic_gap(), [("step", T, {"u": U})], scales=[*below, blown, 2 * blown])
    assert d.status == "inconclusive" and d.min_scale is None and d.bracket == (0.1, None)
    assert "cut by the blow-up at scale" in d.reason and f"inconclusive above {0.1:g}" in d.reason
    assert "none of the scales" not in render_design(d, "text")
    assert [v.scale for v in d.visits] == below and all(v.sufficient is False for v in d.visits)
    assert [b.scale for b in d.blowups] == [blown] and d.skipped == (2 * blown,)
    assert set(d.visits[-1].missing) == {"kc", "g"}
    assert undecided_line(d).startswith("inconclusive: no scale that ran suffices")


def test_only_a_blow_up_at_the_smallest_scale_is_an_error() -> None:
    blown, _ = first_blow_up(DEFAULT_SCALES)
    with pytest.raises(AnalysisError, match=f"blew up at the smallest scale tried, {blown:g}") as err:
        design(cubic_gap(), [("step", T, {"u": U})], scales=[blown, 2 * blown])
    assert "give smaller scales=" in str(err.value) and f"below {blown:g}" in str(err.value)


class _BlowsUpInside:
    """Stands for the simulations of a design: every scale strictly between 1 and 4 blows up."""

    def at(self, scale: float, *, bisection: bool = False) -> ScaleVisit:
        if 1.0 < scale < 4.0:
            raise ScaleBlewUp(BlowUp(scale, "r", 1.0, "blew up at t = 1"))
        return ScaleVisit(scale, (VisitedBranch((1,), None, 1.0),), {}, scale >= 4.0)


def test_the_bisection_never_takes_a_blown_up_scale_for_an_insufficient_one() -> None:
    grid = [_BlowsUpInside().at(1.0), _BlowsUpInside().at(16.0)]
    min_scale, bracket, status, reason, points = _search(_BlowsUpInside(), grid, 1e-3)
    # 4 suffices (the first point), the next point, 2, blows up: the bracket stays [1, 4], proven by scales that ran
    assert [p.scale for p in points] == [4.0]
    assert (min_scale, bracket, status) == (None, (1.0, 4.0), "inconclusive")
    assert "bisection stopped at scale 2" in reason and "[1, 4]" in reason


# --------------------------------------------------------------------------- targets no scale makes identifiable
def product_gap(**outputs: str) -> Model:
    """The gap spring with its stiffness written k1*k2 (values 2 and 2: k = 4) and a linear contact spring."""
    return Model(name="product_gap", states=["x", "v"], parameters=["c", "k1", "k2", "kc", "g"], inputs=["u"],
                 equations={"x": "v", "v": "u - c*v - k1*k2*x - kc*Max(x - g, 0)"}, outputs=outputs or {"y": "x"},
                 values={"c": 0.5, "k1": 2.0, "k2": 2.0, "kc": 40.0, "g": 0.1})


def test_the_product_is_a_symmetry() -> None:
    lam, k1, k2, x, v, u, c, kc, g = sp.symbols("lam k1 k2 x v u c kc g", positive=True)
    f = u - c * v - k1 * k2 * x - kc * sp.Max(x - g, 0)
    assert sp.simplify(f.subs({k1: lam * k1, k2: k2 / lam}, simultaneous=True) - f) == 0


def test_structurally_unidentifiable_targets_are_named_and_the_others_searched(tmp_path, capsys) -> None:
    threshold = 0.1 / ((1 + np.exp(-0.5 / 2 * TP)) / 4.0)  # the product's stiffness is 4: the threshold above
    t = TP / 20 * np.arange(101)  # the first peak on sample 20
    d = design(product_gap(), [("step", t, {"u": np.ones_like(t)})], scales=[0.01, 0.1, 1.0, 10.0])
    assert d.structural == ("k1", "k2")
    assert d.searched == ("x", "v", "c", "kc", "g")
    assert "k1, k2 are structurally unidentifiable whatever the scale" in d.structural_reason
    assert "obsnl reparametrize" in d.structural_reason
    assert d.status == "found" and d.bracket[0] <= threshold * (1 + 1e-6) and threshold * (1 - 1e-6) <= d.bracket[1]
    assert all("k1" not in v.missing and "k2" not in v.missing for v in d.visits)  # not searched, not blamed
    text = render_design(d, "text").splitlines()
    heads = [ln.split(":")[0] for ln in text if ":" in ln]
    assert heads.index("structural") < heads.index("min_scale")  # said up front
    doc = json.loads(render_design(d, "json"))
    assert doc["structural"] == ["k1", "k2"] and doc["searched"] == ["x", "v", "c", "kc", "g"]
    # every target structurally unidentifiable: nothing to search, one line (exit 2 on the command line)
    with pytest.raises(AnalysisError, match="k1, k2 are structurally unidentifiable"):
        design(product_gap(), [("step", t, {"u": np.ones_like(t)})], target="k1,k2", scales=[1.0])
    (tmp_path / "m.toml").write_text(
        'name = "product_gap"\nstates = ["x", "v"]\nparameters = ["c", "k1", "k2", "kc", "g"]\ninputs = ["u"]\n'
        '[equations]\nx = "v"\nv = "u - c*v - k1*k2*x - kc*Max(x - g, 0)"\n[outputs]\ny = "x"\n'
        '[values]\nc = 0.5\nk1 = 2.0\nk2 = 2.0\nkc = 40.0\ng = 0.1\n')
    (tmp_path / "step.csv").write_text("time_s,accel_m_s2\n" + "\n".join(f"{a:.17g},1" for a in t) + "\n")
    assert main(["design", str(tmp_path / "m.toml"), "--record", str(tmp_path / "step.csv"), "--target", "k2",
                 "--scales", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "k2 is structurally unidentifiable whatever the scale" in err


def test_the_smallest_scale_sufficing_is_worded_as_a_structural_statement() -> None:
    d = design(cubic_gap(), [("step", T, {"u": U})], scales=[1.0, 2.0])
    assert d.status == "smallest_suffices" and d.bracket == (None, 1.0)
    assert "min_scale is at most 1" in d.reason
    assert "structural statement" in d.reason and "not about noise" in d.reason


# --------------------------------------------------------------------------- the command
@pytest.fixture
def files(tmp_path):
    (tmp_path / "cubic.toml").write_text(
        'name = "cubic_gap"\nstates = ["x", "v"]\nparameters = ["c", "k", "kc", "g"]\ninputs = ["u"]\n'
        f'[equations]\nx = "v"\nv = "{FIELD}"\n[outputs]\ny = "x"\n'
        '[values]\nc = 0.5\nk = 4.0\nkc = 1000.0\ng = 0.1\n')
    (tmp_path / "step.csv").write_text("time_s,accel_m_s2\n" + "\n".join(f"{a:.17g},1" for a in T) + "\n")
    return tmp_path


def test_command_reports_the_blow_up_and_exits_2_only_when_the_search_was_cut(files, capsys) -> None:
    blown, when = first_blow_up(DEFAULT_SCALES)
    model, rec = str(files / "cubic.toml"), str(files / "step.csv")
    assert main(["design", model, "--record", rec, "--format", "json"]) == 0  # the default grid, as a user runs it
    doc = json.loads(capsys.readouterr().out)
    assert doc["status"] == "found" and [b["scale"] for b in doc["blowups"]] == [blown]
    assert blew_up_then(doc["blowups"][0]["time"], when)
    assert main(["design", model, "--record", rec, "--scales", f"0.01,0.1,{blown:.17g}"]) == 2
    out, err = capsys.readouterr()
    assert "blew up" in out and err.count("\n") == 1 and "cut by the blow-up" in err
    assert main(["design", model, "--record", rec, "--scales", f"{blown:.17g}"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "give smaller --scales" in err and "blew up" in err
