"""The ``[bounds]`` table of a model file and the ``bounds=`` argument of :class:`obsnl.Model`, checked at the door:
every mistake is one ``ModelError`` line naming the entry and the fix (issue 41, declared signs and bounds)."""

from __future__ import annotations

import math

import pytest

from obsnl import Model
from obsnl.cli import main
from obsnl.errors import ModelError


def _model(**extra):
    return Model(name="relay", states=["x", "v"], parameters=["k", "fy"], known_constants=["g"], inputs=["u"],
                 equations={"x": "v", "v": "u - k*x - fy*sign(v) - g*x"}, outputs={"y": "x"}, **extra)


def test_words_pairs_and_infinite_ends_are_read():
    m = _model(bounds={"fy": "positive", "k": [0, "inf"], "g": ("-inf", -1.5)})
    assert dict(m.bounds) == {"fy": (0.0, math.inf), "k": (0.0, math.inf), "g": (-math.inf, -1.5)}
    assert dict(_model(bounds={"fy": "negative"}).bounds) == {"fy": (-math.inf, 0.0)}


@pytest.mark.parametrize("bounds, needle", [
    ({"fz": "positive"}, "bounds.fz: not a declared symbol"),
    ({"x": "positive"}, "'x' is a state; bounds are declared for parameters and known constants only"),
    ({"fy": [2, 1]}, "the lower end must be below the upper one"),
    ({"fy": [1, 1]}, "a value known exactly is a known constant"),
    ({"fy": "big"}, "write [lo, hi]"),
    ({"fy": [0, 1, 2]}, "write [lo, hi]"),
    ({"fy": [True, 2]}, "bounds.fy[0] is a boolean"),
    ({"fy": [0, "lots"]}, "bounds.fy[1] must be a number"),
    ({"fy": [float("nan"), 1]}, "bounds.fy[0] is not a number"),
    ({"fy": ["1_0", 20]}, "bounds.fy[0] must be a number"),
    ([("fy", "positive")], "'bounds' must be a table"),
])
def test_a_bad_bound_is_one_line_naming_it(bounds, needle):
    with pytest.raises(ModelError) as info:
        _model(bounds=bounds)
    assert needle in str(info.value) and "\n" not in str(info.value)


@pytest.mark.parametrize("table", ["values", "guess"])
def test_a_number_outside_its_bounds_is_refused(table):
    with pytest.raises(ModelError, match=rf"{table}.fy = -2 is outside bounds.fy = \[0, inf\]"):
        _model(bounds={"fy": "positive"}, **{table: {"fy": -2.0}})
    assert _model(bounds={"fy": [0, 1]}, **{table: {"fy": 1.0}}).bounds["fy"] == (0.0, 1.0)  # ends included


def test_a_model_file_with_a_bad_bound_exits_2_without_a_traceback(tmp_path, capsys):
    path = tmp_path / "m.toml"
    path.write_text('name = "m"\nstates = ["x"]\nparameters = ["a"]\n[equations]\nx = "-a*x"\n[outputs]\ny = "x"\n'
                    '[bounds]\na = [3, -3]\n', encoding="utf-8")
    assert main(["show", str(path)]) == 2
    err = capsys.readouterr().err
    assert "bounds.a is [3, -3]" in err and "Traceback" not in err
