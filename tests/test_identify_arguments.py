"""``obsnl.identify``'s Python arguments checked as strictly as the command line's options (issue 41).

An argument of the wrong kind (``table=5``, ``executor="local"``, ``tuning=(...)``, ``jit="no"``) is refused in one
line naming the argument and the kind it takes, in Python terms, before any work; a text cell of a Python mapping is
read with the CSV reader's rule (``"1_0"`` is refused, where ``float`` reads 10). The hypothesis property extends
the profile of ``tests/test_input_properties.py`` (in ``tests/helpers.py``: derandomized, per-example CPU bound) to
these arguments.

Data: the steady response of a mass-spring-damper, in closed form (no obsnl simulation).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import obsnl
from obsnl.errors import DataError, OptionError

from .helpers import SETTINGS, _check_message, cpu_bounded

MSD = obsnl.Model(name="msd", states=["x", "v"], parameters=["k", "c"], inputs=["u"],
                  equations={"x": "v", "v": "u - k*x - c*v"}, outputs={"y": "x"}, guess={"k": 20.0, "c": 1.0})
T = np.arange(300) * 0.02


def _columns() -> dict[str, np.ndarray]:
    # steady response of x'' + c x' + k x = sin(w t), k = 25, c = 0.8: amplitude and phase of 1 / (k - w^2 + i c w)
    w, k, c = 3.1, 25.0, 0.8
    h = 1.0 / complex(k - w * w, c * w)
    return {"t": T, "u": np.sin(w * T), "y": abs(h) * np.sin(w * T + np.angle(h))
            + 1e-3 * np.random.default_rng(0).standard_normal(T.size)}


@pytest.mark.parametrize("kwargs, words", [
    ({"table": 5}, "table= takes a BranchTable or the path of a branch-table file, got 5"),
    ({"executor": "local"}, "executor= takes an obsnl.executor.Executor"),
    ({"tuning": (0.3, 0.0, 1.0)}, "tuning= takes one Tuning"),
    ({"jit": "no"}, "jit= takes True, False or None"),
    ({"jit": 0}, "jit= takes True, False or None"),
    ({"seed": "0"}, "seed= takes an integer >= 0, got '0'"),
    ({"seed": -1}, "seed= takes an integer >= 0, got -1"),
    ({"progress": "yes"}, "progress= takes True, False or a callable"),
])
def test_identify_refuses_python_arguments_of_the_wrong_kind(kwargs, words):
    with pytest.raises(OptionError) as info:
        obsnl.identify(MSD, _columns(), **kwargs)
    assert words in str(info.value) and "\n" not in str(info.value)


def test_study_checks_the_same_arguments():
    from obsnl.identification.identify import study

    with pytest.raises(OptionError, match="tuning= takes one Tuning"):
        study(MSD, "no-record.csv", tuning=[0.3, 0.0, 1.0])


def test_a_text_cell_written_with_an_underscore_is_refused_as_the_csv_reader_refuses_it():
    cols = {k: [str(v) for v in a] for k, a in _columns().items()}
    cols["u"][5] = "1_0"  # float("1_0") is 10: the CSV reader refuses the cell, so must a Python mapping
    with pytest.raises(DataError, match=r"column 'u' is not numeric .*'1_0' is written with '_'"):
        obsnl.identify(MSD, cols, progress=False)


def test_text_cells_in_plain_digits_are_read():
    from obsnl.estimation.measured import measured

    m = measured({"t": ["0", "0.5", "1"], "u": [" 2.5e-3 ", "1", 2], "y": ["0", "1", "nan"]}, inputs=["u"],
                 outputs=["y"])
    assert m.u.ravel().tolist() == [0.0025, 1.0, 2.0] and m.missing == {"y": 1}


_WRONG = st.one_of(st.integers(-3, 3), st.floats(allow_nan=True), st.text(max_size=8), st.none(),
                   st.lists(st.floats(0, 1), max_size=3).map(tuple), st.just(object()), st.booleans())
_ARGUMENTS = {
    "table": _WRONG.filter(lambda v: v is not None and not isinstance(v, str)),
    "tuning": _WRONG.filter(lambda v: v is not None),
    "executor": _WRONG.filter(lambda v: v is not None),
    "jit": _WRONG.filter(lambda v: v is not None and not isinstance(v, bool)),
    "seed": _WRONG.filter(lambda v: isinstance(v, bool) or not isinstance(v, int) or v < 0),
    "refine": _WRONG.filter(lambda v: not isinstance(v, bool)),
    "hold": _WRONG.filter(lambda v: not isinstance(v, bool)),
    "allow_unidentifiable": _WRONG.filter(lambda v: not isinstance(v, bool)),
    "guess": _WRONG.filter(lambda v: v is not None),
    "noise": _WRONG.filter(lambda v: v is not None),
    "progress": _WRONG.filter(lambda v: v is not None and not isinstance(v, bool)),
    "known_initial": _WRONG.filter(lambda v: v is not None),
}


@SETTINGS
@given(data=st.data())
@cpu_bounded
def test_identify_refuses_any_python_argument_of_the_wrong_kind_in_one_line(data):
    name = data.draw(st.sampled_from(sorted(_ARGUMENTS)), label="argument")
    value = data.draw(_ARGUMENTS[name], label="value")
    with pytest.raises(Exception) as info:  # the kind is checked by _check_message
        obsnl.identify(MSD, _columns(), passes=1, **{name: value})
    _check_message(info.value)
    assert f"{name}=" in str(info.value), str(info.value)
