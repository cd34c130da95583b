"""Issue 25, item 3: typed results end to end. The structural check of an identification is a
:class:`StructuralCheck` value, :class:`Practical` stays a value inside :class:`Identification` (its JSON is
unchanged), the text of a run is rendered from the value, and one ``analyze`` checks its limits once.

Before: ``Identification.structural`` and ``.practical`` were ``Mapping[str, Any]`` (the practical check
flattened by ``to_dict()``), ``identify_text`` read ``identify.json``'s dict (the command line printed from
``to_dict()``), and one ``analyze`` ran ``check_analysis_limits`` two to three times (its own check, the joint
verdict's, the symmetry search's).
"""

from __future__ import annotations

import collections
import dataclasses
import json
import sys

import pytest

import obsnl
from obsnl.errors import AnalysisError
from obsnl.identification.practical import Practical, Spread
from obsnl.identification.results import (
    Identification,
    NoiseLevel,
    ParameterEstimate,
    RecordSummary,
    RefinementSummary,
)
from obsnl.identification.setup import Tuning
from obsnl.identification.structural import StructuralCheck, structural_check
from obsnl.observability import limits
from obsnl.observability.analyze import analyze

FRICTION = obsnl.Model(name="friction", states=["x", "v"], parameters=["c", "mu"], inputs=["u"],
                       equations={"x": "v", "v": "u - c*v - mu*sign(v)"}, outputs={"y": "x"})
DRIFT = obsnl.Model(name="drift", states=["x"], parameters=["a", "b"], inputs=["u"],
                    equations={"x": "(a + b)*u"}, outputs={"y": "x"})


# --------------------------------------------------------------------------- the structural check
def test_the_structural_check_is_a_frozen_value_with_the_json_of_the_old_dict():
    check = structural_check(analyze(FRICTION, seed=0), "friction", ["c", "mu"])
    assert isinstance(check, StructuralCheck) and check.identifiable
    assert (check.verdict, check.unidentifiable, check.branches, check.frozen_by_the_dukf) == ("joint", (), 2, ())
    with pytest.raises(dataclasses.FrozenInstanceError):
        check.verdict = "union"  # type: ignore[misc]
    # identify.json's "structural" object: the keys the dict had, in its order
    assert list(check.to_dict()) == ["verdict", "unidentifiable", "allowed", "undecided", "branches",
                                     "frozen_by_the_dukf"]
    assert check.note() == "structural analysis (joint verdict over 2 branches): every parameter identifiable"
    assert repr(check).startswith("StructuralCheck(verdict='joint'") and len(repr(check)) <= 160


def test_the_structural_check_refuses_or_names_the_unidentifiable():
    result = analyze(DRIFT, seed=0)
    with pytest.raises(AnalysisError, match="a, b of 'drift' are structurally unidentifiable"):
        structural_check(result, "drift", ["a", "b"])
    allowed = structural_check(result, "drift", ["a", "b"], allow_unidentifiable=True)
    assert allowed.unidentifiable == ("a", "b") and allowed.allowed and not allowed.identifiable
    assert allowed.to_dict()["unidentifiable"] == ["a", "b"] and "calls a, b unidentifiable" in allowed.note()
    # without the joint verdict the per-branch union is read, and said
    union = structural_check(analyze(DRIFT, seed=0, joint=False), "drift", ["a", "b"], allow_unidentifiable=True)
    assert union.verdict == "union" and union.unidentifiable == ("a", "b")


