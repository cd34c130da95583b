"""The sensor search stops when its answer is complete, and refuses only a size it has to enumerate (issue 41:
``sensors --target k0`` was refused with "118,755 sets to examine" although size 1 already held the whole answer).

The expected answers are derived from the dependency graph in each test: in these models the parts do not
interact, so an output reveals only the parameters of the state it measures, and a set reveals a target exactly
when it measures that target's state (each part alone, ``x' = -a x + u`` measured as ``c x``, is identifiable).
"""

from __future__ import annotations

import itertools
import json
import time

import obsnl
from obsnl import Model
from obsnl.cli import main
from obsnl.design.sensors import _largest_without


def _spread(n: int) -> Model:
    """x0 with k0, measured by y0 only; x1 with a, measured by n other outputs (none of which sees k0)."""
    return Model(name="spread", states=["x0", "x1"], parameters=["k0", "a"], inputs=["u"],
                 equations={"x0": "u - k0*x0", "x1": "u - a*x1"},
                 outputs={"y0": "x0", **{f"y{i}": f"{i}*x1" for i in range(1, n + 1)}})


def _pairs(n: int) -> Model:
    """Two decoupled states, ``n`` outputs of each: every minimal set is a pair, no sensor suffices alone."""
    return Model(name="pairs", states=["x", "z"], parameters=["a", "b"], inputs=["u"],
                 equations={"x": "u - a*x", "z": "u - b*z"},
                 outputs={**{f"a{i}": f"{i + 1}*x" for i in range(n)}, **{f"b{i}": f"{i + 1}*z" for i in range(n)}})


def test_one_sensor_that_suffices_alone_ends_the_search_with_the_complete_answer():
    # k0 acts on x0 only, which only y0 measures: {y0} is the one minimal set of any size, and the 29 others
    # together (a subset of every set without y0) never reach k0. Before: sets of 5 were refused (118,755 of them).
    t0, seen = time.perf_counter(), []
    res = obsnl.sensors(_spread(29), target="k0", progress=seen.append)
    assert time.perf_counter() - t0 < 20
    assert sum(seen) == 2 ** 30 - 1  # every set is decided: the larger ones by the completeness proof
    assert res.minimal_sets == (("y0",),) and res.complete and not res.none_exists
    others = res.answer([f"y{i}" for i in range(1, 30)])
    assert others is not None and others.sufficient is False and others.how == "reachability"
    assert res.analyses <= 3
    assert "of any size" in res.summary()


def test_the_command_line_answers_without_a_max_size(tmp_path, capsys):
    m = _spread(29)
    path = tmp_path / "spread.json"
    path.write_text(json.dumps(m.to_dict()), encoding="utf-8")
    assert main(["sensors", str(path), "--target", "k0", "--format", "json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["minimal_sets"] == [["y0"]] and out["complete"] is True


def test_pairs_needed_end_after_size_2_instead_of_refusing_size_4():
    # every minimal set is one a-output and one b-output (derived: a is seen only through x, b only through z)
    res = obsnl.sensors(_pairs(30), target=["a", "b"], max_size=4)
    expected = {frozenset((f"a{i}", f"b{j}")) for i in range(30) for j in range(30)}
    assert {frozenset(s) for s in res.minimal_sets} == expected and res.complete


def test_a_search_that_stops_early_still_lists_every_minimal_set_of_a_full_search():
    # small enough to search every size: stopping early must give the same minimal sets
    m = Model(name="mixed", states=["x", "z"], parameters=["a", "b"], inputs=["u"],
              equations={"x": "u - a*x", "z": "u - b*z"},
              outputs={"s": "x + 2*z", "a1": "x", "a2": "3*x", "b1": "z", "b2": "5*z"})
    res = obsnl.sensors(m, target=["a", "b"], max_size=2)
    # derived: s alone sees both states; otherwise one of {a1, a2} and one of {b1, b2}
    expected = {frozenset(["s"])} | {frozenset(p) for p in itertools.product(["a1", "a2"], ["b1", "b2"])}
    assert {frozenset(s) for s in res.minimal_sets} == expected and res.complete


def test_the_largest_sets_without_a_minimal_set():
    # a set contains neither {a} nor {b, c} iff it lacks a and lacks b or c: within {b, d} or {c, d}
    assert _largest_without(["a", "b", "c", "d"], [("a",), ("b", "c")]) == [("b", "d"), ("c", "d")]
    assert _largest_without(["a", "b"], [("a",), ("b",)]) == [()]
