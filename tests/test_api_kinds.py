"""Arguments of the wrong kind, levels beyond double precision and degenerate information: each refused or
reported with one line that names it, never a raw Python error deep inside nor a silently wrong number.

Data come from closed forms (a mass-spring-damper's steady response), never from obsnl's simulator; the
expected answers are derived here. Every check is exact (no randomness beyond fixed noise seeds)."""

from __future__ import annotations

import numpy as np
import pytest

import obsnl
from obsnl.cli import main
from obsnl.errors import DataError, OptionError
from obsnl.estimation.codegen import to_casadi

MSD = obsnl.Model(name="msd", states=["x", "v"], parameters=["k", "c"], inputs=["u"],
                  equations={"x": "v", "v": "u - k*x - c*v"}, outputs={"y": "x"}, guess={"k": 20.0, "c": 1.0})
T = np.arange(300) * 0.02


def _columns(scale_u: float = 1.0) -> dict[str, np.ndarray]:
    # steady response of x'' + c x' + k x = sin(w t) with k = 25, c = 0.8: amplitude 1 / |k - w^2 + i c w|
    w, k, c = 3.1, 25.0, 0.8
    h = 1.0 / complex(k - w * w, c * w)
    y = abs(h) * np.sin(w * T + np.angle(h))
    return {"t": T, "u": scale_u * np.sin(w * T), "y": y + 1e-3 * np.random.default_rng(0).standard_normal(T.size)}


@pytest.mark.parametrize("kwargs, words", [
    (dict(noise=0.01), "noise= takes {channel: ratio}"),
    (dict(noise=[0.01]), "noise= takes {channel: ratio}"),
    (dict(guess=1.0), "guess= takes {parameter: value}"),
    (dict(guess={"c": "abc"}), "guess= gives c = 'abc'; give a number"),
    (dict(guess={"c": None}), "guess= gives c = None; give a number"),
    (dict(guess={"c": True}), "guess= gives c = True; give a number"),
    (dict(refine="no"), "refine= takes True or False, got 'no'"),
    (dict(hold=1), "hold= takes True or False, got 1"),
    (dict(noise={"y": 1e-160}), "must lie in [1e-12, 1)"),
    (dict(noise={"y": True}), "the noise= ratio y=True"),
])
def test_identify_refuses_arguments_of_the_wrong_kind(kwargs, words):
    with pytest.raises(OptionError) as info:
        obsnl.identify(MSD, _columns(), progress=False, **kwargs)
    assert words in str(info.value) and "\n" not in str(info.value)


def test_identify_refuses_data_that_are_not_data():
    with pytest.raises(DataError, match="data= takes a CSV file, a mapping of columns"):
        obsnl.identify(MSD, None)


@pytest.mark.parametrize("noise", ["high", True, -0.01, float("nan"), None])
def test_a_study_refuses_a_noise_ratio_of_the_wrong_kind_before_any_work(noise, monkeypatch):
    # a text reached math.isfinite after the structural analysis: a raw TypeError
    import obsnl.identification.identify as ident
    from obsnl.estimation.accelerogram import Record

    monkeypatch.setattr(ident, "run_analysis", _no_analysis)
    model = MSD.replace(values={"k": 25.0, "c": 0.8})
    with pytest.raises(OptionError) as info:
        ident.study(model, Record("r", list(np.sin(3.1 * T)), 0.02), noise=noise, progress=False)
    assert "noise= takes one noise-to-signal ratio > 0 for every channel" in str(info.value)
    assert "\n" not in str(info.value)


def test_a_misspelt_guess_is_refused_before_the_structural_analysis(monkeypatch):
    # the guesses were checked after the analysis and the compilation
    import obsnl.identification.identify as ident

    monkeypatch.setattr(ident, "run_analysis", _no_analysis)
    with pytest.raises(OptionError, match="guess= names 'kk', which is not a parameter of 'msd'"):
        obsnl.identify(MSD, _columns(), guess={"kk": 3.0}, progress=False)


@pytest.mark.parametrize("worker, words", [
    ("obsnl.observability.analyze:run_analysis", "run_analysis takes the CheckedAnalysis"),
    ("obsnl.identification.identify:run_identification", "run_identification takes the CheckedIdentification"),
    ("obsnl.observability.certificates.symmetry:symmetries_of", "symmetries_of takes an obsnl Model"),
])
def test_a_worker_refuses_what_its_door_did_not_check_in_one_line(worker, words):
    # each raised an AttributeError ('int' object has no attribute 'model', 'is_smooth')
    import importlib

    module, name = worker.split(":")
    with pytest.raises(obsnl.errors.ObsnlError) as info:
        getattr(importlib.import_module(module), name)(3)
    assert words in str(info.value) and "got int" in str(info.value) and "\n" not in str(info.value)


def _no_analysis(*a, **k):
    raise AssertionError("the structural analysis ran before the arguments were checked")


def test_an_input_too_small_to_move_the_model_is_named_not_an_index_error():
    # 1e-170 N moves the states to ~1e-172: their squares underflow to 0, so the filter has no scale to work with
    with pytest.raises(DataError, match=r"the inputs move no state \(largest \|input\| 1e-170\)"):
        obsnl.identify(MSD, _columns(scale_u=1e-170), progress=False)