def test_the_structural_check_names_what_the_dukf_would_freeze():
    # one Bouc-Wen storey: every branch sees beta*s + gamma only (s = +1 or -1), the branches together identify
    # both; a per-branch DUKF would hold them at the guess (the same case as test_joint_analysis, from Python)
    storey = obsnl.Model(name="storey", states=["x", "v", "z"], parameters=["c", "k", "kh", "beta", "gamma"],
                         inputs=["ag"], outputs={"a": "-c*v - k*x - kh*z"},
                         equations={"x": "v", "v": "-ag - c*v - k*x - kh*z",
                                    "z": "v - beta*Abs(v)*Abs(z)*z - gamma*v*z**2"})
    result = analyze(storey, seed=0)
    table = obsnl.report.branch_table(result, storey)
    names = [p.name for p in storey.parameters]
    with pytest.raises(AnalysisError, match="beta, gamma of 'storey' are identifiable only jointly"):
        structural_check(result, "storey", names, table=table, method="dukf")
    check = structural_check(result, "storey", names, table=table, method="dukf", allow_unidentifiable=True)
    assert check.identifiable and check.frozen_by_the_dukf == ("beta", "gamma")
    assert check.to_dict()["frozen_by_the_dukf"] == ["beta", "gamma"] and "frozen by the DUKF" in check.summary()
    assert structural_check(result, "storey", names, table=table, method="ukf").frozen_by_the_dukf == ()


# --------------------------------------------------------------------------- Identification holds values
def _refinement(**changes) -> RefinementSummary:
    base = dict(method="maximum likelihood", converged=False, reason="stopped after 60 iterations", iterations=60,
                evaluations=75, newton_decrement=0.5, last_step_in_std=0.3, chi2=310.0, samples=300, seconds=2.0,
                noise_std={"y": 0.011}, misfit_over_noise={"y": 1.02}, x0={"x": 0.0, "v": 0.1},
                correlation={"k": {"k": 1.0, "c": None, "m": -0.5}}, input_noise_widening={"k": 1.0, "c": 1.0, "m": 1.2})
    return RefinementSummary(**{**base, **changes})


def _identification(**changes) -> Identification:
    params = (ParameterEstimate("k", 3.0, 2.0, 0.01, False, False, interval=(1.98, 2.02),
                                interval_method="profile likelihood"),
              ParameterEstimate("c", 0.3, None, None, True, True, reason="held at its guess: flat profile"),
              ParameterEstimate("m", 1.0, 1.1, 0.5, False, True, reason="Cramér-Rao std 40 %", true=1.0,
                                error=10.0, error_kind="percent"))
    practical = Practical(parameters=("k", "c", "m"), crb=(0.001, float("nan"), 0.4), sensitivity=(9.0, 0.0, 0.1),
                          posterior=(0.01, 1.0, 0.9), flagged=("c", "m"),
                          reasons={"c": "the filter kept 100 % of its prior std", "m": "Cramér-Rao std 40 %"})
    spread = Spread(parameters=("k", "c", "m"), std=(0.01, float("nan"), 0.3), lower=(0.005, float("nan"), 0.2),
                    upper=(0.02, float("nan"), 0.5), replicates=8, diverged=0, confidence=0.95, seed=0, held=("c",))
    base = dict(model="storey", mode="measured", method="ukf", parameters=params, fit={"y": 1.234, "z": None},
                passes=3, passes_run=2, seconds=1.5, converged=False, output_misfit=0.9,
                noise={"y": NoiseLevel(0.01, "given")}, tuning=Tuning(0.3, 0.0, 100.0),
                tuning_scores=((Tuning(0.3, 0.0, 100.0), 0.9), (Tuning(0.5, 0.0, 100.0), 1.2)),
                data=RecordSummary(name="run1", dt=0.01, samples=300), practical=practical.with_spread(spread),
                assumptions=("white noise",), structural=StructuralCheck("joint", (), False, ("m",), 2),
                converged_reason="the profile of m moved", refinement=_refinement(misfit_over_noise={"y": 1.02}))
    return Identification(**{**base, **changes})


