"""The minimal sensor sets (:func:`obsnl.design.sensors.sensors`) against answers derived in the tests.

The cases are linear in the states, so each test derives the answer with classical linear theory, written
out below and computed here with numpy and sympy (not with obsnl): for a linear system with unknown
initial state and generic known inputs, a parameter is identifiable iff it is locally determined by the
coefficients of the transfer functions from the inputs to the chosen outputs (denominators made monic),
and, the parameters being determined, a state is observable iff its unit vector lies in the row space of
the Kalman observability matrix. A set is sufficient when every target passes both.

Randomness: the ranks are evaluated at one random rational point (seeded); a generic rank can only drop
at a point, and the derivations below only assert full ranks that the point reaches, so an assertion can
fail by bad luck only if the point hits the zero set of a non-zero polynomial, probability < 1e-6 with
coefficients drawn from 1..10^6 (Schwartz-Zippel; degrees below 20).
"""

from __future__ import annotations

import itertools
import json
import random

import numpy as np
import pytest
import sympy as sp

from obsnl import Model, analyze
from obsnl.cli import main
from obsnl.design.sensors import sensors
from obsnl.design.sufficiency import restrict


_RESOLVENT: dict = {}


def _resolvent(model: Model) -> tuple:
    """A, the adjugate and determinant of (sI - A) and B, symbolic in the parameters (once per model)."""
    if model.name not in _RESOLVENT:
        xs, us = list(model.states), list(model.inputs)
        A = sp.Matrix([[sp.diff(model.equations[x], y) for y in xs] for x in xs])
        B = sp.Matrix([[sp.diff(model.equations[x], u) for u in us] for x in xs])
        s = sp.Symbol("s")
        M = s * sp.eye(len(xs)) - A
        _RESOLVENT[model.name] = (A, M.adjugate(), sp.Poly(M.det(), s), B, s)
    return _RESOLVENT[model.name]


def _linear_answer(model: Model, outputs: list[str], targets: list[str], seed: int = 1) -> bool:
    """Sufficiency derived with the transfer functions and the Kalman matrix (module docstring)."""
    rng = random.Random(seed)
    xs, ps = list(model.states), list(model.parameters)
    A, adj, den, B, s = _resolvent(model)
    C = sp.Matrix([[sp.diff(model.outputs[o], y) for y in xs] for o in outputs])
    point = {p: sp.Rational(rng.randint(1, 10**6), rng.randint(1, 10**6)) for p in ps}
    lead = den.LC()
    coeffs = [c / lead for c in den.all_coeffs()[1:]]
    for entry in C * adj * B:
        coeffs += [c / lead for c in sp.Poly(sp.expand(entry), s).all_coeffs()]
    J = sp.Matrix([[sp.diff(c, p) for p in ps] for c in coeffs]).subs(point)
    rank_j = J.rank()
    ident_params = {p.name for i, p in enumerate(ps) if sp.Matrix.vstack(J, sp.eye(len(ps))[i, :]).rank() == rank_j}
    An, Cn = A.subs(point), C.subs(point)
    O = sp.Matrix.vstack(*[Cn * An**k for k in range(len(xs))])
    r = O.rank()
    observable = {x.name for i, x in enumerate(xs) if sp.Matrix.vstack(O, sp.eye(len(xs))[i, :]).rank() == r}
    if not ident_params >= {p.name for p in ps}:  # the derivation above assumes the parameters determined
        observable = set()
    known = ident_params | observable
    return all(t in known for t in targets)


def _expected_minimal(model: Model, targets: list[str], max_size: int | None = None) -> list[tuple[str, ...]]:
    names = list(model.output_names)
    top = len(names) if max_size is None else max_size
    sufficient = {frozenset(c) for k in range(1, top + 1) for c in itertools.combinations(names, k)
                  if _linear_answer(model, list(c), targets)}
    minimal = [tuple(n for n in names if n in c) for c in sufficient if not any(o < c for o in sufficient)]
    return sorted(minimal, key=lambda c: (len(c), [names.index(n) for n in c]))


#: Two equal side masses on springs k and dampers c to a middle mass (spring k0 to the ground), the force u on
#: the middle mass: the structure and its excitation are symmetric about the middle mass.
SYMMETRIC = Model(
    name="symmetric", states=["x1", "v1", "x0", "v0", "x2", "v2"], parameters=["k", "c", "k0"], inputs=["u"],
    equations={"x1": "v1", "v1": "-k*(x1 - x0) - c*(v1 - v0)",
               "x2": "v2", "v2": "-k*(x2 - x0) - c*(v2 - v0)",
               "x0": "v0", "v0": "u - k0*x0 - k*(2*x0 - x1 - x2) - c*(2*v0 - v1 - v2)"},
    outputs={"y1": "x1", "y0": "x0", "y2": "x2"},
)