def test_a_guess_that_makes_the_model_diverge_is_named():
    # k = -1e6: the 'spring' pushes the mass away at exp(1000 t), and the simulation at the guess overflows within
    # a few samples; c = 1e20: one step of the damper overflows (it ended in "Q contains NaN/inf", naming nothing)
    with pytest.raises(DataError, match="left the finite numbers at sample .* when simulated at the guess"):
        obsnl.identify(MSD, _columns(), guess={"k": -1e6}, progress=False)
    with pytest.raises(obsnl.errors.EstimatorError, match="the step of 'msd' overflows at the guess: give guesses"):
        obsnl.identify(MSD, _columns(), guess={"c": 1e20}, progress=False)


def test_the_command_line_refuses_a_channel_given_twice(tmp_path, capsys):
    csv = tmp_path / "d.csv"
    cols = _columns()
    csv.write_text("t,u,y\n" + "\n".join(f"{a!r},{b!r},{c!r}" for a, b, c in zip(*cols.values())), encoding="utf-8")
    model = tmp_path / "msd.toml"
    model.write_text('name = "msd"\nstates = ["x", "v"]\nparameters = ["k", "c"]\ninputs = ["u"]\n'
                     '[equations]\nx = "v"\nv = "u - k*x - c*v"\n[outputs]\ny = "x"\n[guess]\nk = 20.0\nc = 1.0\n',
                     encoding="utf-8")
    for extra in (["--noise", "y=0.01", "--noise", "y=0.02"], ["--noise", "0.01", "--noise", "0.02"],
                  ["--guess", "k=20", "--guess", "k=30"]):
        assert main(["identify", str(model), "--data", str(csv), "--no-refine", *extra]) == 2
        err = capsys.readouterr().err.strip()
        assert "twice" in err and "give it once" in err and len(err.splitlines()) == 1, err


@pytest.mark.parametrize("column, words", [
    (np.sin(T) + 1j, "holds complex numbers"),                       # read as floats: the imaginary part dropped
    (np.arange(T.size).astype("datetime64[ms]"), "holds dates"),        # read as floats: milliseconds as seconds
    (np.sin(T) > 0, "holds booleans"),
    (np.ma.masked_array(np.sin(T), mask=T > 5.0), "holds masked samples"),  # the mask would be ignored
    ([10 ** 400] * T.size, "is not numeric (or beyond the float range)"),   # OverflowError before
])
def test_data_columns_of_the_wrong_kind_are_refused(column, words):
    cols = _columns() | {"u": column}
    with pytest.raises(DataError) as info:
        obsnl.identify(MSD, cols, progress=False)
    assert words in str(info.value) and "\n" not in str(info.value)


# ----------------------------------------------------------------------------- the rest of the flat API
FRICTION = "obsnl:coulomb_friction"


@pytest.mark.parametrize("call, words", [
    # each raised an AttributeError or a TypeError from deep inside (open(3) would even read file descriptor 3)
    (lambda: obsnl.symmetries(3), "a model is an obsnl Model, the path of a .toml or .json model file or obsnl:NAME"),
    (lambda: obsnl.reparametrize(None), "a model is an obsnl Model"),
    (lambda: obsnl.identifiable_functions({"name": "m"}), "a model is an obsnl Model"),
    (lambda: obsnl.symmetries(obsnl.Model(name="s", states=["x"], parameters=["a"], equations={"x": "-a*x"},
                                          outputs={"y": "x"}), seed="a"), "seed must be a non-negative integer"),
    (lambda: obsnl.read_record(3), "read_record takes the path of a record file (text or a path), got int 3"),
    (lambda: obsnl.read_measured(3, inputs=["u"], outputs=["y"]), "read_measured takes the path of a CSV file"),
    (lambda: obsnl.analyze(FRICTION, branches=3), "branches= takes labels"),
    (lambda: obsnl.analyze(FRICTION, branches=["a", 1]), "branches= takes labels"),
    # 0 seeds ran the whole tuning and ended in an IndexError; passes=0 did the same; "5" a TypeError
    (lambda: obsnl.reproduce(seeds=0), "seeds= takes a whole number >= 1, got 0"),
    (lambda: obsnl.reproduce(tuning_seeds="2"), "tuning_seeds= takes a whole number >= 1, got '2'"),
    (lambda: obsnl.reproduce(passes=0), "passes= must be at least 1"),
    (lambda: obsnl.reproduce(samples="5"), "samples= takes a whole number of samples"),
    # the rooms' entries that take a Model: an AttributeError deep inside before
    (lambda: obsnl.model.split_branches(3), "split_branches takes an obsnl Model, got int"),
    (lambda: to_casadi("m.toml"), "to_casadi takes an obsnl Model, got str"),
], ids=["symmetries-model", "reparametrize-model", "identifiable-model", "symmetries-seed", "read_record",
        "read_measured", "analyze-branches-int", "analyze-branches-mixed", "reproduce-seeds", "reproduce-tuning",
        "reproduce-passes", "reproduce-samples", "split_branches", "to_casadi"])
def test_the_flat_api_refuses_arguments_of_the_wrong_kind_in_one_line(call, words):
    with pytest.raises(obsnl.ObsnlError) as info:
        call()
    assert str(info.value).startswith(words) and "\n" not in str(info.value), str(info.value)


def test_a_model_file_is_taken_where_a_model_is_and_labels_as_the_command_line_writes_them():
    """As analyze and identify do, symmetries, reparametrize and identifiable_functions read a model's file; analyze
    reads ``branches="a"`` as the label a (``"ab"`` would be one label, never a and b)."""
    assert obsnl.reparametrize(FRICTION).model.name.startswith("coulomb_friction")
    assert [b.label for b in obsnl.analyze(FRICTION, branches="a", seed=0).branches] == ["a"]
    with pytest.raises(obsnl.ObsnlError, match="'ab'"):
        obsnl.analyze(FRICTION, branches="ab", seed=0)