def test_identification_keeps_practical_and_structural_as_values_and_its_json_keys():
    run = _identification()
    assert isinstance(run.practical, Practical) and run.practical.spread.replicates == 8
    assert isinstance(run.structural, StructuralCheck) and run.structural.undecided == ("m",)
    doc = json.loads(json.dumps(run.to_dict(), allow_nan=False))  # no NaN reaches the JSON
    # identify.json's keys, as before the values (tests and reports read them)
    assert list(doc) == ["schema", "model", "mode", "method", "passes", "passes_run", "seconds", "seed", "compiled",
                         "held", "flagged", "parameters", "fit", "converged", "converged_reason", "refinement", "profiles",
                         "output_misfit", "noise", "tuning", "tuning_scores", "data", "structural", "repairs",
                         "practical_identifiability", "adequacy", "modal", "assumptions"]
    assert doc["practical_identifiability"] == json.loads(json.dumps(run.practical.to_dict(), allow_nan=False))
    assert set(doc["practical_identifiability"]) == {
        "parameters", "crb_relative_std", "sensitivity_over_noise", "posterior_over_prior_std", "flagged",
        "flagged_linearised", "reasons", "inconclusive", "undecided", "monte_carlo"}
    assert doc["practical_identifiability"]["crb_relative_std"][1] is None
    assert doc["structural"] == {"verdict": "joint", "unidentifiable": [], "allowed": False, "undecided": ["m"],
                                 "branches": 2, "frozen_by_the_dukf": []}
    # the summary says the structural verdict under the run's line
    assert run.summary().splitlines()[1] == "structural analysis (joint verdict over 2 branches): every parameter " \
        "identifiable"
    # not computed: the empty objects identify.json had
    bare = _identification(practical=None, structural=None).to_dict()
    assert bare["practical_identifiability"] == {} and bare["structural"] == {}


# --------------------------------------------------------------------------- the text renders the value
#: The text of ``_identification()`` as the renderer of identify.json's dict wrote it: the value gives the same.
TEXT = """\
UKF + maximum likelihood on storey, measured data run1, 3 pass(es), 1.50 s: NOT converged: the profile of m moved
  tuning: s0 0.3, q_theta 0, q_x 100, gate off (the smallest output misfit after one pass of 2 configurations)
  stopped after pass 2: its estimate cannot be simulated (the filter diverged)
  k          estimate 2          std 0.01      95 % [1.98, 2.02]
  c          held at its guess 0.3 (not estimated): held at its guess: flat profile
  m          true 1           estimate 1.1        std 0.5       error 10.00 %  poorly informed: Cramér-Rao std 40 %
  1 parameter(s) held at their guess
  fit (NRMSE): y 1.23 %, z -
  residual RMS / the noise level the fit was given: y 1.02"""


