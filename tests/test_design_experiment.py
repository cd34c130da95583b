"""Experiment design (``obsnl.design.experiment``, ``obsnl design``): the smallest record scale at which a
gap spring's parameters become identifiable, and which records suffice together.

The answers are derived here, not read from obsnl: the gap model is linear until the gap first closes,
so the smallest scale at which the record reaches the contact branch is ``g / peak``, with ``peak`` the
largest displacement of the *linear* oscillator under the record at scale 1 along its continuous trajectory
(``scipy.signal.lsim``, exact for an input linear between samples, on the samples' times where the peak falls on a
sample, else on a finer grid). Which gaps each record reaches in the
multi-record case is simulated with ``scipy.integrate.solve_ivp`` on the full nonlinear model; the
contact parameters act only in their contact branch, so a set of records suffices exactly when together
they reach every contact branch.
"""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.signal import lsim

from obsnl import Model
from obsnl.cli import main
from obsnl.design.experiment import DEFAULT_SCALES, ScaleVisit, VisitedBranch, _notes, _search, design
from obsnl.errors import AnalysisError, OptionError

GAP = {"c": 0.5, "k": 4.0, "kc": 40.0, "g": 0.1}
T = np.arange(0.0, 5.0, 0.05)  # 100 samples
U = np.sin(1.3 * T) * np.exp(-0.2 * T)  # below resonance (sqrt(k) = 2 rad/s)
#: A unit step sampled so that the first overshoot, the step response's largest value, falls on sample 20:
#: between samples the linear response stays below it, so the threshold is exactly g / peak.
TP = np.pi / np.sqrt(GAP["k"] - GAP["c"] ** 2 / 4)  # time of the first peak, pi / omega_d
T_STEP = TP / 20 * np.arange(101)
U_STEP = np.ones_like(T_STEP)


def gap_model(**outputs: str) -> Model:
    return Model(name="gap", states=["x", "v"], parameters=list(GAP), inputs=["u"],
                 equations={"x": "v", "v": "u - c*v - k*x - kc*Max(x - g, 0)"},
                 outputs=outputs or {"y": "x"}, values=dict(GAP))


def linear_threshold(u: np.ndarray, t: np.ndarray = T) -> float:
    """``g / peak``: the scale at which the linear response first reaches the gap at a time of ``t``."""
    a = [[0.0, 1.0], [-GAP["k"], -GAP["c"]]]
    _, y, _ = lsim((a, [[0.0], [1.0]], [[1.0, 0.0]], [[0.0]]), U=u, T=t)
    peak = float(np.max(y))
    assert peak > 0
    return GAP["g"] / peak


def test_min_scale_is_g_over_the_linear_peak() -> None:
    expected = linear_threshold(U_STEP, T_STEP)
    overshoot = (1 + np.exp(-GAP["c"] / 2 * TP)) / GAP["k"]  # the step response's peak, in closed form
    assert GAP["g"] / expected == pytest.approx(overshoot, rel=1e-12)  # lsim's peak is that sample's
    assert DEFAULT_SCALES[0] < expected < DEFAULT_SCALES[-1]  # inside the default bracket
    d = design(gap_model(), [("step", T_STEP, {"u": U_STEP})], tol=1e-8)
    assert d.status == "found"
    lo, hi = d.bracket
    assert (hi - lo) / hi <= d.tol == 1e-8
    assert lo <= expected * (1 + 1e-9) and expected * (1 - 1e-9) <= hi  # within the simulation's accuracy
    assert d.min_scale == hi
    grid = [v for v in d.visits if not v.bisection]
    assert [v.scale for v in grid] == list(DEFAULT_SCALES)
    for v in d.visits:  # below the threshold only the free branch, kc and g lost; above, both branches suffice
        if abs(v.scale / expected - 1) < 1e-9:  # closer than the simulation's accuracy
            continue
        below = v.scale < expected
        assert len(v.branches) == (1 if below else 2), v.scale
        assert v.sufficient is (not below)
        assert set(v.missing) == ({"kc", "g"} if below else set())
    assert d.analyses == 2  # two distinct visited sets, however many scales
    doc = json.loads(json.dumps(d.to_dict()))
    assert doc["min_scale"] == d.min_scale and doc["bracket"] == [lo, hi]
    assert doc["sufficient_records"] == [["step"]]  # scale 1 is above the threshold
    assert {"targets", "sensors", "analyses", "assumptions", "visited"} <= set(doc)


