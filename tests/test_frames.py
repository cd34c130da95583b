"""Results in pandas and records as pandas DataFrames (issue 43 item 3): ``to_frame()`` holds what the JSON holds,
and a DataFrame record gives the same estimates, scores and design as the CSV or the columns it was made from. The
record comes from scipy's solve_ivp (never obsnl's simulator), with a fixed seed (deterministic)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy.integrate import solve_ivp

import obsnl
from obsnl.errors import DataError, OptionError
from obsnl.estimation.measured import frame_columns, measured

from .radau_data import noisy, write_csv

SDOF = obsnl.Model(name="sdof", states=["x", "v"], parameters=["k", "c"], inputs=["F"],
                   equations={"x": "v", "v": "F - k*x - c*v"}, outputs={"y": "x"}, guess={"k": 30.0, "c": 0.8})
TRUE = {"k": 25.0, "c": 0.5}


@pytest.fixture(scope="module")
def record():
    t = np.arange(600) * 0.02
    F = np.sin(2 * np.pi * 0.5 * t) + 0.6 * np.sin(2 * np.pi * 1.3 * t + 0.4)
    sol = solve_ivp(lambda s, z: [z[1], np.interp(s, t, F) - TRUE["k"] * z[0] - TRUE["c"] * z[1]], (0, t[-1]),
                    [0.0, 0.0], t_eval=t, rtol=1e-10, atol=1e-12, max_step=0.02)
    return pd.DataFrame({"time_s": t, "F": F, "y": noisy(sol.y[0], 0.01, np.random.default_rng(3))})


@pytest.fixture(scope="module")
def runs(record, tmp_path_factory):
    path = write_csv(tmp_path_factory.mktemp("frame") / "sdof.csv", {c: record[c].to_numpy() for c in record})
    kw = dict(jit=False, intersample="linear", progress=False, passes=2)
    from_csv = obsnl.identify(SDOF, str(path), **kw)
    indexed = record.set_index("time_s")  # the time as a float index
    return from_csv, obsnl.identify(SDOF, indexed, **kw), path


def test_a_dataframe_record_gives_the_estimates_of_the_csv(runs):
    from_csv, from_frame, _ = runs
    for a, b in zip(from_csv.parameters, from_frame.parameters):
        assert a.estimate == pytest.approx(b.estimate, rel=1e-9) and a.std == pytest.approx(b.std, rel=1e-6)
        assert a.estimate == pytest.approx(TRUE[a.name], rel=0.02)  # and the truth is found


def test_to_frame_holds_what_the_json_holds(runs):
    res = runs[0]
    frame, doc = res.to_frame(), res.to_dict()
    assert list(frame.index) == [p["name"] for p in doc["parameters"]]
    for p in doc["parameters"]:
        row = frame.loc[p["name"]]
        for key in ("estimate", "std", "guess"):
            assert row[key] == pytest.approx(p[key], rel=1e-15)
        assert [row["interval_low"], row["interval_high"]] == pytest.approx(p["interval"], rel=1e-15)
        assert (row["held"], row["flagged"], row["interval_method"]) == (p["held"], p["flagged"],
                                                                         p["interval_method"])
        assert row["reason"] == p["reason"] or (row["reason"] is None and p["reason"] is None)


def test_validation_takes_a_dataframe_and_its_frame_holds_the_json(runs, record):
    res, _, path = runs
    by_csv = res.simulate(str(path))
    by_frame = res.simulate(record)
    frame, doc = by_frame.to_frame(), by_frame.to_dict()
    assert list(frame.index) == list(doc["outputs"]) == ["y"]
    for key in ("rmse", "nrmse", "fit_percent", "db"):
        assert frame.loc["y", key] == pytest.approx(doc["outputs"]["y"][key], rel=1e-15)
        assert by_csv.outputs["y"].to_dict()[key] == pytest.approx(doc["outputs"]["y"][key], rel=1e-9)
    # and obsnl.simulate itself
    again = obsnl.simulate(SDOF, {p.name: p.estimate for p in res.parameters}, record)
    assert again.outputs["y"].rmse == pytest.approx(by_frame.outputs["y"].rmse, rel=1e-12)


def test_a_datetime_index_is_read_as_seconds_from_the_first_sample(record):
    stamped = record.drop(columns="time_s").set_index(
        pd.date_range("2024-05-01 12:00", periods=len(record), freq="20ms"))
    a = measured(stamped, inputs=["F"], outputs=["y"])
    b = measured({c: record[c].to_numpy() for c in record}, inputs=["F"], outputs=["y"])
    assert a.dt == pytest.approx(0.02, rel=1e-12) and np.array_equal(a.y, b.y) and np.array_equal(a.u, b.u)
    assert frame_columns(stamped)["time_s"][-1] == pytest.approx(0.02 * (len(record) - 1), rel=1e-12)


def test_a_frame_without_a_time_is_refused_in_one_line(record):
    with pytest.raises(DataError, match="no time column and its index is not a time") as err:
        measured(record.drop(columns="time_s"), inputs=["F"], outputs=["y"])  # a RangeIndex: sample numbers
    assert "\n" not in str(err.value) and "time_s" in str(err.value)
    with pytest.raises(DataError, match="distinct names"):
        measured(pd.DataFrame(np.zeros((3, 3)), columns=["time_s", "F", "F"]), inputs=["F"], outputs=["y"])


def test_design_takes_dataframes(record):
    gap = obsnl.Model(name="gap", states=["x", "v"], parameters=["c", "k", "kc", "g"], inputs=["u"],
                      equations={"x": "v", "v": "u - c*v - k*x - kc*Max(x - g, 0)"}, outputs={"y": "x"},
                      values={"c": 0.5, "k": 4.0, "kc": 40.0, "g": 0.1})
    from obsnl.design import design

    t = np.linspace(0.0, 4.0, 81)
    by_tuple = design(gap, [("push", t, {"u": np.sin(2 * t)})], scales=[0.125, 0.25, 1.0, 2.0])
    frame = pd.DataFrame({"u": np.sin(2 * t), "note": 1.0}, index=pd.Index(t, name="seconds"))
    by_frame = design(gap, frame, scales=[0.125, 0.25, 1.0, 2.0])
    assert math.isclose(by_frame.min_scale, by_tuple.min_scale, rel_tol=1e-12)
    assert by_frame.sufficient_records == (("record 1",),)
    with pytest.raises(OptionError, match="no column for the input 'u'"):
        design(gap, [frame.rename(columns={"u": "w"})])


def test_notebook_html_of_the_results(runs):
    # each result's _repr_html_ holds its numbers (from its own to_dict, rounded as shown) and escapes its text
    res = runs[0]
    html = res._repr_html_()
    assert html.startswith("<div>") and "<table" in html
    for p in res.to_dict()["parameters"]:
        assert f"{p['estimate']:.4g}" in html and f"{p['std']:.2g}" in html
    val = res.simulate(runs[2])
    assert f"{val.to_dict()['outputs']['y']['rmse']:.4g}" in val._repr_html_()
    m = obsnl.Model(name="a<b", states=["x"], parameters=["a"], equations={"x": "-a*x"}, outputs={"y": "x"})
    shown = obsnl.analyze(m, seed=0)._repr_html_()
    assert "a&lt;b" in shown and "a<b" not in shown and "Observable" in shown
    modal = res.modal()
    assert f"{modal.frequency_hz[0]:.4g}" in modal._repr_html_()
    search = obsnl.sensors(m, target="all")
    assert "minimal set" in search._repr_html_()
