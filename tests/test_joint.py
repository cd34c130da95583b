"""The joint verdict of switched models (obsnl.observability.joint.verdict).

Every expected answer is derived by hand in the comments of its test (research/switched.md §2 for
the bilinear spring); none is copied from obsnl's output.
"""

from __future__ import annotations

import json

import pytest

from obsnl import Model, analyze, read_model
from obsnl.model import split_branches
from obsnl.observability.joint.verdict import joint_verdict
from obsnl.observability.joint.result import JointResult

from .conftest import PEER_CASES


def bilinear() -> Model:
    return Model(name="bilinear", states=["x", "v"], parameters=["c", "k", "alpha", "x_y"], inputs=["u"],
                 equations={"x": "v", "v": "u - c*v - k*x + (1 - alpha)*k*Max(x - x_y, 0)"},
                 outputs={"y": "x"})


def relay() -> Model:
    return Model(name="relay", states=["x", "v"], parameters=["k", "c", "s", "d"], inputs=["u"],
                 equations={"x": "v", "v": "u - k*x - c*v - s*sign(x - d)"}, outputs={"y": "x"})


def hidden() -> Model:
    return Model(name="hidden", states=["x", "z"], parameters=["a", "b", "e", "q"], inputs=["u"],
                 equations={"x": "-a*x + u", "z": "-b*z + e*sign(z - q)"}, outputs={"y": "x"})


def friction() -> Model:
    return Model(name="base_friction", states=["x", "v"], parameters=["m", "c", "k", "F"], inputs=["ag"],
                 equations={"x": "v", "v": "-ag - (c*v + k*x + F*sign(v))/m"}, outputs={"y": "x"})


def bouc_wen(output: str = "accel") -> Model:
    outputs = {"a": "-c*v - k*x - kh*z"} if output == "accel" else {"y": "x"}
    return Model(name=f"bouc_wen_{output}", states=["x", "v", "z"], parameters=["c", "k", "kh", "beta", "gamma"],
                 inputs=["ag"],
                 equations={"x": "v", "v": "-ag - c*v - k*x - kh*z",
                            "z": "v - beta*Abs(v)*Abs(z)*z - gamma*v*z**2"},
                 outputs=outputs)


ALL_BILINEAR = ("x", "v", "c", "k", "alpha", "x_y")


# --------------------------------------------------------------------------- 1. bilinear spring
def test_bilinear_spring_joint_all_union_misses_alpha_and_yield():
    # Branch x < x_y: v' = u - c v - k x. With y = x: y' = v, y'' = u - c v - k x; u is generic, so the
    # coefficients of v and x in y'' give c and k: x, v, c, k identifiable, alpha and x_y absent.
    # Branch x > x_y: v' = u - c v - alpha k x - (1 - alpha) k x_y: identifiable c, alpha k and
    # (1 - alpha) k x_y (3 functions of 4 parameters), not k, alpha, x_y separately.
    # Union: alpha, x_y unobservable. Joint (shared parameters): k from the first branch, then alpha
    # from alpha k and x_y from (1 - alpha) k x_y (alpha != 1 generically): everything identifiable,
    # parameter rank 4 from the two branch visits alone.
    m = bilinear()
    r = joint_verdict(m, seed=0)
    assert isinstance(r, JointResult)
    assert r.observable == ALL_BILINEAR
    assert r.unobservable == () and r.inconclusive == () and r.reason == ""
    assert set(r.union_observable) == {"x", "v", "c", "k"}
    assert r.parameter_rank == 4
    assert r.probability == 1.0  # a full-rank stack is a certificate
    # the two branches already give everything: early stop before the surface visit
    assert r.early_stop and [v.kind for v in r.visits] == ["branch", "branch"]
    assert sorted(v.parameter_rank for v in r.visits) == [2, 3]  # {c, k} and {c, alpha k, (1-alpha) k x_y}
    a = analyze(m, seed=0)
    assert set(a.overall_unobservable) == {"alpha", "x_y"}
    assert set(a.overall_observable) <= set(r.observable)


# --------------------------------------------------------------------------- 2. relay level
def test_relay_level_only_in_switching_function_identified_by_crossing():
    # In either branch sign(x - d) = +-1: v' = u - k x - c v -+ s. y'' = u - k x - c v -+ s with u
    # generic gives k, c and s; d appears in no branch (absent, unobservable in the union).
    # On the surface x = d the two sides' y'' differ by 2 s != 0: the crossing is visible, and at
    # the crossing instant y = x = d, so d = y(t*) is identifiable jointly.
    m = relay()
    r = joint_verdict(m, seed=0)
    assert r.observable == ("x", "v", "k", "c", "s", "d")
    assert "d" not in r.union_observable and set(r.union_observable) == {"x", "v", "k", "c", "s"}
    surf = [v for v in r.visits if v.kind == "surface"]
    assert len(surf) == 1 and surf[0].visible is True and surf[0].solved_for == "x"
    assert surf[0].rank_gain == 1  # d: the only parameter the branches did not give
    assert "d" in analyze(m, seed=0).overall_unobservable


