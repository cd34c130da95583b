"""The joint verdict inside ``analyze`` and ``obsnl analyze``: the seed models, visited sets (--branches,
--record), representative branches of a multi-storey building, certificates by shared symmetries.

Expected answers are derived in the comments (or come from the seed paper, 000_d24855f97fc8bdd4.txt)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import obsnl
from obsnl.cli import main
from obsnl.model.branching.representatives import representative_branches, switching_groups
from obsnl.observability.joint.visited import visited_patterns
from obsnl.studies.buildings import bouc_wen_building

from .conftest import MODELS

BILINEAR = obsnl.Model(
    name="bilinear", states=["x", "v"], parameters=["c", "k", "alpha", "x_y"], inputs=["u"],
    equations={"x": "v", "v": "u - c*v - k*x + (1 - alpha)*k*Max(x - x_y, 0)"}, outputs={"y": "x"},
    values={"c": 0.5, "k": 40.0, "alpha": 0.1, "x_y": 0.02})


def test_seed_models_joint_verdicts():
    # Seed paper section 3.2: per branch the original model hides sigma, eta, E_h, A_m, L, E, sigma_y,
    # c_eta, c, h, beta, gamma (plus w_h in (b), (d)). Jointly w_h is seen in (a), (c); the others stay
    # hidden: the scalings x -> lambda^w x that the paper's recombination (16) divides out (r = sigma L/E,
    # k_m = A_m E/L, ...) act on every branch and keep sigma - eta = 0 and x2 = 0 in place. So the joint
    # unobservable set is the twelve, each certified by a symmetry shared by the four branches.
    m = obsnl.read_model(MODELS / "damage_healing.toml")
    r = obsnl.analyze(m, seed=0)
    twelve = {"sigma", "eta", "E_h", "A_m", "L", "E", "sigma_y", "c_eta", "c", "h", "beta", "gamma"}
    assert set(r.joint.unobservable) == twelve and not r.joint.inconclusive
    assert set(r.union_unobservable) == twelve  # w_h is observable in (a), (c): union and joint agree here
    assert r.joint.assumptions.symmetry_certificates
    # the reparametrized model (16) is observable per branch union (Table 1) and jointly
    rep = obsnl.analyze(obsnl.read_model(MODELS / "damage_healing_reparam.toml"), seed=0)
    assert rep.union_unobservable == () and rep.joint.unobservable == () and rep.joint.inconclusive == ()


def test_json_overall_is_joint_and_union_is_per_branch(tmp_path, capsys):
    f = tmp_path / "bilinear.toml"
    f.write_text(obsnl.model.model_to_toml(BILINEAR))
    assert main(["analyze", str(f), "--format", "json", "--seed", "0"]) == 0
    doc = json.loads(capsys.readouterr().out)
    # the elastic branch gives k, the yielded one alpha*k and (1 - alpha)*k*x_y: jointly everything
    assert doc["overall"]["rule"] == "joint" and doc["overall"]["unobservable"] == []
    assert set(doc["union"]["unobservable"]) == {"alpha", "x_y"}
    assert [b["label"] for b in doc["branches"]] == ["a", "b"]  # the per-branch results stay


def test_branches_option_restricts_the_visits(tmp_path, capsys):
    f = tmp_path / "bilinear.toml"
    f.write_text(obsnl.model.model_to_toml(BILINEAR))
    # branch b (x < x_y) is the elastic one: alpha and x_y do not appear there, so over b alone they are
    # unobservable: the answer is about the visited branch, and says so
    assert main(["analyze", str(f), "--format", "json", "--seed", "0", "--branches", "b"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [b["label"] for b in doc["branches"]] == ["b"]
    assert set(doc["overall"]["unobservable"]) == {"alpha", "x_y"} and doc["visited"]["how"] == "labels"
    assert main(["analyze", str(f), "--branches", "z"]) == 2
    assert "no branch labelled 'z'" in capsys.readouterr().err


def test_record_option_lists_the_visited_branches(tmp_path, capsys):
    # a sine of amplitude 20 on k = 40 gives |x| up to about 0.5 > x_y = 0.02: the response yields
    t = np.linspace(0.0, 20.0, 2001)
    rec = tmp_path / "sine.csv"
    rec.write_text("time_s,accel_m_s2\n" + "\n".join(f"{a:.4f},{20 * np.sin(2 * a):.6f}" for a in t) + "\n")
    f = tmp_path / "bilinear.toml"
    f.write_text(obsnl.model.model_to_toml(BILINEAR))
    assert main(["analyze", str(f), "--format", "json", "--seed", "0", "--record", str(rec)]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["visited"]["how"] == "record"
    assert set(doc["visited"]["durations"]) == {"a", "b"}
    assert abs(sum(doc["visited"]["durations"].values()) - 20.0) < 0.05
    assert doc["visited"]["crossings"]["x - x_y"] >= 2 and doc["overall"]["unobservable"] == []


def test_visited_patterns_of_a_record_that_never_yields():
    # amplitude 0.1 on k = 40: |x| <= 0.0026 < x_y = 0.02 (a linear oscillator far from yield, zero start):
    # only the elastic pattern (x - x_y < 0) is visited, never crossed
    t = np.linspace(0.0, 10.0, 1001)
    vis = visited_patterns(BILINEAR, t, {"u": 0.1 * np.sin(2 * t)})
    assert list(vis.patterns) == [(-1,)] and vis.crossings == {"x - x_y": 0}
    r = obsnl.analyze(BILINEAR, seed=0, visited=vis.patterns, crossings=vis.crossings)
    assert set(r.joint.unobservable) == {"alpha", "x_y"}  # this experiment cannot reveal the yield point


def test_switching_groups_of_a_building():
    # storey i's pair (its drift rate, its hysteretic state) acts on z_i's equation only
    sw, groups = switching_groups(bouc_wen_building(3))
    assert len(sw) == 6 and len(groups) == 3 and all(len(g) == 2 for g in groups)
    reps = representative_branches(bouc_wen_building(3))
    # 1 base + 3 patterns per storey = 10 candidates; in each storey the field depends only on the product
    # sign(d_i) sign(z_i) (z' = d (1 - (beta s + gamma) z^2)): one of the three new patterns is new, two merge
    assert len(reps.branches) == 4 and len(reps.merged) == 6 and reps.patterns == 64


@pytest.mark.parametrize("n", [1, 2, 10])
def test_building_every_parameter_jointly_identifiable(n):
    # every floor acceleration measured, unit masses: each storey's branches see beta_i + gamma_i and
    # gamma_i - beta_i (sign product +1 / -1), so jointly beta_i, gamma_i are identifiable; c_i, k_i, kh_i
    # appear linearly in the measured accelerations
    m = bouc_wen_building(n)
    r = obsnl.analyze(m, seed=0)
    assert r.joint.unobservable == () and r.joint.inconclusive == ()
    params = {p.name for p in m.parameters}
    assert params <= set(r.joint.observable)
    assert {f"beta{i}" for i in range(1, n + 1)} <= set(r.union_unobservable)  # the per-branch rule misses them
    if n == 10:
        assert r.visited.how == "representatives" and len(r.branches) == 11
        assert "instead of 1048576 sign patterns" in r.visited.note


def test_representatives_never_claim_an_unobservable_verdict_for_the_model():
    # 13 relays act on 13 separate states; one level q appears only in its relay's switching function and
    # the states' outputs do not see state w: with representatives the rank finds w, b unobservable over
    # the visits, which is not a verdict over the 2^13 patterns unless a shared symmetry proves it:
    # w -> w + eps, b unchanged... here the translation d/dw is not a symmetry (w' = -b*w + ...), so the
    # verdict must be "not decided", never "unobservable"
    eqs = {f"x{i}": f"-a{i}*x{i} + u - s{i}*sign(x{i} - 1)" for i in range(13)}
    eqs["w"] = "-b*w + sign(w)"
    m = obsnl.Model(name="relays", states=[f"x{i}" for i in range(13)] + ["w"],
                    parameters=[f"a{i}" for i in range(13)] + [f"s{i}" for i in range(13)] + ["b"], inputs=["u"],
                    equations=eqs, outputs={f"y{i}": f"x{i}" for i in range(13)})
    r = obsnl.analyze(m, seed=0)
    assert r.visited.how == "representatives"
    assert "w" not in r.joint.unobservable and "b" not in r.joint.unobservable
    assert {"w", "b"} <= set(r.joint.inconclusive) and "not decided" in r.joint.reason


def test_dukf_refuses_parameters_that_every_branch_freezes_but_the_joint_verdict_identifies(tmp_path, capsys):
    # one Bouc-Wen storey (n = 2, A = 1): z' = v (1 - (beta*sign(v*z) + gamma) z^2); every branch sees only
    # beta*s + gamma (s = +1 or -1), so every branch freezes both, while the two kinds of branch together
    # identify both: a per-branch DUKF can never learn them (switched.md section 5)
    model = tmp_path / "storey.toml"
    model.write_text('''name = "storey"
states = ["x", "v", "z"]
parameters = ["c", "k", "kh", "beta", "gamma"]
inputs = ["ag"]
[outputs]
a = "-c*v - k*x - kh*z"
[equations]
x = "v"
v = "-ag - c*v - k*x - kh*z"
z = "v - beta*Abs(v)*Abs(z)*z - gamma*v*z**2"
[values]
c = 0.3
k = 9.0
kh = 3.0
beta = 20.0
gamma = 10.0
[guess]
c = 0.4
k = 8.0
kh = 2.5
beta = 15.0
gamma = 12.0
''')
    table = tmp_path / "table.json"
    assert main(["analyze", str(model), "--seed", "0", "--format", "json-table", "-o", str(table)]) == 0
    doc = json.loads(table.read_text())
    assert set(doc["overall"]["unobservable"]) == {"beta", "gamma"} and doc["joint"]["unobservable"] == []
    capsys.readouterr()
    record = MODELS.parent / "obsnl" / "studies" / "data" / "northridge1994_LOS270_ngawest2_accel.csv"
    code = main(["identify", str(model), "--record", str(record), "--method", "dukf", "--table", str(table),
                 "--samples", "100"])
    err = capsys.readouterr().err
    assert code == 2 and "beta, gamma" in err and "obsnl reparametrize" in err and len(err.strip().splitlines()) == 1


def test_a_branch_whose_outputs_are_constant_shows_nothing_and_the_joint_verdict_still_runs():
    # a contact force measured alone: y = kc*Max(x - g, 0) is 0 while the contact is open, so that branch
    # reveals nothing (before the fix: "no output depends on a state" there, and the joint verdict failed on
    # the visit's empty rows). In contact, y = kc (x - g) gives y'' = kc u - c y' - (k + kc) y - k kc g: with a
    # generic input, kc, c, k + kc and k kc g are read off, so c, k, kc, g are identifiable, then x = y/kc + g
    # and v = y'/kc: every variable, in that branch alone and jointly.
    m = obsnl.Model(name="gap", states=["x", "v"], parameters=["c", "k", "kc", "g"], inputs=["u"],
              equations={"x": "v", "v": "u - c*v - k*x - kc*Max(x - g, 0)"}, outputs={"contact": "kc*Max(x - g, 0)"})
    res = obsnl.analyze(m, seed=0)
    everything = {"x", "v", "c", "k", "kc", "g"}
    by_sign = {b.label: b for b in res.branches}
    assert len(by_sign) == 2
    closed = [b for b in res.branches if set(b.observable) == everything]
    open_ = [b for b in res.branches if set(b.unobservable) == everything]
    assert len(closed) == 1 and len(open_) == 1
    assert any("constant on this branch" in n for n in open_[0].notes)
    assert set(res.joint.observable) == everything and not res.joint.inconclusive
    # the joint verdict alone (per_branch=False, as the sensor search runs it) gives the same answer
    assert set(obsnl.analyze(m, seed=1, per_branch=False).joint.observable) == everything
