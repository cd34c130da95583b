"""``obsnl analyze``: JSON keys of the issue, text summary, output files, exit codes."""

from __future__ import annotations

import json

import pytest

from obsnl.cli import main
from tests.conftest import MODELS, PEER_CASES

# issue 14: "overall" is the joint verdict, "union" the per-branch union, "joint" its visits and assumptions,
# "visited" how the branches were chosen; issue 17: "verdict" and "assumptions"
TOP_KEYS = {"model", "method", "seed", "probability", "seconds", "branches", "overall", "union", "joint", "visited",
            "verdict", "assumptions"}
BRANCH_KEYS = {"label", "guard", "observable", "unobservable", "absent", "rank", "size", "transcendence_degree",
               "seconds", "verdict"}


def test_json_has_exactly_the_issue_keys_and_the_published_answer(capsys) -> None:
    case = PEER_CASES / "si_lotka_volterra_input.json"
    assert main(["analyze", str(case), "--format", "json", "--seed", "5", "--method", "sedoglavic"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert set(doc) == TOP_KEYS
    assert set(doc["overall"]) == {"rule", "observable", "unobservable", "inconclusive", "reason", "unknown_inputs",
                                   "only_jointly"}
    assert set(doc["union"]) == {"observable", "unobservable", "verdict"}
    assert doc["seed"] == 5 and doc["method"] == "sedoglavic" and doc["probability"] >= 0.99
    for b in doc["branches"]:
        assert set(b) == BRANCH_KEYS
    expected = json.loads(case.read_text())["expected"]
    assert set(doc["overall"]["unobservable"]) == set(expected["nonidentifiable"])
    assert set(doc["overall"]["observable"]) == set(expected["identifiable"])
    # a smooth model: the joint verdict and the union agree
    assert doc["union"]["unobservable"] == doc["overall"]["unobservable"]


def test_seed_model_json_branches(capsys) -> None:
    assert main(["analyze", str(MODELS / "damage_healing_reparam.toml"), "--format", "json", "--seed", "1"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [b["label"] for b in doc["branches"]] == ["a", "b", "c", "d"]
    assert doc["branches"][1]["absent"] == ["w_h", "Delta1"]
    assert doc["overall"]["unobservable"] == []


def test_text_format(capsys) -> None:
    assert main(["analyze", str(MODELS / "coulomb_friction.toml"), "--seed", "2"]) == 0
    out = capsys.readouterr().out
    # the joint verdict first (in words), the union after, then the branches
    assert out.index("jointly identifiable: all") < out.index("union unobservable") < out.index("(a) v > 0")
    assert out.splitlines()[1].strip().startswith("jointly identifiable: all")


def test_output_file_and_force(tmp_path, capsys) -> None:
    target = tmp_path / "res.json"
    args = ["analyze", str(PEER_CASES / "si_if_chain.json"), "--format", "json", "--seed", "1", "-o", str(target)]
    assert main(args) == 0
    assert set(json.loads(target.read_text())) == TOP_KEYS
    assert main(args) == 2
    assert "--force" in capsys.readouterr().err
    assert main(args + ["--force"]) == 0


def test_inconclusive_exits_2_with_the_reason(capsys) -> None:
    code = main(["analyze", str(PEER_CASES / "genssi_hiv.json"), "--method", "orc", "--max-seconds", "0.3",
                 "--format", "json", "--seed", "0"])
    cap = capsys.readouterr()
    assert code == 2
    assert "inconclusive" in cap.err and cap.err.count("\n") == 1
    doc = json.loads(cap.out)  # the result is still printed; undecided variables are in neither list
    assert doc["overall"]["unobservable"] == []


@pytest.mark.parametrize("argv,needle", [
    (["analyze", "missing.toml"], "missing.toml"),
    (["analyze", str(PEER_CASES / "si_if_chain.json"), "--method", "fast"], ""),
])
def test_bad_input_exits_2(argv, needle, capsys) -> None:
    assert main(argv) == 2
    assert needle in capsys.readouterr().err


def test_model_without_outputs_exits_2(tmp_path, capsys) -> None:
    f = tmp_path / "mute.toml"
    f.write_text('name = "mute"\nstates = ["x"]\nparameters = ["a"]\n[equations]\nx = "-a*x"\n')
    assert main(["analyze", str(f)]) == 2
    assert "no outputs" in capsys.readouterr().err
