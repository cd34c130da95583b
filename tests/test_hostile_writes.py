"""Hostile input, second round (issue 26): tables whose ``joint`` key lies, writes outside the named
folder, overwrites that were not atomic, a trusted compiled-filter cache, orphaned workers and a
scheduler address where something else answers.

Each test excludes the old behaviour: it failed before the fix.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import obsnl
from obsnl.cli import main
from obsnl.errors import TableError

REC = Path(obsnl.__file__).parent / "studies" / "data" / "northridge1994_LOS270_ngawest2_accel.csv"

#: Bouc-Wen with A = 1: beta and gamma are frozen in every branch but identifiable jointly.
BOUC_WEN_A1 = {
    "name": "bw1", "states": ["x", "v", "z"], "parameters": ["c_m", "k1", "k2", "beta", "gamma", "n"],
    "inputs": ["xg_dd"], "switching": ["v", "z"], "outputs": {"y": "x"},
    "equations": {"x": "v", "v": "-c_m*v - k1*x - k2*z - xg_dd", "z": "v*(1 - (beta*sign(v*z) + gamma)*Abs(z)**n)"},
    "values": {"c_m": 0.5, "k1": 5.0, "k2": 15.0, "beta": 0.5, "gamma": 0.5, "n": 2.0, "x": 0.0, "v": 0.0, "z": 0.0},
    "guess": {"c_m": 0.6, "k1": 4.0, "k2": 12.0, "beta": 0.4, "gamma": 0.6, "n": 2.2},
}


def run(capsys, *argv: str) -> tuple[int, str]:
    code = main(list(argv))
    return code, capsys.readouterr().err.strip()


def one_line_refusal(code: int, err: str, *words: str) -> None:
    assert code == 2, err
    assert "Traceback" not in err
    last = err.splitlines()[-1]
    for w in words:
        assert w in last, last


# ----------------------------------------------------------------------------- 1 the table's joint key
@pytest.fixture(scope="module")
def bouc_wen_a1(tmp_path_factory):
    from obsnl.observability.analyze import analyze
    from obsnl.observability.branch_table import BranchTable

    folder = tmp_path_factory.mktemp("bw1")
    path = folder / "bw1.json"
    path.write_text(json.dumps(BOUC_WEN_A1), encoding="utf-8")
    model = obsnl.load_model(path)
    table = BranchTable.from_result(analyze(model, seed=0))
    assert set(table.frozen_everywhere) >= {"beta", "gamma"} and {"beta", "gamma"} <= set(table.joint["observable"])
    return path, model, table


def _moved(table, names=("beta", "gamma")):
    from obsnl.observability.branch_table import BranchTable

    d = table.to_dict()
    d["joint"]["observable"] = [v for v in d["joint"]["observable"] if v not in names]
    d["joint"]["unobservable"] += list(names)
    return BranchTable.from_dict(d)  # consistent in itself: only the fresh analysis can tell


def test_1_a_joint_key_that_hides_jointly_identifiable_parameters_is_refused(bouc_wen_a1):
    from obsnl.observability.table_check import check_table

    _, model, table = bouc_wen_a1
    check_table(table, model)  # the table obsnl wrote passes
    with pytest.raises(TableError, match=r"joint verdict contradicts.*lacks \['beta', 'gamma'\].*regenerate"):
        check_table(_moved(table), model)


def test_1_a_joint_key_with_an_invented_inconclusive_entry_is_refused(bouc_wen_a1):
    from obsnl.observability.branch_table import BranchTable
    from obsnl.observability.table_check import check_table

    _, model, table = bouc_wen_a1
    d = table.to_dict()
    d["joint"]["observable"].remove("n")
    d["joint"]["inconclusive"].append("n")
    with pytest.raises(TableError, match="joint"):
        check_table(BranchTable.from_dict(d), model)


def test_1_the_dukf_refuses_such_a_table_before_any_run(bouc_wen_a1, tmp_path, capsys):
    path, _, table = bouc_wen_a1
    bad = tmp_path / "bad.json"
    bad.write_text(_moved(table).to_json(), encoding="utf-8")
    # it used to run, printing beta and gamma as estimates equal to their guesses
    code, err = run(capsys, "identify", str(path), "--record", str(REC), "--samples", "100", "--passes", "1",
                    "--s0", "0.2", "--method", "dukf", "--table", str(bad))
    one_line_refusal(code, err, "joint", "beta", "regenerate")
    assert "step/s" not in err