def test_the_visits_are_read_between_the_samples() -> None:
    """Under the sine the linear response peaks between samples, 4.6e-4 higher than at any sample: the threshold is
    g over the peak of the continuous response (lsim on a grid 100 times finer, the input linear between samples as
    design takes it by default), not over the peak at the sample times (issue 41: a contact between two samples is
    a visit)."""
    at_samples = linear_threshold(U)
    fine = np.arange(0.0, T[-1] + 1e-9, 0.0005)
    between = linear_threshold(np.interp(fine, T, U), fine)
    assert between < at_samples * (1 - 3e-4)
    d = design(gap_model(), [("sine", T, {"u": U})], tol=1e-4)
    assert d.status == "found"
    lo, hi = d.bracket
    assert lo <= between * (1 + 2e-5) and between * (1 - 2e-5) <= hi
    assert hi < at_samples * (1 - 2e-4)


def test_the_grid_alone_above_or_below_the_threshold_gives_no_number() -> None:
    expected = linear_threshold(U_STEP, T_STEP)
    rec = [("step", T_STEP, {"u": U_STEP})]
    above = design(gap_model(), rec, scales=[1.01 * expected, 4 * expected])
    assert (above.status, above.min_scale, above.bracket) == ("smallest_suffices", None, (None, 1.01 * expected))
    below = design(gap_model(), rec, scales=[expected / 4, 0.99 * expected])
    assert (below.status, below.min_scale, below.bracket) == ("none_suffices", None, (0.99 * expected, None))
    assert "kc, g" in below.reason


def two_gaps() -> tuple[Model, dict[str, float]]:
    vals = {"c": 0.6, "k": 4.0, "k1": 30.0, "g1": 0.2, "k2": 50.0, "g2": 0.15}
    m = Model(name="two_gaps", states=["x", "v"], parameters=list(vals), inputs=["u"],
              equations={"x": "v", "v": "u - c*v - k*x - k1*Max(x - g1, 0) - k2*Min(x + g2, 0)"},
              outputs={"y": "x"}, values=vals)
    return m, vals


def reached(vals: dict[str, float], u: np.ndarray) -> set[str]:
    """Which gaps the nonlinear model reaches at the sample times (scipy), with a margin either side."""
    def rhs(t: float, z: np.ndarray) -> list[float]:
        x, v = z
        f = vals["k1"] * max(x - vals["g1"], 0.0) + vals["k2"] * min(x + vals["g2"], 0.0)
        return [v, float(np.interp(t, T, u)) - vals["c"] * v - vals["k"] * x - f]

    x = solve_ivp(rhs, (T[0], T[-1]), [0.0, 0.0], t_eval=T, rtol=1e-10, atol=1e-12, max_step=0.01).y[0]
    out = set()
    for side, excess in (("upper", x.max() - vals["g1"]), ("lower", -vals["g2"] - x.min())):
        assert abs(excess) > 0.05 * vals["g1"], (side, excess)  # far from the threshold: no rounding decides
        if excess > 0:
            out.add(side)
    return out


def test_sufficient_records_are_the_minimal_sets_reaching_every_contact_branch() -> None:
    m, vals = two_gaps()
    ramp = np.minimum(T / 0.5, 1.0)
    records = {"pos": 1.2 * ramp, "neg": -1.0 * ramp, "small": 0.2 * np.sin(2.5 * T), "both": 2.0 * np.sin(2.5 * T)}
    reach = {name: reached(vals, u) for name, u in records.items()}
    assert reach["pos"] == {"upper"} and reach["neg"] == {"lower"} and not reach["small"]  # the premise
    expected: list[tuple[str, ...]] = []
    for size in range(1, len(records) + 1):
        for combo in itertools.combinations(records, size):
            if set().union(*(reach[n] for n in combo)) == {"upper", "lower"} and \
                    not any(set(e) <= set(combo) for e in expected):
                expected.append(combo)
    d = design(m, [(n, T, {"u": u}) for n, u in records.items()], scales=[1.0])
    assert d.sufficient_records == tuple(expected)
    assert d.undecided_records == ()
    (at1,) = d.visits
    assert {n: len(p) for n, p in at1.by_record.items()} == {n: 1 + len(reach[n]) for n in records}


def test_bad_arguments_and_the_time_limit() -> None:
    rec = ("sine", T, {"u": U})
    with pytest.raises(OptionError, match="distinct names"):
        design(gap_model(), [rec, rec])
    with pytest.raises(OptionError, match="tol"):
        design(gap_model(), [rec], tol=0.0)
    with pytest.raises(OptionError, match="scales"):
        design(gap_model(), [rec], scales=[-1.0])
    with pytest.raises(OptionError, match="not an output"):
        design(gap_model(), [rec], sensors="nope")
    with pytest.raises(AnalysisError, match="max_seconds="):
        design(gap_model(), [rec], max_seconds=1e-9)