def test_a_result_without_its_record_is_refused_before_any_file(tmp_path):
    # t, y_measured and y_fit default to None (a result built by hand, as here); write_identification says so
    # instead of failing inside matplotlib with the folder half made
    from obsnl.errors import DataError
    from obsnl.identification.identify import write_identification

    with pytest.raises(DataError, match="carries no record"):
        write_identification(_identification(), tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_identify_text_renders_the_value_as_the_json_renderer_did():
    from obsnl.report.identification import identify_text

    run = _identification()
    assert identify_text(run) == TEXT
    # without the refinement the practical check's undecided parameters are named, before the parameters
    lines = identify_text(_identification(refinement=None)).splitlines()
    assert lines[0] == "UKF on storey, measured data run1, 3 pass(es), 1.50 s: NOT converged: the profile of m moved"
    assert lines[3] == ("  k: not decided whether the record pins it within 5 %: Monte-Carlo std of the relative "
                        "error 1 % (95 % interval 0.5-2 %, 8 replicates) contains 1.7 %")
    assert lines[4:] == TEXT.splitlines()[3:-1]
    # identify.json's dict is no longer a run to render (the command line passes the value)
    with pytest.raises(TypeError, match="renders the Identification value"):
        identify_text(run.to_dict())


def test_identify_text_takes_a_run_without_practical_check_nor_tuning_choice():
    from obsnl.report.identification import identify_text

    text = identify_text(_identification(practical=None, refinement=None, tuning_scores=()))
    assert text.splitlines()[0] == "UKF on storey, measured data run1, 3 pass(es), 1.50 s: NOT converged: " \
        "the profile of m moved"
    assert "tuning:" not in text and "not decided" not in text and "  fit (NRMSE): y 1.23 %, z -" in text


# --------------------------------------------------------------------------- limits checked once
def _count_limit_checks(monkeypatch: pytest.MonkeyPatch) -> collections.Counter:
    """Wrap ``check_analysis_limits`` wherever a loaded obsnl module holds it; count the calls."""
    real = limits.check_analysis_limits
    calls: collections.Counter = collections.Counter()

    def counted(*a, **k):
        calls[a[0].name if a else k["model"].name] += 1
        return real(*a, **k)

    for name, module in list(sys.modules.items()):
        if name.startswith("obsnl") and getattr(module, "check_analysis_limits", None) is real:
            monkeypatch.setattr(module, "check_analysis_limits", counted)
    return calls


def test_one_analyze_checks_its_limits_once(monkeypatch):
    import obsnl.observability.certificates.certify as certify

    calls = _count_limit_checks(monkeypatch)
    searched = []
    real_symmetries = certify.symmetries_of
    monkeypatch.setattr(certify, "symmetries_of", lambda *a, **k: searched.append(1) or real_symmetries(*a, **k))
    analyze(FRICTION, seed=0)  # branches and the joint verdict
    assert sum(calls.values()) == 1
    calls.clear()
    analyze("obsnl:bouc_wen", seed=0)  # the joint verdict and the symmetry certificates too
    assert searched and sum(calls.values()) == 1


def test_the_analyze_command_checks_once_and_before_the_record_is_simulated(tmp_path, monkeypatch):
    """``obsnl analyze --record`` checked the limits twice (its own check, then analyze's) and a bad method only after
    the record's simulation: now the options and the limits are checked once, before the record is read."""
    import math

    import obsnl.design.continuous as continuous
    from obsnl.commands.analyze import AnalyzeRequest, run_analyze

    record = tmp_path / "rec.csv"
    record.write_text("time_s,u\n" + "".join(f"{i * 0.01:.2f},{math.sin(i * 0.05):.6f}\n" for i in range(200)),
                      encoding="utf-8")
    calls = _count_limit_checks(monkeypatch)
    checks_when_simulated = []
    real = continuous.continuous_visits

    def simulate(*a, **k):
        checks_when_simulated.append(sum(calls.values()))
        return real(*a, **k)

    monkeypatch.setattr(continuous, "continuous_visits", simulate)
    result = run_analyze(AnalyzeRequest(model="obsnl:coulomb_friction", record=record, seed=0))
    assert checks_when_simulated == [1] and sum(calls.values()) == 1
    assert result.analysis.visited.how == "record"  # the record chose the branches
    with pytest.raises(AnalysisError, match="unknown method 'newton'"):
        run_analyze(AnalyzeRequest(model="obsnl:coulomb_friction", record=record, method="newton"))
    assert checks_when_simulated == [1]  # refused before the simulation


def test_the_doors_check_once_and_the_searches_they_call_do_not(monkeypatch):
    """A context variable used to tell the inner entries whether a public call up the stack had checked; now each
    door checks once and calls the search that takes a checked model: a symmetry search over the branches checks the
    model once, not once more per branch."""
    from obsnl.observability.certificates.symmetry import branch_symmetries, symmetries
    from obsnl.observability.joint.verdict import joint_verdict

    calls = _count_limit_checks(monkeypatch)
    joint_verdict(FRICTION, seed=0)
    symmetries(DRIFT, seed=0)
    assert calls == {"friction": 1, "drift": 1}
    calls.clear()
    found = branch_symmetries(FRICTION, seed=0)  # two branches, v > 0 and v < 0
    assert len(found) == 2 and all(s is not None for _, s in found)
    assert calls == {"friction": 1}
    calls.clear()
    obsnl.reparametrize(FRICTION, seed=0)  # then it analyses the model it built: that one is checked at its doors
    assert {k: n for k, n in calls.items() if not k.startswith("friction_reparam")} == {"friction": 1}
    with pytest.raises(obsnl.errors.NotSupportedError, match="degree must be 1 or 2"):
        branch_symmetries(FRICTION, degree=3)  # the options too are checked at the door, before the split


def test_a_model_too_large_is_still_refused_before_any_work():
    # the one check is analyze's own: it still runs first
    n = limits.MAX_UNKNOWNS
    big = obsnl.Model(name="wide", states=["x"], parameters=[f"k{i}" for i in range(n)], inputs=["u"],
                      equations={"x": " + ".join(f"k{i}" for i in range(n)) + " - x + u"}, outputs={"y": "x"})
    with pytest.raises(AnalysisError, match=f"has {n + 1} unknowns .* more than the {n}"):
        analyze(big, seed=0)


# --------------------------------------------------------------------------- issue 42: the fit, noise and record
#: identify.json's "refinement" object as Refinement.to_dict wrote it before issue 42 (the fifteen keys, in order),
#: with the objective and the predictor's gain that the prediction-error objective added after "method", and the
#: samples left out next to a jump of a jumping output, last.
REFINEMENT_JSON_KEYS = ["method", "objective", "predictor_gain", "converged", "reason", "iterations", "evaluations",
                        "newton_decrement", "last_step_in_std", "chi2", "samples", "seconds", "noise_std",
                        "misfit_over_noise", "x0", "correlation", "input_noise_widening", "left_out_near_jumps"]
#: identify.json's "data" object of measured data: Measured.to_dict's keys and the inputs' intersample entries.
MEASURED_JSON_KEYS = ["name", "source", "dt", "samples", "inputs", "outputs", "clock_deviation", "clock_tolerance",
                      "missing", "ignored", "intersample"]
FORCED = obsnl.Model(name="forced", states=["x", "v"], parameters=["k", "c"], inputs=["u"],
                     equations={"x": "v", "v": "u - k*x - c*v"}, outputs={"y": "x"})


def _forced_record():
    """A mass-spring-damper (k 25, c 0.8) under a two-sine force, integrated by scipy's DOP853; 1 % output noise and
    0.5 % input noise (seed 5), output sample 10 missing, and a column the model does not use."""
    import numpy as np
    from scipy.integrate import solve_ivp

    t = np.arange(400) * 0.02
    u = np.sin(5.0 * t) + 0.5 * np.sin(11.0 * t + 0.3)
    sol = solve_ivp(lambda tt, s: [s[1], np.interp(tt, t, u) - 25.0 * s[0] - 0.8 * s[1]], (0, t[-1]), [0.0, 0.0],
                    method="DOP853", t_eval=t, rtol=1e-11, atol=1e-13, max_step=0.005)
    x = sol.y[0]
    rng = np.random.default_rng(5)
    y = x + 0.01 * np.sqrt(np.mean(x ** 2)) * rng.standard_normal(t.size)
    y[10] = np.nan
    u_measured = u + 0.005 * np.sqrt(np.mean(u ** 2)) * rng.standard_normal(t.size)
    return {"t": t, "u": u_measured, "y": y, "note": np.zeros(t.size)}


@pytest.fixture(scope="module")
def forced_run():
    """One identification with the fits it made (each Refinement refine() returned, the last the one kept)."""
    import obsnl.identification.runs as runs

    fits = []
    real = runs.refine
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(runs, "refine", lambda *a, **k: fits.append(real(*a, **k)) or fits[-1])
        res = obsnl.identify(FORCED, _forced_record(), guess={"k": 20.0, "c": 1.0}, noise={"y": 0.01},
                             passes=1, progress=False, jit=False)
    return res, fits


def test_the_fit_noise_and_record_of_a_run_are_frozen_values(forced_run):
    res, _ = forced_run
    assert isinstance(res.refinement, RefinementSummary) and isinstance(res.data, RecordSummary)
    assert all(isinstance(level, NoiseLevel) for level in res.noise.values()) and set(res.noise) == {"u", "y"}
    for value, name in ((res.refinement, "converged"), (res.data, "name"), (res.noise["y"], "ratio")):
        with pytest.raises(dataclasses.FrozenInstanceError):
            setattr(value, name, None)
    # read as attributes: the noise given for y, estimated for u (0.5 % was added; the differences estimate it, an
    # upper bound where their orders disagree)
    assert res.noise["y"].origin == "given" and res.noise["y"].ratio == 0.01 and res.noise["y"].estimate is None
    u = res.noise["u"]
    assert u.origin == ("upper bound" if u.upper_bound else "estimated") and 0.002 < u.estimate < 0.01
    assert res.refinement.objective == "output" and res.refinement.predictor_gain is None
    assert set(res.refinement.x0) == {"x", "v"} and res.refinement.samples == 399  # sample 10 missing
    assert res.data.missing == {"y": 1} and res.data.ignored == ("note",) and res.data.inputs == ("u",)
    assert [b.input for b in res.data.intersample] == ["u"]


def test_the_json_of_the_values_has_the_keys_identify_json_had(forced_run):
    from obsnl.identification.results import clean_json

    res, fits = forced_run
    doc = json.loads(json.dumps(res.to_dict(), allow_nan=False))
    assert list(doc["refinement"]) == REFINEMENT_JSON_KEYS
    assert list(doc["data"]) == MEASURED_JSON_KEYS
    assert list(doc["noise"]["y"]) == ["ratio", "source"] and doc["noise"]["y"]["source"] == "given"
    assert list(doc["noise"]["u"]) == ["ratio", "estimate", "upper_bound", "source"]
    # the fit kept is the one refine() returned last: its own to_dict is what identify.json held before the value
    # (a fit that does not name its objective is an output-error one)
    own = json.loads(json.dumps(clean_json(fits[-1].to_dict()), allow_nan=False))
    assert {k: doc["refinement"][k] for k in own} == own
    assert set(doc["refinement"]) - set(own) <= {"objective", "predictor_gain", "left_out_near_jumps"}
    # identify.json's objects read back into the same values
    assert RefinementSummary.from_dict(doc["refinement"]).to_dict() == doc["refinement"]
    assert RecordSummary.from_dict(doc["data"]) == res.data
    assert {c: NoiseLevel.from_dict(v) for c, v in doc["noise"].items()} == dict(res.noise)


def test_a_simulation_records_json_is_the_records_own():
    import numpy as np

    from obsnl.estimation.accelerogram import Record

    for channels in ((), ("a", "b")):
        record = Record(name="r", accel=np.ones((5, 2)) if channels else np.arange(5.0), dt=0.01, source="made here",
                        notes=("scaled",), channels=channels)
        summary = RecordSummary.from_dict(record.to_dict())
        assert summary.kind == "simulated" and summary.to_dict() == record.to_dict()
        assert list(summary.to_dict()) == list(record.to_dict())


def test_a_refinement_or_record_object_without_its_keys_is_refused():
    from obsnl.errors import DataError

    with pytest.raises(DataError, match="the refinement object lacks 'chi2'"):
        RefinementSummary.from_dict({k: 0 for k in REFINEMENT_JSON_KEYS if k != "chi2"})
    with pytest.raises(DataError, match="the data object lacks 'dt', 'samples'"):
        RecordSummary.from_dict({"name": "run1"})


def test_a_floored_noise_level_is_said_beside_the_misfit():
    from obsnl.report.identification import identify_text

    # an estimate of 2e-5 raised to the filter's floor 1e-4: the misfit over it understates a misfit
    floored = NoiseLevel(1e-4, "estimated from the differences; floored at 0.0001", estimate=2e-5)
    assert floored.floored and floored.origin == "estimated" and not NoiseLevel(0.01, "given").floored
    assert not NoiseLevel(1e-4, "taken as exact", estimate=0.9, upper_bound=True).floored  # an input at the floor
    last = identify_text(_identification(noise={"y": floored})).splitlines()[-1]
    assert last == "  residual RMS / the noise level the fit was given: y 1.02 (that level floored: a smaller " \
        "misfit is not seen)"


def test_a_validations_record_is_a_value_with_the_keys_validate_json_had():
    v = obsnl.simulate(FORCED, {"k": 25.0, "c": 0.8}, _forced_record())
    assert isinstance(v.record, RecordSummary) and v.record.samples == 400 and v.record.ignored == ("note",)
    assert v.record.intersample is None  # said beside the record, in v.intersample
    doc = json.loads(json.dumps(v.to_dict(), allow_nan=False))
    # Measured.to_dict's keys, as validate.json's "record" held them
    assert list(doc["record"]) == MEASURED_JSON_KEYS[:-1] and doc["record"]["missing"] == {"y": 1}
    assert v.scored == 400 and "forced on 'data': 400 samples scored" in v.summary()
