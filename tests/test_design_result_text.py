"""The design's answer follows the rule of every result value (tests/test_result_text.py): a one-line ``repr``
(at most 160 characters, the class name and its headline) and a short ``summary()`` (at most 12 lines, the
answer first). Before, ``ExperimentDesign`` had no ``summary`` and its ``repr`` was the dataclass dump, every
visited scale included (several kB for the README's gap oscillator under one sine).

The design is built by hand with the fields ``design`` fills, many scales and many records, so that the cut to
one line and to a dozen lines is exercised without simulating anything.
"""

from __future__ import annotations

from dataclasses import replace

from obsnl.design.experiment import ExperimentDesign, ScaleVisit, VisitedBranch
from tests.test_result_text import _check  # the rule every result value follows

SCALES = [2.0 ** k for k in range(-10, 11)]  # the default grid: 21 scales
RECORDS = tuple(f"record_{i}" for i in range(12))


def _visit(scale: float) -> ScaleVisit:
    closed = scale >= 1.0  # below 1 the gap g - x never closes: branch (a) only, kc and g not identifiable
    branches = (VisitedBranch((1,), "a", 9.0), VisitedBranch((-1,), "b", 1.0)) if closed else \
        (VisitedBranch((1,), "a", 10.0),)
    return ScaleVisit(scale, branches, {"g - x": 2 if closed else 0}, closed,
                      missing=() if closed else ("kc", "g"), reason="" if closed else "kc, g not jointly identifiable")


DESIGN = ExperimentDesign(
    model="gap", targets=("x", "v", "c", "k", "kc", "g"), sensors=("disp",), records=RECORDS, switching=("g - x",),
    visits=tuple(_visit(s) for s in SCALES), min_scale=1.0, bracket=(0.5, 1.0), status="found",
    reason="scale 1 suffices, 0.5 does not", tol=0.001, sufficient_records=tuple((r,) for r in RECORDS),
    analyses=2, seed=0)


def test_design_has_a_one_line_repr_and_a_short_summary() -> None:
    _check(DESIGN, "model='gap'", "gap")
    assert "min_scale=1.0" in repr(DESIGN)
    assert "found" in DESIGN.summary().splitlines()[0]
    assert "scale 1 suffices, 0.5 does not" in DESIGN.summary()


def test_design_summary_says_when_no_scale_is_known() -> None:
    none = replace(DESIGN, min_scale=None, bracket=(1024.0, None), status="none_suffices",
                   reason="not even scale 1024 makes kc, g identifiable", sufficient_records=())
    _check(none, "status='none_suffices'", "none_suffices")
    assert "not even scale 1024" in none.summary()


def test_a_repr_of_its_own_changes_nothing_else() -> None:
    assert DESIGN == replace(DESIGN)
    assert DESIGN.to_dict()["min_scale"] == 1.0
