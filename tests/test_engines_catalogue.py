"""Every published peer case gives exactly its stated classes, under both engines where they apply.

Expected answers are read from the case files (``expected``, ``expected_unknown_inputs``), never from
obsnl's own output. The randomized verdicts use fixed seeds; every run asserts the reported lower
bound on the probability of a right answer (>= 0.99, Sedoglavic's Prop. 3.3, see obsnl.algebra.bounds), so a
spurious failure has probability below 1e-2 per case and in practice far below (full-rank results
are certificates; unobservable ones are confirmed by a second independent run).
"""

from __future__ import annotations

import pytest

import ast
import json
import time

from obsnl import Verdict, analyze, read_model
from obsnl.model.bounds.textsize import check_expression_size
from tests.conftest import PEER_CASE_FILES, PEER_CASES

#: Cases on which the symbolic ORC swells past its limits (measured: 2.9M-term Lie derivatives for
#: genssi_arabidopsis, >10 s per derivative for the others, a Lie derivative past 2 million terms after
#: about 6 s for si_bench_qy). The ORC then answers INCONCLUSIVE (checked on si_bench_qy below), so only
#: the randomized test applies to them.
ORC_SWELLS = {
    "genssi_arabidopsis",
    "genssi_biomd10_mapk",
    "genssi_hiv",
    "si_bench_clv1_2out",
    "si_bench_mapk_5out",
    "si_bench_qy",
}

CASES = [pytest.param(p, id=p.stem) for p in PEER_CASE_FILES]


def _check_case(path, method: str) -> None:
    model = read_model(path)
    expected = model.metadata["expected"]
    result = analyze(model, method=method, seed=20240611, max_seconds=120)
    assert all(b.verdict is not Verdict.INCONCLUSIVE for b in result.branches), [b.reason for b in result.branches]
    assert result.probability >= 0.99
    observable, unobservable = set(result.overall_observable), set(result.overall_unobservable)
    assert not observable & unobservable
    known = {s.name for s in model.known_initial_conditions}
    listed = set(expected["identifiable"]) | set(expected["nonidentifiable"])
    unknowns = {s.name for s in model.states if s.name not in known} | {s.name for s in model.parameters}
    assert unknowns <= listed, "the case file must classify every unknown"
    # exactly the stated classes: a state with a known initial value is observable (its value is known)
    assert unobservable == set(expected["nonidentifiable"])
    assert observable == set(result.variables) - set(expected["nonidentifiable"])
    if "expected_unknown_inputs" in model.metadata:
        exp_ui = model.metadata["expected_unknown_inputs"]
        (branch,) = result.branches
        assert set(branch.unknown_inputs["observable"]) == set(exp_ui["observable"])
        assert set(branch.unknown_inputs["unobservable"]) == set(exp_ui["unobservable"])


@pytest.mark.parametrize("path", CASES)
def test_randomized_test_reproduces_published_classes(path) -> None:
    _check_case(path, "sedoglavic")


@pytest.mark.parametrize("path", CASES)
def test_orc_reproduces_published_classes(path) -> None:
    if path.stem in ORC_SWELLS:
        pytest.skip("symbolic Lie derivatives swell past the ORC's limits on this case (see ORC_SWELLS)")
    _check_case(path, "orc")


def test_orc_exclusions_are_real_cases() -> None:
    names = {p.stem for p in PEER_CASE_FILES}
    assert ORC_SWELLS <= names


# ----------------------------------------------------------------------------- the largest published case
# The QY benchmark of StructuralIdentifiability.jl: one right-hand side of 14 kB (P4'), refused by the
# old 4000-node bound (issue 26). Its published classes are checked above with the other cases (the
# randomized test: about 1 s); here the size that the bounds must accept, and the ORC's bounded refusal.
QY = PEER_CASES / "si_bench_qy.json"


def test_qy_is_a_case_of_over_12000_nodes_that_loads_within_the_bounds() -> None:
    raw = json.loads(QY.read_text())
    rhs = raw["equations"]["P4"]
    # counted here with Python's own parser, independently of obsnl: every node of the syntax tree (about
    # 12 400, the "12 000 nodes"), of which operations, names and numbers are about 6400
    tree = ast.parse(rhs, mode="eval")
    every = sum(1 for _ in ast.walk(tree))
    operations_and_names = sum(1 for n in ast.walk(tree) if isinstance(n, (ast.BinOp, ast.UnaryOp, ast.Name,
                                                                            ast.Constant)))
    assert every > 12000 and operations_and_names > 6000 > 4000 and len(rhs) > 14000
    check_expression_size(rhs, "P4")  # no refusal
    t0 = time.perf_counter()
    model = read_model(QY)
    assert time.perf_counter() - t0 < 10
    assert [s.name for s in model.states] == raw["states"] and [p.name for p in model.parameters] == raw["parameters"]


@pytest.mark.slow
def test_orc_stops_on_qy_at_the_swell_bound_with_its_reason_and_no_classes() -> None:
    t0 = time.perf_counter()
    result = analyze(read_model(QY), method="orc", seed=0, max_seconds=120)
    assert time.perf_counter() - t0 < 60  # stopped by the term bound (about 6 s), not by the time limit
    (branch,) = result.branches
    assert branch.verdict is Verdict.INCONCLUSIVE and "expression swell" in branch.reason
    assert not result.overall_observable and not result.overall_unobservable  # nothing claimed