def test_symmetric_structure_measured_on_its_axis_misses_the_antisymmetric_motion():
    # d = x1 - x2 obeys d'' = -k d - c d': neither u nor x0 enter, and y0 = x0 depends on x1 + x2 only, so on
    # the axis d, d' are invisible (x1, v1, x2, v2 unobservable); an off-axis sensor (y1 or y2) sees them.
    targets = [s.name for s in SYMMETRIC.states] + [p.name for p in SYMMETRIC.parameters]
    assert not _linear_answer(SYMMETRIC, ["y0"], targets)
    expected = _expected_minimal(SYMMETRIC, targets)
    assert expected == [("y1",), ("y2",)]  # the derivation's own result, before obsnl is asked
    res = sensors(SYMMETRIC, target="all", seed=3)
    assert [tuple(s) for s in res.minimal_sets] == expected
    on_axis = res.answer(["y0"])
    assert on_axis.sufficient is False and set(on_axis.missing) == {"x1", "v1", "x2", "v2"}
    assert not res.none_exists and res.undecided_sets == ()


#: Two oscillators that do not interact, each driven by its own force; one sensor each, or one of their sum.
SEPARATE = Model(
    name="separate", states=["x1", "v1", "x2", "v2"], parameters=["k1", "c1", "k2", "c2"], inputs=["u1", "u2"],
    equations={"x1": "v1", "v1": "u1 - k1*x1 - c1*v1", "x2": "v2", "v2": "u2 - k2*x2 - c2*v2"},
    outputs={"a1": "x1", "a2": "x2", "s": "x1 + x2"},
)


def test_substructures_that_do_not_interact_need_one_sensor_each_or_their_sum():
    targets = [s.name for s in SEPARATE.states] + [p.name for p in SEPARATE.parameters]
    expected = _expected_minimal(SEPARATE, targets)
    assert expected == [("s",), ("a1", "a2")]
    res = sensors(SEPARATE, target="all", seed=5)
    assert [tuple(s) for s in res.minimal_sets] == expected
    # {a1} and {a2} fail on reachability alone (the other oscillator has no path to them): no analysis
    for alone, lost in (("a1", {"x2", "v2", "k2", "c2"}), ("a2", {"x1", "v1", "k1", "c1"})):
        ans = res.answer([alone])
        assert ans.how == "reachability" and set(ans.missing) == lost
    # analyses: the full set, {s}, {a1, a2}; {a1, s}, {a2, s} contain {s}
    assert res.analyses == 3 < res.exhaustive == 7


@pytest.mark.parametrize("case, seed", [(SYMMETRIC, 3), (SEPARATE, 5)])
def test_every_minimal_set_passes_analyze_and_fails_with_any_sensor_removed(case, seed):
    res = sensors(case, target="all", seed=seed)
    targets = set(res.targets)
    for s in res.minimal_sets:
        joint = analyze(restrict(case, s), seed=seed + 100).joint  # a fresh seed: an independent analysis
        assert targets <= set(joint.observable)
        for name in s:
            rest = [x for x in s if x != name]
            if rest:
                assert not targets <= set(analyze(restrict(case, rest), seed=seed + 200).joint.observable)


def test_targets_restrict_the_question():
    # the parameters alone: on the axis the symmetric motion already gives k, c, k0 (derived as above)
    assert _linear_answer(SYMMETRIC, ["y0"], ["k", "c", "k0"])
    expected = _expected_minimal(SYMMETRIC, ["k", "c", "k0"])
    assert expected == [("y1",), ("y0",), ("y2",)]
    res = sensors(SYMMETRIC, target="parameters", seed=3)
    assert [tuple(x) for x in res.minimal_sets] == expected


def test_no_sensor_breaks_a_symmetry_of_the_dynamics():
    # v' = -ag - (c v + k x + F sign(v))/m is unchanged by (m, c, k, F) -> lambda (m, c, k, F): any output of
    # the states sees the same, so no set of sensors identifies m, c, k, F (and the search says so at once)
    m = Model(name="friction", states=["x", "v"], parameters=["m", "c", "k", "F"], inputs=["ag"],
              equations={"x": "v", "v": "-ag - (c*v + k*x + F*sign(v))/m"},
              outputs={"d": "x", "s": "v", "e": "x + v"})
    res = sensors(m, target="parameters", seed=0)
    assert res.none_exists and res.minimal_sets == ()
    assert res.analyses == 1
    assert "no output breaks" in res.proof and "m" in res.proof


