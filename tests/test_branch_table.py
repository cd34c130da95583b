"""The branch-table contract: schema validation and refusal of corrupt or mismatched tables.

The table used here is the seed paper's Table 1 written by hand (000_d24855f97fc8bdd4.txt), so
the test does not depend on the analysis engines.

Tables that lie (hostile-input reviews): tables contradicting a fresh analysis or themselves, a ``joint`` key that
hides jointly identifiable parameters, an unknown method, a table of another model, huge integers; each is refused
in one line before any run.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import obsnl
from obsnl import Model
from obsnl.errors import TableError
from obsnl.observability.contract.branch_table import BranchTable, read_branch_table

from .conftest import MODELS
from .helpers import BASE, REC, model_file, one_line_refusal, refused_in_one_line, run, sine_record

STATES = ["x1", "x2", "r", "eta_p", "Eh_p"]
PARAMS = ["k_m", "c_dm", "c_eta_p", "w_h", "c_p", "h_p", "Delta1", "Delta2", "N"]


def paper_table1() -> dict:
    m = obsnl.read_model(MODELS / "damage_healing_reparam.toml")
    branches = []
    for label, signs in (("a", [1, 1]), ("b", [1, -1]), ("c", [-1, -1]), ("d", [-1, 1])):
        unid = ["Delta2"] if signs[0] * signs[1] > 0 else ["Delta1", "w_h"]
        unid = [p for p in PARAMS if p in unid]
        rel = [f"r - eta_p {'>' if signs[0] > 0 else '<'} 0", f"x2 {'>' if signs[1] > 0 else '<'} 0"]
        branches.append({
            "label": label, "guard": f"({rel[0]}) & ({rel[1]})", "signs": signs,
            "observable": [v for v in STATES + PARAMS if v not in unid], "unobservable": unid,
            "absent": unid, "identifiable_parameters": [p for p in PARAMS if p not in unid],
            "unidentifiable_parameters": unid, "transcendence_degree": len(unid), "verdict": "unobservable",
        })
    return {"schema": "obsnl.branch-table/1", "model": m.name, "fingerprint": m.fingerprint, "states": STATES,
            "parameters": PARAMS, "inputs": ["xg_dd"], "outputs": ["y"], "switching": ["r - eta_p", "x2"],
            "method": "sedoglavic", "seed": 0, "probability": 0.99, "branches": branches,
            "overall": {"observable": STATES + PARAMS, "unobservable": []}}


def test_round_trip_and_masks(tmp_path):
    t = BranchTable.from_dict(paper_table1())
    p = tmp_path / "t.json"
    p.write_text(t.to_json())
    t2 = read_branch_table(p)
    assert t2 == t
    assert t.frozen_mask([1, 1]) == tuple(p == "Delta2" for p in PARAMS)
    assert t.frozen_mask([-1, 1]) == tuple(p in ("Delta1", "w_h") for p in PARAMS)
    m = obsnl.read_model(MODELS / "damage_healing_reparam.toml")
    t.check_model(states=[s.name for s in m.states], parameters=[s.name for s in m.parameters],
                  inputs=["xg_dd"], outputs=["y"], switching_count=2, fingerprint=m.fingerprint)


def corrupt(path, value):
    d = paper_table1()
    node = d
    for k in path[:-1]:
        node = node[k]
    if value is KeyError:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return d


@pytest.mark.parametrize("path, value, match", [
    (("schema",), "other/1", "not a branch table"),
    (("branches",), [], "schema at branches"),
    (("branches", 0, "signs"), [1, 2], "schema at branches/0/signs/1"),
    (("branches", 0, "label"), KeyError, "'label' is a required property"),
    (("branches", 1, "signs"), [1, 1], "repeats the sign pattern"),
    (("branches", 0, "signs"), [1], "1 signs for 2 switching functions"),
    (("branches", 0, "observable"), ["x1", "Delta2"], "both observable and unobservable"),
    (("branches", 0, "unidentifiable_parameters"), [], "must split the parameters"),
    (("branches", 0, "unobservable"), ["Delta2", "zzz"], "not states or parameters"),
    (("fingerprint",), "xyz", "schema at fingerprint"),
    (("extra",), 1, "Additional properties"),
])
def test_corrupt_tables_are_refused(path, value, match):
    with pytest.raises(TableError, match=match):
        BranchTable.from_dict(corrupt(path, value))


def test_mismatched_model_is_refused():
    t = BranchTable.from_dict(paper_table1())
    orig = obsnl.read_model(MODELS / "damage_healing.toml")
    with pytest.raises(TableError, match=r"with states \['x1', 'x2', 'r', 'eta_p', 'Eh_p'\].*regenerate"):
        t.check_model(states=[s.name for s in orig.states], parameters=[s.name for s in orig.parameters],
                      inputs=["xg_dd"], outputs=["y"], switching_count=2, fingerprint=orig.fingerprint)
    with pytest.raises(TableError, match="fingerprint"):
        t.check_model(states=STATES, parameters=PARAMS, inputs=["xg_dd"], outputs=["y"], switching_count=2,
                      fingerprint="0" * 32)


def test_not_json_and_missing(tmp_path):
    p = tmp_path / "t.json"
    p.write_text("{")
    with pytest.raises(TableError, match="not valid JSON"):
        read_branch_table(p)
    with pytest.raises(TableError, match="does not exist"):
        read_branch_table(tmp_path / "none.json")
    p.write_text(json.dumps([1]))
    with pytest.raises(TableError, match="JSON object"):
        read_branch_table(p)


def test_identify_with_a_table_analyses_the_model_once(monkeypatch):
    # identify used to analyse the model in check_table and again for its structural check; then its run went
    # through check_table's door, which checked the analysis's options and the model's size a second time. Now
    # check_identify checks the table's analysis once and the run runs it once, then compares the table with it
    import obsnl.identification.identify as ident
    import obsnl.observability.analyze as an
    import obsnl.observability.contract.table_check as tc

    m = obsnl.read_model(MODELS / "damage_healing_reparam.toml")
    table = obsnl.report.branch_table(obsnl.analyze(m, seed=0), m)
    checks, runs = [], []
    real_check, real_run = an.check_analysis, an.run_analysis

    def counted_check(*a, **k):
        checks.append(1)
        return real_check(*a, **k)

    def counted_run(*a, **k):
        runs.append(1)
        return real_run(*a, **k)

    for module in (an, ident, tc):
        monkeypatch.setattr(module, "check_analysis", counted_check)
        monkeypatch.setattr(module, "run_analysis", counted_run)
    t = np.arange(40) * 0.01
    data = {"t": t, "xg_dd": np.sin(3 * t), "y": np.zeros_like(t)}
    checked = ident.check_identify(m, data, table=table, method="dukf", progress=False)
    assert (len(checks), len(runs)) == (1, 0)
    num, structural = ident._prepare(checked)
    assert (len(checks), len(runs)) == (1, 1) and structural.unidentifiable == ()


def test_identify_refuses_a_table_of_another_model_before_any_work(monkeypatch):
    # the signature was compared only when the run began; check_identify now refuses it, and nothing is analysed
    import obsnl.identification.identify as ident

    def no_analysis(*a, **k):
        raise AssertionError("the model was analysed before the table's signature was compared")

    monkeypatch.setattr(ident, "run_analysis", no_analysis)
    friction = obsnl.read_model("obsnl:coulomb_friction")
    table = obsnl.report.branch_table(obsnl.analyze(friction, seed=0), friction)
    m = obsnl.Model(name="leak", states=["x"], parameters=["a"], inputs=["u"],
                    equations={"x": "u - a*x"}, outputs={"y": "x"})
    t = np.arange(40) * 0.01
    with pytest.raises(TableError, match="coulomb_friction"):
        ident.check_identify(m, {"t": t, "u": np.ones_like(t), "y": t}, table=table, progress=False)


# ----------------------------------------------------------------------------- 9 contradictory tables
def _damage_table():
    from obsnl.observability.analyze import analyze
    from obsnl.observability.contract.branch_table import BranchTable

    m = obsnl.read_model("obsnl:coulomb_friction")
    return m, BranchTable.from_result(analyze(m, seed=0)).to_dict()


def _swap_first_two(d):
    b = d["branches"]
    for key in ("observable", "unobservable", "verdict", "transcendence_degree", "identifiable_parameters",
                "unidentifiable_parameters", "absent"):
        b[0][key], b[1][key] = b[1][key], b[0][key]


def _variant(kind):
    from obsnl.observability.analyze import analyze
    from obsnl.observability.contract.branch_table import BranchTable

    # a model whose two branches differ: k is visible only while v > 0
    m = Model.from_dict({**BASE, "equations": {"x": "v", "v": "-k*x*Heaviside(v) - x"}})
    d = BranchTable.from_result(analyze(m, seed=0)).to_dict()
    if kind == "swap":
        _swap_first_two(d)
    elif kind == "flip":
        d["switching"] = ["-v"]
    elif kind == "guard":
        d["branches"][0]["guard"], d["branches"][1]["guard"] = d["branches"][1]["guard"], d["branches"][0]["guard"]
    elif kind == "missing":
        d["branches"] = d["branches"][:1]
        d["overall"] = {"observable": d["branches"][0]["observable"], "unobservable": d["branches"][0]["unobservable"]}
    return m, d


@pytest.mark.parametrize("kind, words", [("swap", "in the table but"), ("flip", "opposite orientation"),
                                         ("guard", "contradicts its signs"), ("missing", "lacks the branch")])
def test_9_tables_contradicting_a_fresh_analysis_are_refused(kind, words):
    from obsnl.observability.contract.branch_table import BranchTable
    from obsnl.observability.contract.table_check import check_table

    m, d = _variant(kind)
    if kind != "swap":
        assert d != _variant("none")[1]
    with pytest.raises(TableError, match=words):
        check_table(BranchTable.from_dict(d), m)


@pytest.mark.parametrize("edit, words", [
    (lambda d: d["branches"][0].update(transcendence_degree=99), "transcendence degree 99"),
    (lambda d: d.update(probability=float("nan")), "probability"),
    (lambda d: d["overall"].update(observable=["x", "v", "k"], unobservable=["k"]), "overall"),
    (lambda d: d["branches"][0].update(observable=["x", "v", "k"], unobservable=["k"], verdict="unobservable",
                                       identifiable_parameters=[], unidentifiable_parameters=["k"]), "both"),
])
def test_9_self_contradicting_tables_are_refused_by_the_reader(edit, words):
    from obsnl.observability.contract.branch_table import BranchTable

    _, d = _damage_table()
    edit(d)
    with pytest.raises(TableError, match=words):
        BranchTable.from_dict(d)


def test_9_identify_refuses_a_swapped_table(tmp_path, capsys):
    from obsnl.observability.analyze import analyze
    from obsnl.observability.contract.branch_table import BranchTable

    p = model_file(tmp_path, equations={"x": "v", "v": "-k*x*Heaviside(v) - x"})
    d = BranchTable.from_result(analyze(obsnl.read_model(p), seed=0)).to_dict()
    _swap_first_two(d)
    (tmp_path / "t.json").write_text(json.dumps(d))
    rec = tmp_path / "r.csv"
    rec.write_text("time_s,accel\n" + "\n".join(f"{i / 100},{(-1) ** i}" for i in range(50)))
    code, err = run(capsys, "identify", str(p), "--table", str(tmp_path / "t.json"), "--record", str(rec),
                    "--method", "dukf")
    one_line_refusal(code, err, "in the table but")


def test_9_a_folder_given_as_a_branch_table_is_named(tmp_path):
    from obsnl.observability.contract.branch_table import read_branch_table

    with pytest.raises(TableError, match="is a folder"):  # used to say "does not exist"
        read_branch_table(tmp_path)


def test_2_a_huge_integer_in_a_branch_table_is_refused(tmp_path, coulomb_table):
    from obsnl.observability.contract.branch_table import read_branch_table

    _, data = coulomb_table
    p = tmp_path / "t.json"
    p.write_text(json.dumps({**data, "seed": 0}).replace('"seed": 0', '"seed": ' + "7" * 5000), encoding="utf-8")
    with pytest.raises(TableError, match="a number with more than 100 digits in branch table") as exc:
        read_branch_table(p)
    assert "set_int_max_str_digits" not in str(exc.value) and "\n" not in str(exc.value)


@pytest.mark.parametrize("method", ["rm -rf", "AUTO", "", "ukf"])
def test_4_an_unknown_method_in_a_table_is_refused(tmp_path, coulomb_table, method):
    # used to: accepted, and the table's check ran the analysis as "auto"
    from obsnl.observability.contract.branch_table import read_branch_table

    _, data = coulomb_table
    p = tmp_path / "t.json"
    p.write_text(json.dumps({**data, "method": method}), encoding="utf-8")
    with pytest.raises(TableError, match="auto, orc, sedoglavic") as exc:
        read_branch_table(p)
    assert "method" in str(exc.value) and "regenerate" in str(exc.value) and "\n" not in str(exc.value)


@pytest.mark.parametrize("method", ["auto", "orc", "sedoglavic"])
def test_4_the_known_methods_still_read(coulomb_table, method):
    from obsnl.observability.contract.branch_table import BranchTable

    _, data = coulomb_table
    assert BranchTable.from_dict({**data, "method": method}).method == method


def test_4_a_table_for_a_model_of_another_name_is_refused(coulomb_table):
    # used to: accepted, the fingerprint (which leaves the name out) matching
    from obsnl.observability.contract.branch_table import BranchTable
    from obsnl.observability.contract.table_check import check_table

    model, data = coulomb_table
    with pytest.raises(TableError, match="the branch table is for model 'bouc_wen', not 'coulomb_friction'; "
                                         "regenerate"):
        check_table(BranchTable.from_dict({**data, "model": "bouc_wen"}), model)
    assert check_table(BranchTable.from_dict(data), model).model == "coulomb_friction"  # its own: accepted


@pytest.mark.parametrize("change, words", [({"method": "rm -rf"}, ["'rm -rf'", "auto, orc, sedoglavic"]),
                                           ({"model": "bouc_wen"}, ["is for model 'bouc_wen', not 'coulomb_friction'"])])
def test_4_identify_refuses_those_tables_in_one_line(tmp_path, capsys, coulomb_table, change, words):
    _, data = coulomb_table
    p = tmp_path / "t.json"
    p.write_text(json.dumps({**data, **change}), encoding="utf-8")
    code, err = run(capsys, "identify", "obsnl:coulomb_friction", "--record", str(sine_record(tmp_path / "r.csv")),
                    "--method", "dukf", "--table", str(p), "--no-refine", "--passes", "1")
    refused_in_one_line(code, err, *words, "regenerate")


#: Bouc-Wen with A = 1: beta and gamma are frozen in every branch but identifiable jointly.
BOUC_WEN_A1 = {
    "name": "bw1", "states": ["x", "v", "z"], "parameters": ["c_m", "k1", "k2", "beta", "gamma", "n"],
    "inputs": ["xg_dd"], "switching": ["v", "z"], "outputs": {"y": "x"},
    "equations": {"x": "v", "v": "-c_m*v - k1*x - k2*z - xg_dd", "z": "v*(1 - (beta*sign(v*z) + gamma)*Abs(z)**n)"},
    "values": {"c_m": 0.5, "k1": 5.0, "k2": 15.0, "beta": 0.5, "gamma": 0.5, "n": 2.0, "x": 0.0, "v": 0.0, "z": 0.0},
    "guess": {"c_m": 0.6, "k1": 4.0, "k2": 12.0, "beta": 0.4, "gamma": 0.6, "n": 2.2},
}


# ----------------------------------------------------------------------------- 1 the table's joint key
@pytest.fixture(scope="module")
def bouc_wen_a1(tmp_path_factory):
    from obsnl.observability.analyze import analyze
    from obsnl.observability.contract.branch_table import BranchTable

    folder = tmp_path_factory.mktemp("bw1")
    path = folder / "bw1.json"
    path.write_text(json.dumps(BOUC_WEN_A1), encoding="utf-8")
    model = obsnl.read_model(path)
    table = BranchTable.from_result(analyze(model, seed=0))
    assert set(table.frozen_everywhere) >= {"beta", "gamma"} and {"beta", "gamma"} <= set(table.joint["observable"])
    return path, model, table


def _moved(table, names=("beta", "gamma")):
    from obsnl.observability.contract.branch_table import BranchTable

    d = table.to_dict()
    d["joint"]["observable"] = [v for v in d["joint"]["observable"] if v not in names]
    d["joint"]["unobservable"] += list(names)
    return BranchTable.from_dict(d)  # consistent in itself: only the fresh analysis can tell


def test_1_a_joint_key_that_hides_jointly_identifiable_parameters_is_refused(bouc_wen_a1):
    from obsnl.observability.contract.table_check import check_table

    _, model, table = bouc_wen_a1
    check_table(table, model)  # the table obsnl wrote passes
    with pytest.raises(TableError, match=r"joint verdict contradicts.*lacks \['beta', 'gamma'\].*regenerate"):
        check_table(_moved(table), model)


def test_1_a_joint_key_with_an_invented_inconclusive_entry_is_refused(bouc_wen_a1):
    from obsnl.observability.contract.branch_table import BranchTable
    from obsnl.observability.contract.table_check import check_table

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
