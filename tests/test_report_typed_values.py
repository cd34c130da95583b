"""The renderers of obsnl.report read the typed result values (issue 42, "typed results end to end"): each is given a
small value built here by hand and its text is compared with the rows written out below (never with obsnl's own output
captured at run time)."""

from __future__ import annotations

import math

from obsnl.design.ranking import RankedSet, Ranking
from obsnl.design.sensor_search import SensorSearch
from obsnl.report.sensors import render_sensors


# ----------------------------------------------------------------------------- the sensor ranking
def _ranked_search() -> SensorSearch:
    rows = (
        RankedSet(
            sensors=("x", "v"), worst_relative_std=0.0123, worst="k", log_det_fim=12.345, relative_std=(0.0123, 0.001)
        ),
        RankedSet(
            sensors=("x",), worst_relative_std=math.inf, worst="c", log_det_fim=-math.inf, relative_std=(0.5, math.inf)
        ),
    )
    ranking = Ranking(
        rows=rows,
        parameters=("k", "c"),
        nuisance=(),
        noise_level={"x": 0.01, "v": 0.01},
        noise_std={"x": 0.1, "v": 0.2},
        samples=10,
        dt=0.1,
        seconds=0.0,
    )
    return SensorSearch(
        model="m",
        candidates=("x", "v"),
        targets=("k", "c"),
        max_size=2,
        minimal_sets=(),
        ranking=ranking,
        effective_independence=("v", "x"),
    )


def test_the_sensor_ranking_is_rendered_from_its_ranked_sets():
    search = _ranked_search()
    text = render_sensors(search, "text").splitlines()
    start = text.index("ranking along the record (Cramer-Rao bound, best first):")
    # 3 significant digits; an infinity keeps its sign; the set effective independence chose (the same sensors in
    # another order) is marked
    assert text[start + 1 : start + 3] == [
        "  {x, v}: worst relative std 0.0123 (k), log det FIM 12.3  <- effective independence",
        "  {x}: worst relative std inf (c), log det FIM -inf",
    ]
    md = render_sensors(search, "md").splitlines()
    assert "| 1 | {x, v} | 0.0123 | k | 12.3 | chosen |" in md
    assert "| 2 | {x} | inf | c | -inf |  |" in md
    tex = render_sensors(search, "tex").splitlines()
    assert r"1 & \{\texttt{x}, \texttt{v}\} & 0.0123 & 12.3 \\" in tex
    assert r"2 & \{\texttt{x}\} & inf & -inf \\" in tex


def test_no_set_is_marked_without_an_effective_independence_choice():
    search = _ranked_search()
    plain = SensorSearch(
        model=search.model,
        candidates=search.candidates,
        targets=search.targets,
        max_size=2,
        minimal_sets=(),
        ranking=search.ranking,
    )
    text = render_sensors(plain, "text")
    assert "  {x, v}: worst relative std 0.0123 (k), log det FIM 12.3\n" in text
    assert "effective independence" not in text
    assert "| 1 | {x, v} | 0.0123 | k | 12.3 |  |" in render_sensors(plain, "md").splitlines()


# ----------------------------------------------------------------------------- the validation figure's titles
def test_the_validation_panels_are_titled_from_the_typed_scores():
    from obsnl.identification.validation.merit import OutputScore
    from obsnl.report.identification.validation import _title

    # RMSE in 4 significant digits, fit % with 2 decimals; a constant measured output has no fit (None), an output
    # without a score gets n/a for both
    assert _title("y", OutputScore("y", 0.012345, 0.1, 90.0, -20.0)) == "y: RMSE 0.01235, fit 90.00 %"
    assert _title("y", OutputScore("y", 2.0, None, None, 6.0)) == "y: RMSE 2, fit n/a %"
    assert _title("y", None) == "y: RMSE n/a, fit n/a %"