def test_max_size_bounds_the_search_and_json_keys():
    res = sensors(SEPARATE, target="all", max_size=1, seed=5)
    assert res.minimal_sets == (("s",),) and res.max_size == 1
    d = res.to_dict()
    assert {"minimal_sets", "analyses", "certificates"} <= set(d)
    cert = d["certificates"][0]
    assert cert["sensors"] == ["s"] and cert["analysis"]["sufficient"] is True


def test_cli_sensors_json_and_bad_input(tmp_path, capsys):
    path = tmp_path / "sep.toml"
    path.write_text(
        'name = "sep"\nstates = ["x1", "v1", "x2", "v2"]\nparameters = ["k1", "c1", "k2", "c2"]\n'
        'inputs = ["u1", "u2"]\n[equations]\nx1 = "v1"\nv1 = "u1 - k1*x1 - c1*v1"\nx2 = "v2"\n'
        'v2 = "u2 - k2*x2 - c2*v2"\n[outputs]\na1 = "x1"\na2 = "x2"\ns = "x1 + x2"\n', encoding="utf-8")
    assert main(["sensors", str(path), "--target", "all", "--format", "json", "--seed", "5"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["minimal_sets"] == [["s"], ["a1", "a2"]] and out["analyses"] == 3
    assert main(["sensors", str(path), "--target", "all", "--seed", "5"]) == 0
    text = capsys.readouterr().out
    assert "{s}" in text and "{a1, a2}" in text
    assert main(["sensors", str(path), "--target", "kk"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "'kk'" in err
    assert main(["sensors", str(path), "--max-size", "0"]) == 2
    capsys.readouterr()
    out_file = tmp_path / "s.md"
    assert main(["sensors", str(path), "--format", "md", "-o", str(out_file)]) == 0
    assert "| {s} |" in out_file.read_text(encoding="utf-8") or "s" in out_file.read_text(encoding="utf-8")
    assert main(["sensors", str(path), "--format", "md", "-o", str(out_file)]) == 2  # no overwrite without --force


def test_progress_callable_counts_every_set():
    seen = []
    sensors(SEPARATE, target="all", seed=5, progress=seen.append)
    assert sum(seen) == res_total(SEPARATE)


def res_total(model: Model) -> int:
    return 2 ** len(model.output_names) - 1


def test_parallel_search_gives_the_same_answer():
    from obsnl.executor import Executor

    serial = sensors(SYMMETRIC, target="all", seed=3)
    parallel = sensors(SYMMETRIC, target="all", seed=3, executor=Executor(workers=2))
    assert parallel.minimal_sets == serial.minimal_sets and parallel.analyses == serial.analyses


def test_undecided_is_never_reported_minimal(monkeypatch):
    # an analysis cut short (a tiny time limit) leaves sets undecided, never minimal by a guess
    import obsnl.design.sensors as mod
    from obsnl.design.sufficiency import Sufficiency

    real = mod.check_sensors

    def flaky(model, names, targets, **kw):
        if tuple(names) == ("y0",):
            return Sufficiency(tuple(names), None, undecided=tuple(targets), reason="time limit")
        return real(model, names, targets, **kw)

    monkeypatch.setattr(mod, "check_sensors", flaky)
    res = mod.sensors(SYMMETRIC, target="all", seed=3)
    assert ("y0",) in res.undecided_sets
    # {y0, y1} contains the minimal {y1}: not minimal whatever {y0} is; the answer is otherwise unchanged
    assert res.minimal_sets == (("y1",), ("y2",))
    assert np.isfinite(res.seconds)


def test_cli_ranks_sufficient_sets_along_a_record(tmp_path, capsys):
    # the symmetric structure with numbers, driven on its axis from rest: mirror images {y1} and {y2} have the
    # same Cramer-Rao bounds (the response is mirror-symmetric), and both are ranked; {y0} is not sufficient
    model = tmp_path / "sym.toml"
    model.write_text(
        'name = "sym"\nstates = ["x1", "v1", "x0", "v0", "x2", "v2"]\nparameters = ["k", "c", "k0"]\ninputs = ["u"]\n'
        '[equations]\nx1 = "v1"\nv1 = "-k*(x1 - x0) - c*(v1 - v0)"\nx2 = "v2"\nv2 = "-k*(x2 - x0) - c*(v2 - v0)"\n'
        'x0 = "v0"\nv0 = "u - k0*x0 - k*(2*x0 - x1 - x2) - c*(2*v0 - v1 - v2)"\n'
        '[outputs]\ny1 = "x1"\ny0 = "x0"\ny2 = "x2"\n[values]\nk = 3.0\nc = 0.2\nk0 = 5.0\n', encoding="utf-8")
    t = np.arange(400) * 0.02
    rec = tmp_path / "rec.csv"
    rec.write_text("time_s,accel_m_s2\n" + "\n".join(f"{a:.6f},{np.sin(2.1 * a) + 0.5 * np.sin(5.3 * a):.9f}"
                                                     for a in t) + "\n", encoding="utf-8")
    assert main(["sensors", str(model), "--target", "all", "--record", str(rec), "--format", "json", "--seed", "3"]) == 0
    out = json.loads(capsys.readouterr().out)
    rows = out["ranking"]
    assert sorted(tuple(r["sensors"]) for r in rows) == [("y1",), ("y2",)]
    a, b = (r["worst_relative_std"] for r in rows)
    assert a == pytest.approx(b, rel=1e-6) and 0 < a < 1
    assert out["effective_independence"] and set(out["effective_independence"]) <= {"y0", "y1", "y2"}
    assert main(["sensors", str(model), "--target", "all", "--record", str(rec), "--rank-size", "2", "--format", "md",
                 "--seed", "3"]) == 0
    md = capsys.readouterr().out
    assert md.count("| {y") >= 3  # the three pairs, each containing a minimal set
    assert main(["sensors", str(model), "--record", str(tmp_path / "missing.csv")]) == 2
    assert capsys.readouterr().err.count("\n") == 1


#: The symmetric structure seen by five on-axis sensors (each sees only the symmetric motion) and one that
#: measures the antisymmetric motion x1 - x2 (which never sees the middle mass).
ESSENTIAL = SYMMETRIC.replace(name="essential", outputs={
    "m1": "x0", "m2": "v0", "m3": "x0 - v0", "m4": "x0 + v0", "m5": "2*x0 + v0", "q": "x1 - x2"})


def test_an_essential_sensor_prunes_every_set_without_it():
    # no single sensor suffices (on the axis d = x1 - x2 is invisible; q sees d only, whose dynamics
    # d'' = -k d - c d' never involve x0, v0, k0); derived with the linear theory above, the minimal sets of at
    # most two sensors are q with any on-axis sensor
    targets = [s.name for s in ESSENTIAL.states] + [p.name for p in ESSENTIAL.parameters]
    expected = _expected_minimal(ESSENTIAL, targets, max_size=2)
    assert expected == [("m1", "q"), ("m2", "q"), ("m3", "q"), ("m4", "q"), ("m5", "q")]
    res = sensors(ESSENTIAL, target="all", max_size=2, seed=7)
    assert [tuple(s) for s in res.minimal_sets] == expected
    # without q even every other sensor is not enough: each pair of on-axis sensors is implied insufficient
    without_q = res.answer(["m1", "m2", "m3", "m4", "m5"])
    assert without_q.sufficient is False
    for pair in itertools.combinations(["m1", "m2", "m3", "m4", "m5"], 2):
        assert res.answer(pair).how == "implied"
    # analyses: the full set, the 6 singletons, the 6 sets with one sensor left out, the 5 pairs with q; the
    # plain level-wise search would analyse the 10 on-axis pairs instead of the 6 leave-one-out sets
    assert res.analyses == 1 + 6 + 6 + 5 < 1 + 6 + 15


def test_cli_says_undecided_sets_with_exit_2(tmp_path, capsys, monkeypatch):
    import obsnl.design.sensors as mod
    from obsnl.design.sufficiency import Sufficiency

    real = mod.check_sensors

    def flaky(model, names, targets, **kw):
        if tuple(names) == ("a1", "a2"):
            return Sufficiency(tuple(names), None, undecided=tuple(targets), reason="time limit reached")
        return real(model, names, targets, **kw)

    monkeypatch.setattr(mod, "check_sensors", flaky)
    path = tmp_path / "sep.json"
    path.write_text(json.dumps(SEPARATE.to_dict()), encoding="utf-8")
    assert main(["sensors", str(path), "--format", "json", "--seed", "5"]) == 2
    cap = capsys.readouterr()
    assert json.loads(cap.out)["undecided_sets"] == [["a1", "a2"]]  # the answer is printed first
    assert cap.err.count("\n") == 1 and "undecided" in cap.err and "{a1, a2}" in cap.err


@pytest.mark.parametrize("command", [["analyze"], ["sensors"], ["design"]])
def test_record_of_a_model_with_two_inputs_is_refused_in_one_line(tmp_path, capsys, command):
    # a record drives one known input; SEPARATE has two (u1, u2), so each command refuses before any work
    path = tmp_path / "sep.json"
    path.write_text(json.dumps(SEPARATE.to_dict()), encoding="utf-8")
    rec = tmp_path / "rec.csv"
    rec.write_text("time_s,accel_m_s2\n" + "\n".join(f"{0.01 * i:.2f},{np.sin(0.1 * i):.6f}" for i in range(50)) + "\n",
                   encoding="utf-8")
    assert main([*command, str(path), "--record", str(rec)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--record drives one input" in err and "has 2" in err
