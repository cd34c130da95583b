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
from obsnl.identification.results import Identification, ParameterEstimate
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
                noise={"y": {"ratio": 0.01, "source": "given"}}, tuning=Tuning(0.3, 0.0, 100.0),
                tuning_scores=((Tuning(0.3, 0.0, 100.0), 0.9), (Tuning(0.5, 0.0, 100.0), 1.2)),
                data={"name": "run1"}, practical=practical.with_spread(spread), assumptions=("white noise",),
                structural=StructuralCheck("joint", (), False, ("m",), 2), converged_reason="the profile of m moved",
                refinement={"misfit_over_noise": {"y": 1.02}})
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
    lines = identify_text(_identification(refinement={})).splitlines()
    assert lines[0] == "UKF on storey, measured data run1, 3 pass(es), 1.50 s: NOT converged: the profile of m moved"
    assert lines[3] == ("  k: not decided whether the record pins it within 5 %: Monte-Carlo std of the relative "
                        "error 1 % (95 % interval 0.5-2 %, 8 replicates) contains 1.7 %")
    assert lines[4:] == TEXT.splitlines()[3:-1]
    # identify.json's dict is no longer a run to render (the command line passes the value)
    with pytest.raises(TypeError, match="renders the Identification value"):
        identify_text(run.to_dict())


def test_identify_text_takes_a_run_without_practical_check_nor_tuning_choice():
    from obsnl.report.identification import identify_text

    text = identify_text(_identification(practical=None, refinement={}, tuning_scores=()))
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
    real_symmetries = certify.symmetries
    monkeypatch.setattr(certify, "symmetries", lambda *a, **k: searched.append(1) or real_symmetries(*a, **k))
    analyze(FRICTION, seed=0)  # branches and the joint verdict
    assert sum(calls.values()) == 1
    calls.clear()
    analyze("obsnl:bouc_wen", seed=0)  # the joint verdict and the symmetry certificates too
    assert searched and sum(calls.values()) == 1


def test_the_inner_entries_still_check_when_called_on_their_own(monkeypatch):
    from obsnl.observability.certificates.symmetry import symmetries
    from obsnl.observability.joint.verdict import joint_verdict

    calls = _count_limit_checks(monkeypatch)
    joint_verdict(FRICTION, seed=0)
    symmetries(DRIFT, seed=0)
    assert calls == {"friction": 1, "drift": 1}
    with limits.limits_checked():  # inside a public call that checked: not again
        joint_verdict(FRICTION, seed=0)
    assert calls == {"friction": 1, "drift": 1}


def test_a_model_too_large_is_still_refused_before_any_work():
    # the one check is analyze's own: it still runs first
    n = limits.MAX_UNKNOWNS
    big = obsnl.Model(name="wide", states=["x"], parameters=[f"k{i}" for i in range(n)], inputs=["u"],
                      equations={"x": " + ".join(f"k{i}" for i in range(n)) + " - x + u"}, outputs={"y": "x"})
    with pytest.raises(AnalysisError, match=f"has {n + 1} unknowns .* more than the {n}"):
        analyze(big, seed=0)