# --------------------------------------------------------------------------- 3. a switch nobody sees
def test_switch_that_never_reaches_the_output_reveals_nothing():
    # y = x and x' = -a x + u do not involve z, b, e, q: any change of (z(0), b, e, q) leaves y
    # unchanged (a symmetry of every branch), and the crossing z = q is invisible (the output series
    # of both sides coincide, the switched equation does not feed the output). From y, y' = -a y + u:
    # x and a identifiable.
    r = joint_verdict(hidden(), seed=0)
    assert r.observable == ("x", "a")
    assert r.unobservable == ("z", "b", "e", "q")
    assert r.inconclusive == () and r.reason == ""
    surf = [v for v in r.visits if v.kind == "surface"]
    assert len(surf) == 1 and surf[0].visible is False
    assert r.assumptions.surfaces_invisible and not r.assumptions.surfaces_used
    assert r.runs == 2  # unobservable verdicts are confirmed by a second independent run
    assert r.probability >= 0.99


# --------------------------------------------------------------------------- 4. friction scaling
def test_base_excited_friction_scaling_symmetry():
    # v' = -ag - (c v + k x + F sign(v))/m. (m, c, k, F) -> lambda (m, c, k, F) leaves both branch
    # fields (sign(v) = +-1) unchanged and does not move the surface v = 0 (no parameter in it):
    # m, c, k, F are jointly unobservable. y = x, y' = v: x, v observable; y'' = -ag - c/m v - k/m x
    # -+ F/m gives c/m, k/m, F/m: the joint parameter rank is 3 of 4. The crossing v = 0 is visible
    # (y'' jumps by 2 F/m) but adds nothing the scaling does not keep.
    r = joint_verdict(friction(), seed=0)
    assert r.observable == ("x", "v")
    assert r.unobservable == ("m", "c", "k", "F")
    assert r.parameter_rank == 3
    surf = [v for v in r.visits if v.kind == "surface"]
    assert len(surf) == 1 and surf[0].visible is True and surf[0].switching == "v"
    assert r.runs == 2 and r.probability >= 0.99


# --------------------------------------------------------------------------- 5. Bouc-Wen storey
@pytest.mark.parametrize("output", ["accel", "x"])
def test_bouc_wen_storey_beta_gamma_joint_only(output):
    # n = 2, A = 1: z' = v - beta |v| |z|^(n-1) z - gamma v |z|^n = v - beta |v| |z| z - gamma v z^2.
    # In a branch |v| = s_v v and |z| = s_z z, so beta |v| |z| z = beta s_v s_z v z^2 and
    # z' = v - (beta s + gamma) v z^2 with s = s_v s_z = sign(v z): every branch sees beta and gamma
    # only through theta = beta s + gamma (the union leaves beta, gamma unobservable). Branches with
    # s = +1 and s = -1 give beta + gamma and gamma - beta: jointly both are identifiable, with
    # c, k, kh and the states (the measured acceleration -c v - k x - kh z, or x, determines them in
    # each branch). Gray order: branch a (v > 0, z > 0), b (v > 0, z < 0) already differ in s.
    m = bouc_wen(output)
    r = joint_verdict(m, seed=0)
    assert r.observable == ("x", "v", "z", "c", "k", "kh", "beta", "gamma")
    assert r.unobservable == () and r.inconclusive == ()
    assert "beta" not in r.union_observable and "gamma" not in r.union_observable
    assert r.probability == 1.0 and r.early_stop
    assert [v.labels for v in r.visits] == [("a",), ("b",)]
    a = analyze(m, seed=0)
    assert set(a.overall_unobservable) == {"beta", "gamma"}


# --------------------------------------------------------------------------- 6. oracles
def mass_spring_damper() -> Model:
    return Model(name="msd", states=["x", "v"], parameters=["m", "c", "k"], inputs=["u"],
                 equations={"x": "v", "v": "(u - c*v - k*x)/m"}, outputs={"y": "x"})


@pytest.mark.parametrize("make", [lambda: read_model(PEER_CASES / "si_bench_seir34.json"), mass_spring_damper],
                         ids=["seir34", "msd"])
def test_smooth_model_joint_equals_per_branch(make):
    # A smooth model has one branch and no surface: the joint verdict is the branch's verdict.
    m = make()
    r = joint_verdict(m, seed=0)
    a = analyze(m, seed=0)
    assert len(r.visits) == 1 and r.visits[0].labels == ("smooth",)
    assert r.observable == a.overall_observable
    assert r.unobservable == a.overall_unobservable
    assert r.union_observable == a.overall_observable


