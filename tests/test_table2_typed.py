"""Table 2 of the seed-paper reproduction as typed values end to end (issue 42): ``table2.json`` is read back into a
:class:`~obsnl.studies.seed_reproduction.Reproduction` (``from_dict``) that writes exactly the same document again,
the renderers read its fields, and a malformed or partial document is a one-line DataError (exit code 2 from the
command line), never a traceback."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from obsnl.cli import main
from obsnl.errors import DataError, OptionError
from obsnl.identification.adequacy import Adequacy, AdequacyTest
from obsnl.identification.practical import Practical, Spread
from obsnl.identification.setup import Tuning
from obsnl.identification.summaries import RecordSummary
from obsnl.report.identification import table2_latex, table2_markdown, table2_ml_summary, table2_summary
from obsnl.studies.seed_document import Coordinates, Experiment, TuningChoice, TuningScore
from obsnl.studies.seed_reproduction import Reproduction, read_reproduction, write_reproduction
from obsnl.studies.seed_runs import Attempt, Refined, RunResult, Start

from .conftest import ROOT

COMMITTED = [ROOT / "reports" / "identification" / "table2.json",
             ROOT / "reports" / "identification" / "northridge1994_LOS000_femap695_ngawest1_accel" / "table2.json"]
NAN = float("nan")
GATE_OFF = Tuning(0.1, 0.0, 1.0)  # gate inf: written as None
GATED = Tuning(0.2, 1e-9, 100.0, 3.0)


def _small() -> Reproduction:
    """A two-parameter reproduction built by hand: a UKF run judged with a Monte-Carlo spread and one attempt
    redone, a DUKF run that stopped (no estimate), a refinement with its adequacy and a flat direction, and one
    that could not run."""
    exp = Experiment(
        model="toy", record=RecordSummary(name="rec", dt=0.01, samples=200, kind="simulated", source="rec.csv",
                                          pga_m_s2=1.5),
        truth={"k": 2.0, "c": 0.5}, guess={"k": 3.0, "c": 0.4}, noise_ratio=1e-3,
        coordinates=Coordinates(("log_k", "log_c"), ("k", "c"), (("k",), ("c",))), integrator="RK4")
    spread = Spread(parameters=("k", "c"), std=(0.01, NAN), lower=(0.008, NAN), upper=(0.013, NAN), replicates=8,
                    diverged=0, confidence=0.99, seed=5000, held=("c",))
    practical = Practical(parameters=("k", "c"), crb=(0.001, math.inf), sensitivity=(3.0, 0.0), posterior=(0.1, 1.0),
                          flagged=("c",), reasons={"c": "flat"}, spread=spread, linearised=())
    ukf = RunResult(method="ukf", passes=1, seed=0, tuning=GATED, theta=(2.1, 0.45), seconds=0.5, repairs=1,
                    implicit=0, misfit=1.2e-3, practical=practical, interventions={"gated": 3, "held": 0},
                    redone=(Attempt(GATE_OFF, NAN, "the filter produced NaN"),), passes_run=1)
    dukf = RunResult(method="dukf", passes=1, seed=0, tuning=GATE_OFF, theta=(NAN, NAN), seconds=NAN, repairs=0,
                     implicit=0, misfit=NAN, practical=None, error="the filter produced NaN/inf at step 7")
    test = AdequacyTest("whiteness", "y", 20.0, 0.6, True, "Ljung-Box Q over lags 1..25")
    refined = Refined(seed=0, start=Start("ukf", 1, 1.2e-3), theta=(2.0, 0.5), std=(0.02, math.inf), converged=True,
                      reason="first-order condition met", seconds=3.0, iterations=7, misfit_over_noise={"y": 1.01},
                      newton_decrement=1e-9, last_step_in_std=1e-4,
                      adequacy=Adequacy(passed=True, level=0.01, tests=(test,), assumptions=("white noise",),
                                        model_error={"y": 0.0}, input_noise_share={"y": 0.3}))
    failed = Refined(seed=1, start=Start("guess", 0, NAN), theta=(NAN, NAN), std=(NAN, NAN), converged=False,
                     reason="", seconds=0.1, error="the start cannot be simulated")
    tuning = (TuningChoice("ukf", 1, GATED, (TuningScore(GATED, 1e-3, 2), TuningScore(GATE_OFF, math.inf, 1))),)
    return Reproduction(experiment=exp, table_source="obsnl analysis", runs=(ukf, dukf), tuning=tuning,
                        tuning_seeds=(1000, 1001), tuning_protocol="full grid", compile_seconds={"ukf": 2.0},
                        refinements=(refined, failed), refinement_protocol="maximum likelihood",
                        paper_errors={"ukf": {"k": 1.0, "c": 2.0}, "dukf": {"k": 0.5, "c": 0.1}})


def test_a_small_reproduction_reads_back_exactly_what_it_wrote():
    rep = _small()
    doc = rep.to_dict()
    text = json.dumps(doc, indent=1)
    back = Reproduction.from_dict(json.loads(text))  # through JSON text, as the file is
    assert json.dumps(back.to_dict(), indent=1) == text
    assert back.to_dict() == doc
    ukf, dukf = back.runs
    # the errors in % of the truth, by hand: k 2.1 against 2, c 0.45 against 0.5
    assert doc["runs"][0]["parameters"]["k"]["error_percent"] == pytest.approx(5.0)
    assert doc["runs"][0]["parameters"]["c"]["error_percent"] == pytest.approx(-10.0)
    # what JSON cannot hold comes back as it was meant: no estimate NaN, a flat direction inf, a gate off inf
    assert doc["runs"][1]["parameters"]["k"]["estimate"] is None and np.isnan(dukf.theta).all()
    assert doc["refinements"][0]["parameters"]["c"]["std"] is None and back.refinements[0].std[1] == math.inf
    assert np.isnan(back.refinements[1].std).all()  # no estimate: no std either
    assert doc["runs"][0]["redone"][0]["tuning"]["gate"] is None and ukf.redone[0].tuning == GATE_OFF
    assert ukf.redone[0].error == "the filter produced NaN" and np.isnan(ukf.redone[0].misfit)
    # the typed parts: the adequacy, the start, the practical identifiability and its spread, the tuning
    assert isinstance(back.refinements[0].adequacy, Adequacy) and back.refinements[0].adequacy.passed
    assert back.refinements[0].adequacy.tests[0].label() == "whiteness of y"
    assert back.refinements[1].start == Start("guess", 0, back.refinements[1].start.misfit)
    assert ukf.flagged == ("c",) and ukf.flagged_linearised == () and dukf.flagged is None
    assert ukf.practical is not None and ukf.practical.spread is not None and ukf.practical.spread.held == ("c",)
    assert back.tuning[0].scores[1].misfit == math.inf and back.tuning[0].chosen == GATED
    assert back.setup is None and back.table is None and not back.trajectories


def test_each_part_reads_back_exactly_what_it_wrote():
    rep = _small()
    params, truth = rep.experiment.parameters, rep.experiment.theta_true
    for run in rep.runs:
        d = run.to_dict(params, truth)
        assert RunResult.from_dict(d).to_dict(params, truth) == d
    for ref in rep.refinements:
        d = ref.to_dict(params, truth)
        assert Refined.from_dict(d).to_dict(params, truth) == d
    adequacy = rep.refinements[0].adequacy
    assert adequacy is not None and Adequacy.from_dict(adequacy.to_dict()) == adequacy
    practical = rep.runs[0].practical
    assert practical is not None and Practical.from_dict(practical.to_dict()).to_dict() == practical.to_dict()
    assert Experiment.from_dict(rep.experiment.to_dict()) == rep.experiment
    assert TuningChoice.from_dict(rep.tuning[0].to_dict()) == rep.tuning[0]


@pytest.mark.parametrize("path", COMMITTED, ids=["LOS270", "LOS000"])
def test_a_committed_table2_json_reads_back_to_the_same_json(path):
    text = path.read_text(encoding="utf-8")
    rep = read_reproduction(path)
    assert rep.to_dict() == json.loads(text)
    assert json.dumps(rep.to_dict(), indent=1) + "\n" == text  # the file write_reproduction writes, byte for byte
    assert len(rep.runs) == len(json.loads(text)["runs"]) and all(isinstance(r, RunResult) for r in rep.runs)


def test_the_renderers_read_the_typed_values():
    # the small reproduction renders: the stopped run and the refinement that could not run are named, the
    # flat direction reads "flat", the goal of the ML column is not met (a refinement could not run)
    rep = _small()
    md = table2_markdown(rep)
    assert "- UKF, seed 0: (0.1, 0, 1, off) misfit inf, the filter produced NaN -> (0.2, 1e-09, 100, 3)" in md
    assert "- DUKF, 1 pass(es), seed 0: the filter produced NaN/inf at step 7" in md
    assert "| 1 | guess, 0 pass(es) (-) | 0 | 0.1 | - | could not run | the start cannot be simulated |" in md
    assert "not met (1 refinement(s) could not run)" in md
    assert "tuning seeds [1000, 1001] (never reported)" in md
    ml = table2_ml_summary(rep)
    assert ml is not None and ml.seeds == (0,) and ml.failed == ((1, "the start cannot be simulated"),)
    assert ml.mean_std_percent[1] == math.inf and ml.flagged("c") and not ml.flagged("k")  # 0.02 / 2 = 1 % <= 5/3 %
    ukf = table2_summary(rep)[("ukf", 1)]
    assert ukf.worst_abs_error == pytest.approx([5.0, 10.0]) and ukf.flagged("c") and ukf.interventions["gated"] == 3
    assert r"\multicolumn{3}{c}{ML}" in table2_latex(rep)


def _broken(tmp_path: Path, edit) -> Path:
    doc = json.loads(COMMITTED[0].read_text(encoding="utf-8"))
    edit(doc)
    path = tmp_path / "table2.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    return path


@pytest.mark.parametrize(("edit", "says"), [
    (lambda d: d.pop("runs"), "lacks 'runs'"),
    (lambda d: d["runs"][3].pop("seed"), "run 3 in the Table 2 document lacks 'seed'"),
    (lambda d: d["runs"][0]["parameters"]["k_m"].update(estimate="big"), "run 0 in the Table 2 document holds a value"),
    (lambda d: d["runs"][0]["parameters"].pop("N"), "run 0 of the Table 2 document has 8 parameters"),
    (lambda d: d["refinements"][1].update(adequacy={"passed": True}), "refinement 1 in the Table 2 document lacks"),
    (lambda d: d["experiment"].update(truth=None), "no true values"),
    (lambda d: d.update(runs={"a": 1}), "'runs' in the Table 2 document is dict, not a list"),
    (lambda d: d["tuning"][0].pop("chosen"), "tuning 0 in the Table 2 document lacks 'chosen'"),
])
def test_a_malformed_or_partial_table2_json_is_a_one_line_data_error(tmp_path, edit, says):
    with pytest.raises(DataError) as err:
        read_reproduction(_broken(tmp_path, edit))
    message = str(err.value)
    assert says in message and "\n" not in message and "obsnl reproduce" in message


def test_a_file_that_is_not_json_or_not_an_object_is_a_data_error(tmp_path):
    (tmp_path / "table2.json").write_text('{"runs": [', encoding="utf-8")
    with pytest.raises(DataError, match="table2.json is not JSON"):
        read_reproduction(tmp_path / "table2.json")
    (tmp_path / "table2.json").write_text("[1, 2]", encoding="utf-8")
    with pytest.raises(DataError, match="the Table 2 document is list, not an object"):
        read_reproduction(tmp_path / "table2.json")


def test_the_command_line_says_a_partial_table2_json_in_one_line_with_exit_code_2(tmp_path, monkeypatch, capsys):
    # the run is replaced (no 4.5 minutes here): it "writes" a table2.json that lacks its runs; reading it back for
    # what reproduce prints is exit code 2 with one line on standard error, no traceback
    import obsnl.studies.seed_paper as seed_paper
    import obsnl.studies.seed_reproduction as seed_reproduction

    def write(rep, out, force):
        Path(out).mkdir(parents=True)
        return [_broken(Path(out), lambda d: d.pop("runs"))]

    monkeypatch.setattr(seed_paper, "reproduce", lambda **kw: "rep")
    monkeypatch.setattr(seed_reproduction, "write_reproduction", write)
    monkeypatch.chdir(tmp_path)
    assert main(["reproduce", "--quick"]) == 2
    err = capsys.readouterr().err  # the progress bar's lines first (carriage returns), then the error's one line
    said = [line for line in err.split("\n") if "error" in line]
    assert len(said) == 1 and said[0].startswith("obsnl reproduce: error: the Table 2 document lacks 'runs'")
    assert "regenerate it with obsnl reproduce" in said[0] and "Traceback" not in err


def test_a_reproduction_read_back_has_no_run_to_draw_figures_from(tmp_path):
    with pytest.raises(OptionError, match="read back from a table2.json"):
        write_reproduction(read_reproduction(COMMITTED[0]), tmp_path / "out")
    assert not (tmp_path / "out").exists()