# --------------------------------------------------------------------------- the command
MODEL_TOML = """name = "gap"
states = ["x", "v"]
parameters = ["c", "k", "kc", "g"]
inputs = ["u"]
[equations]
x = "v"
v = "u - c*v - k*x - kc*Max(x - g, 0)"
[outputs]
y = "x"
a = "v"
[values]
c = 0.5
k = 4.0
kc = 40.0
g = 0.1
"""


@pytest.fixture
def files(tmp_path):
    (tmp_path / "gap.toml").write_text(MODEL_TOML)
    rows = "\n".join(f"{t:.17g},{u:.17g}" for t, u in zip(T, U))
    (tmp_path / "sine.csv").write_text("time_s,accel_m_s2\n" + rows + "\n")
    return tmp_path


def test_command_text_json_and_figure(files, capsys) -> None:
    expected = linear_threshold(U)
    model, rec = str(files / "gap.toml"), str(files / "sine.csv")
    assert main(["design", model, "--record", rec]) == 0
    text = capsys.readouterr().out
    line = next(ln for ln in text.splitlines() if ln.startswith("min_scale: "))
    assert abs(float(line.split()[1]) - expected) <= 2e-3 * expected
    fig = files / "visits.png"
    assert main(["design", model, "--record", rec, "--format", "json", "--sensors", "y", "--target", "parameters",
                 "--figure", str(fig)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["sensors"] == ["y"] and doc["targets"] == ["c", "k", "kc", "g"]
    assert abs(doc["min_scale"] - expected) <= 1e-3 * expected
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize("extra, message", [
    ([], "--record"),
    (["--record", "missing.csv"], "missing.csv"),
    (["--record", "sine.csv", "--target", "zz"], "zz"),
])
def test_command_bad_input_is_one_line(files, capsys, monkeypatch, extra, message) -> None:
    monkeypatch.chdir(files)
    assert main(["design", "gap.toml", *extra]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and err.startswith("obsnl design: error:")


def test_command_output_is_not_overwritten_without_force(files, capsys, monkeypatch) -> None:
    monkeypatch.chdir(files)
    (files / "out.json").write_text("keep")
    args = ["design", "gap.toml", "--record", "sine.csv", "--format", "json", "--scales", "0.5,1", "-o", "out.json"]
    assert main(args) == 2
    assert "--force" in capsys.readouterr().err
    assert (files / "out.json").read_text() == "keep"
    assert main([*args, "--force"]) == 0
    assert json.loads((files / "out.json").read_text())["records"] == ["sine"]


# --------------------------------------------------------------------------- undecided verdicts, shrinking visits
def _visit(scale: float, sufficient: bool | None, *patterns: tuple[int, ...]) -> ScaleVisit:
    return ScaleVisit(scale, tuple(VisitedBranch(p, None, 1.0) for p in patterns), {}, sufficient)


class _Undecided:
    """Stands for the simulations of a design: every bisection point is undecided."""

    def at(self, scale: float, *, bisection: bool = False) -> ScaleVisit:
        return _visit(scale, None, (1,))


def test_an_undecided_verdict_is_reported_never_guessed() -> None:
    # the grid scale below the first sufficient one is undecided: no bracket end below, no number
    min_scale, bracket, status, _, points = _search(_Undecided(), [_visit(1, False), _visit(2, None),
                                                                   _visit(4, True)], 1e-3)
    assert (min_scale, bracket, status, points) == (None, (1, 4), "inconclusive", [])
    # the first bisection point is undecided: the bracket stays where the proven verdicts put it
    min_scale, bracket, status, reason, points = _search(_Undecided(), [_visit(1, False), _visit(4, True)], 1e-3)
    assert (min_scale, bracket, status, [p.scale for p in points]) == (None, (1, 4), "inconclusive", [2.0])
    assert "inconclusive" in reason
    # nothing proven sufficient, the largest scale undecided
    assert _search(_Undecided(), [_visit(1, False), _visit(2, None)], 1e-3)[1:3] == ((1, None), "inconclusive")


def test_a_visited_set_that_shrinks_with_the_scale_is_noted() -> None:
    grid = [_visit(1, False, (1,)), _visit(2, True, (1,), (-1,)), _visit(4, False, (1,))]
    notes = _notes(grid, 2)
    assert len(notes) == 2 and "scale 2 visits -" in notes[0] and "scale(s) 4" in notes[1]
    assert _notes(grid[:2], 2) == ()
