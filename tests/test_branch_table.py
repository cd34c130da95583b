"""The branch-table contract: schema validation and refusal of corrupt or mismatched tables.

The table used here is the seed paper's Table 1 written by hand (000_d24855f97fc8bdd4.txt), so
the test does not depend on the analysis engines.
"""

from __future__ import annotations

import copy
import json

import pytest

import obsnl
from obsnl.observability.contract.branch_table import BranchTable, read_branch_table
from obsnl.errors import TableError

from .conftest import MODELS

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
    # identify used to analyse the model in check_table and again for its structural check
    import obsnl.identification.identify as ident
    import obsnl.observability.analyze as an

    m = obsnl.read_model(MODELS / "damage_healing_reparam.toml")
    table = obsnl.report.branch_table(obsnl.analyze(m, seed=0), m)
    calls = []
    real = an.analyze

    def counted(*a, **k):
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(an, "analyze", counted)
    monkeypatch.setattr(ident, "analyze", counted)
    num, g, tab, structural = ident._prepare(m, table, None, False, 0, "dukf")
    assert len(calls) == 1 and tab is table and structural.unidentifiable == ()
