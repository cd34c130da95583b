"""Hostile input, design commands, second round: ``obsnl sensors``, ``obsnl design``, ``obsnl report``, ``obsnl bank``
and :func:`obsnl.sensors` / :func:`obsnl.design.experiment.design`.

Each test pins one defect the round found (before the fix: a hang, work done then a confusing refusal, files written
into the current folder, or a meaningless request answered); each ends in a one-line refusal now (exit 2 with the
message on stderr, or an :class:`~obsnl.errors.ObsnlError` from Python). What ``tests/test_hostile_design_options.py``
covers (bad values of every option, wrong types) is not repeated.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

import obsnl
from obsnl import Model, ObsnlError
from obsnl.cli import main
from obsnl.design.experiment import design
from obsnl.errors import OptionError
from obsnl.estimation.accelerogram import Record
from tests.test_hostile_design_options import TINY_MODEL as TINY  # one state, one parameter, one input

T = np.arange(200) * 0.01
U = np.sin(5 * T)
GAP = Model(name="gap", states=["x", "v"], parameters=["c", "k", "kc", "g"], inputs=["u"],
            equations={"x": "v", "v": "u - c*v - k*x - kc*Max(x - g, 0)"}, outputs={"y": "x"},
            values={"c": 0.5, "k": 4.0, "kc": 40.0, "g": 0.1})


def _many(n: int) -> Model:
    """One state, ``n`` outputs, each revealing everything alone."""
    return Model(name="many", states=["x"], parameters=["k"], inputs=["u"], equations={"x": "-k*x + u"},
                 outputs={f"y{i}": f"{i + 1}*x" for i in range(n)})


@pytest.fixture()
def files(tmp_path):
    model = tmp_path / "tiny.toml"
    model.write_text(TINY, encoding="utf-8")
    record = tmp_path / "rec.csv"
    record.write_text("time_s,u\n" + "".join(f"{i * 0.01:.2f},{math.sin(i * 0.05):.6f}\n" for i in range(200)),
                      encoding="utf-8")
    return {"dir": tmp_path, "model": str(model), "record": str(record)}


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    capsys.readouterr()
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def _refused(code: int, err: str, *words: str) -> None:
    assert code == 2, err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    for w in words:
        assert w in err, err


# ----------------------------------------------------------------------------- the search stays bounded
def test_many_outputs_that_each_suffice_alone_end_at_once():
    """24 outputs, each sufficient alone: the search enumerated all 2**24 sets (a hang) though each contains one."""
    t0 = time.perf_counter()
    res = obsnl.sensors(_many(24), target="all")
    assert time.perf_counter() - t0 < 10
    assert len(res.minimal_sets) == 24 and res.analyses == 25  # the full set and each sensor alone


def test_the_progress_still_counts_every_set():
    seen: list[int] = []
    obsnl.sensors(_many(6), target="all", progress=seen.append)
    assert sum(seen) == 2 ** 6 - 1


def _quads(n: int) -> Model:
    """Four decoupled states, ``n`` outputs of each: every minimal set has four sensors, one of each state."""
    states, params = ["x", "z", "w", "q"], ["a", "b", "c", "d"]
    return Model(name="quads", states=states, parameters=params,
                 equations={s: f"-{p}*{s}" for s, p in zip(states, params)},
                 outputs={f"{p}{i}": f"{i + 1}*{s}" for s, p in zip(states, params) for i in range(n)})


def test_a_search_size_with_too_many_sets_is_refused_with_the_max_size_that_fits():
    """60 outputs, quadruples needed: sets of 4 sensors are 487 635 (2**60 in all), none of the smaller sizes
    suffices (so the answer is not complete before them); refused, naming --max-size. (With pairs needed the
    search now stops after size 2, its answer complete: tests/test_sensors_search.py.)"""
    with pytest.raises(OptionError, match="max_size= of at most 3") as info:
        obsnl.sensors(_quads(15), target=["a", "b", "c", "d"], max_size=4)
    assert "487,635 sets of 4 sensors" in str(info.value) and "\n" not in str(info.value)


def test_a_search_size_with_too_many_sets_from_the_command_line(capsys, tmp_path):
    import json

    p, m = tmp_path / "quads.json", _quads(15)
    p.write_text(json.dumps({"name": m.name, "states": [s.name for s in m.states],
                             "parameters": [s.name for s in m.parameters],
                             "equations": {s.name: str(e) for s, e in m.equations.items()},
                             "outputs": {n: str(m.outputs[n]) for n in m.output_names}}), encoding="utf-8")
    code, out, err = _run(capsys, "sensors", str(p), "--target", "a,b,c,d", "--max-size", "4")
    _refused(code, err, "--max-size of at most 3")
    assert not out


# ----------------------------------------------------------------------------- meaningless requests
@pytest.mark.parametrize("function", ["sensors", "design"])
def test_target_parameters_of_a_model_without_parameters_is_refused(function):
    """It resolved to no target at all: every sensor set 'sufficed', every scale too (exit 0)."""
    m = Model(name="nop", states=["x"], parameters=[], inputs=["u"], equations={"x": "-x + u"}, outputs={"y": "x"})
    with pytest.raises(OptionError, match="has no parameters"):
        if function == "sensors":
            obsnl.sensors(m, target="parameters")
        else:
            design(m, [("r", T, {"u": U})], scales=[1.0], target="parameters")


def test_a_progress_that_is_neither_a_flag_nor_a_callable_is_refused():
    with pytest.raises(OptionError, match="progress is True, False or a callable"):
        obsnl.sensors(GAP, target="all", progress="yes")


@pytest.mark.parametrize("record", [("r", T, {"u": U, "w": U}), ("r", T, {"U": U, "u": U}),
                                    Record("r", np.c_[U, U], 0.01, channels=("u", "w"))],
                         ids=["tuple", "misspelt", "channels"])
def test_a_record_input_the_model_does_not_have_is_refused_not_ignored(record):
    with pytest.raises(OptionError, match="is not an input of 'gap'"):
        design(GAP, [record], scales=[1.0])


@pytest.mark.parametrize("samples", [U + 1j, U + 0j], ids=["complex", "zero-imaginary"])
def test_a_complex_record_is_refused_not_cast(samples):
    """numpy cast it to float with a ComplexWarning and the imaginary part was dropped."""
    with pytest.raises(OptionError, match="real numbers, not complex"):
        design(GAP, [("r", T, {"u": samples})], scales=[1.0])


# ----------------------------------------------------------------------------- empty output names
@pytest.mark.parametrize("argv", [["sensors", "-o", ""], ["analyze", "-o", " "], ["design", "--record", "REC", "-o", ""]])
def test_an_empty_output_file_is_refused_before_any_work(files, capsys, monkeypatch, argv):
    """The whole job ran, then '. is a folder; name a file'."""
    import obsnl.design.records as records

    def no_work(*a, **k):
        raise AssertionError("the job ran")

    for name in ("analyze", "design"):
        monkeypatch.setattr(records, name, no_work, raising=False)
    monkeypatch.setattr("obsnl.design.sensors.sensors", no_work)
    monkeypatch.setattr("obsnl.design.experiment.design", no_work)
    argv = [a.replace("REC", files["record"]) for a in argv]
    code, out, err = _run(capsys, argv[0], files["model"], *argv[1:])
    _refused(code, err, "output file name is empty")
    assert not out


@pytest.mark.parametrize("command", ["report", "bank", "identify", "reproduce"])
def test_an_empty_out_folder_is_refused_not_the_current_folder(files, capsys, monkeypatch, command):
    """``--out ""`` wrote the tables (report) or the benchmark (bank) into the current folder; identify wrote
    nothing without saying so, reproduce wrote into its default folder."""
    work = files["dir"] / "cwd"
    work.mkdir()
    monkeypatch.chdir(work)
    argv = {"report": ["report", files["model"]], "bank": ["bank"], "reproduce": ["reproduce", "--quick"],
            "identify": ["identify", files["model"], "--record", files["record"]]}[command]
    code, out, err = _run(capsys, *argv, "--out", "")
    _refused(code, err, "--out is empty", "name a folder")
    assert list(work.iterdir()) == []


def test_an_empty_out_folder_is_refused_by_the_library(files):
    """The check is the library's (the jobs behind the commands, and every writer of a folder), not the CLI's."""
    from obsnl.errors import OutputError
    from obsnl.report.files import check_folder
    from obsnl.studies.jobs import identify_job

    for out in ("", "  "):
        with pytest.raises(OutputError, match="out= is empty"):
            check_folder(out, ["a.json"], force=True)
    with pytest.raises(OutputError, match="out= is empty"):
        identify_job(files["model"], record=files["record"], out="")


# ----------------------------------------------------------------------------- an option that would be ignored
def test_unknown_input_derivatives_without_unknown_inputs_is_refused(files, capsys):
    """``--unknown-input-derivatives 2`` on a model without unknown inputs was accepted and ignored."""
    code, out, err = _run(capsys, "analyze", files["model"], "--unknown-input-derivatives", "2")
    _refused(code, err, "--unknown-input-derivatives", "has none")
    assert not out
    with pytest.raises(OptionError, match="has none"):
        obsnl.analyze(GAP, unknown_input_derivatives=0)
    ui = Model(name="ui", states=["x"], parameters=["a"], unknown_inputs=["w"], equations={"x": "-a*x + w"},
               outputs={"y": "x"})
    assert obsnl.analyze(ui, seed=1, unknown_input_derivatives=0).assumptions["unknown_input_derivatives"] == 0


def test_a_scale_with_an_underscore_is_refused_not_read_as_another_number(files, capsys):
    """``--scales 1_0`` was read as 10 (Python's float syntax); a record cell ``1_0`` is refused, so is this."""
    code, out, err = _run(capsys, "design", files["model"], "--record", files["record"], "--scales", "0.5,1_0")
    _refused(code, err, "'1_0'")
    assert not out


@pytest.mark.parametrize("argv", [["analyze", "MODEL", "--max-seconds", "1_0"],
                                  ["identify", "MODEL", "--record", "REC", "--guess", "k=1_0"],
                                  ["identify", "MODEL", "--record", "REC", "--noise", "y=0_01"],
                                  ["identify", "MODEL", "--record", "REC", "--noise", "0_01"]])
def test_a_number_option_with_an_underscore_is_refused(files, capsys, argv):
    """Every number option read ``1_0`` as 10 (Python's float); now each is refused as not a number."""
    argv = [files["model"] if a == "MODEL" else files["record"] if a == "REC" else a for a in argv]
    code, out, err = _run(capsys, *argv)
    assert code == 2 and "not a number" in err and "Traceback" not in err, err
    assert not out


def test_a_quoted_value_with_an_underscore_in_a_model_file_is_refused(tmp_path):
    """``k = "1_0"`` under [values] was read as 10 (a quoted plain number still reads)."""
    from obsnl.errors import ModelError

    p = tmp_path / "m.toml"
    for value, expect in (('"1_0"', None), ('"10"', 10.0)):
        p.write_text(TINY.replace("k = 1.0", f"k = {value}"), encoding="utf-8")
        if expect is None:
            with pytest.raises(ModelError, match="values.k must be a number, got '1_0'"):
                obsnl.read_model(p)
        else:
            assert obsnl.read_model(p).values["k"] == expect