@pytest.mark.parametrize("make", [bilinear, relay, hidden, friction, bouc_wen])
def test_union_is_subset_of_joint(make):
    # Joint information contains every branch's own information (each branch visit is in the stack).
    m = make()
    r = joint_verdict(m, seed=0)
    a = analyze(m, seed=0)
    assert set(a.overall_observable) <= set(r.observable)
    assert set(r.union_observable) <= set(r.observable)
    assert set(r.union_observable) == set(a.overall_observable)


def test_seeds_reproducible_and_json():
    m = relay()
    d1 = joint_verdict(m, seed=7).to_dict()
    d2 = joint_verdict(m, seed=7).to_dict()
    d1.pop("seconds"), d2.pop("seconds")
    assert d1 == d2
    json.dumps(d1)
    assert joint_verdict(m, seed=8).observable == tuple(d1["observable"])


def test_extra_output_of_an_observable_parameter_adds_no_rank():
    # In the hidden model a is jointly identifiable: measuring it as well adds no information
    # (its unit row is already in the joint parameter row space).
    m = hidden()
    r = joint_verdict(m, seed=0)
    outs = dict(m.outputs)
    outs["y_a"] = m.symbol("a")
    r2 = joint_verdict(m.replace(outputs={k: str(v) for k, v in outs.items()}), seed=0)
    assert r2.parameter_rank == r.parameter_rank == 1
    assert r2.observable == r.observable and r2.unobservable == r.unobservable


# --------------------------------------------------------------------------- options and honesty
def test_branch_selection_by_label_and_by_object():
    # Only the branch x > x_y (label a: Max(x - x_y, 0) = x - x_y): c, alpha k, (1 - alpha) k x_y
    # identifiable, so of the parameters only c; no surface (one branch).
    m = bilinear()
    br = split_branches(m)
    a_label = next(b.label for b in br if b.signs == (1,))
    r = joint_verdict(m, branches=[a_label], seed=0)
    assert r.observable == ("x", "v", "c")
    assert r.unobservable == ("k", "alpha", "x_y")
    assert r.assumptions.visited_branches == (a_label,)
    r_obj = joint_verdict(m, branches=list(br), seed=0)
    assert r_obj.observable == ALL_BILINEAR


def test_time_limit_gives_inconclusive_not_a_guess():
    r = joint_verdict(bouc_wen(), seed=0, max_seconds=1e-9)
    assert r.observable == () and r.unobservable == ()
    assert set(r.inconclusive) == {"x", "v", "z", "c", "k", "kh", "beta", "gamma"}
    assert "time limit" in r.reason


def test_unplaceable_surface_makes_unobservable_verdicts_inconclusive():
    # sign(x**2 - d): d - x**2 is affine in no state, so the surface cannot be placed by solving for a
    # state. Branches give x, v, k, s (v' = u - k x -+ s); d is absent from both, and the crossing
    # (which would reveal d = x(t*)**2) is not evaluated: d is inconclusive, not unobservable.
    m = Model(name="square_relay", states=["x", "v"], parameters=["k", "s", "d"], inputs=["u"],
              equations={"x": "v", "v": "u - k*x - s*sign(x**2 - d)"}, outputs={"y": "x"})
    r = joint_verdict(m, seed=0)
    assert r.observable == ("x", "v", "k", "s")
    assert r.unobservable == () and r.inconclusive == ("d",)
    assert "surface" in r.reason and r.assumptions.surfaces_skipped


def test_unknown_input_and_known_initial_condition():
    # x' = -a x + w, y = x, w an unknown input with one non-zero derivative (w = w0 + w1 t):
    # y' = -a y + w0, y'' = -a y' + w1, y''' = -a y'' (w'' = 0), so a = -y'''/y'', then w0 = y' + a y:
    # x, a and w observable. z' = -b z + e sign(z - q), y2 = z with z(0) known: in a branch
    # y2' = -b z -+ e and y2'' = -b y2' give b, then e. The crossing z = q is visible (y2' jumps by
    # 2 e); at the crossing instant y2 = z = q, so q is identifiable jointly (not in any branch).
    m = Model(name="ui", states=["x", "z"], parameters=["a", "b", "e", "q"], unknown_inputs=["w"],
              equations={"x": "-a*x + w", "z": "-b*z + e*sign(z - q)"}, outputs={"y": "x", "y2": "z"},
              known_initial_conditions=["z"])
    r = joint_verdict(m, seed=0)
    assert r.observable == ("x", "z", "a", "b", "e", "q")
    assert r.unobservable == () and r.inconclusive == ()
    assert r.unknown_inputs == {"observable": ("w",), "unobservable": ()}
    assert "q" not in r.union_observable
    assert "surface visits have free states" in r.assumptions.known_initial_conditions
