"""The options of the design commands, ``obsnl sensors`` and ``obsnl design``: hostile values refused in one line.

Property tests of hostile options (issue 26) and pinned cases.

The hypothesis profile of ``tests/test_input_properties.py`` (tables, records, numeric options of
``identify``, ``reproduce`` and ``analyze``) extended to the options of the two design commands and to
their Python functions, with the same settings: derandomized (CI sees the same examples on every run), no
example database, a per-example bound of 8 s on this process's CPU time (``cpu_bounded``: a
wall-clock deadline fails on a busy shared machine) so that an example that starts heavy work fails, :data:`EXAMPLES` examples per property (``OBSNL_HYPOTHESIS_EXAMPLES=N`` raises it,
``OBSNL_HYPOTHESIS_PROFILE=random`` draws fresh examples). The whole file runs in a few seconds.

The properties (each asserts the exit code or the error type and the one-line message, so each can fail):

(d) ``test_invalid_sensors_option_exits_2_in_one_line``: ``obsnl.cli.main(["sensors", ...])`` with one
    invalid value for ``--target``, ``--max-size``, ``--format``, ``--seed``, ``--max-seconds``,
    ``--record``, ``--rank-size`` and ``--noise`` (a bad value with a valid ``--record``, or any value without
    one), ``--workers``, ``--scheduler`` or ``-o``; ``--opt=--``, 10 kB values and file names over 255 bytes
    among them. It must return 2 with exactly one error line on stderr
    (argparse's usage lines aside), no traceback, nothing on stdout, and write no output file.
(e) ``test_invalid_design_option_exits_2_in_one_line``: the same for ``obsnl design`` and ``--record``
    (missing, absent, a folder, not a record, empty, the same twice, more than 12), ``--target``,
    ``--sensors``, ``--format``, ``--figure``, ``--max-seconds``, ``--scales``, ``--seed``, ``-o`` and
    ``--intersample`` (an unknown kind, an input the model lacks, a malformed or 10 kB entry).
(f) ``test_bad_argument_of_the_design_functions_raises_an_obsnl_error``: :func:`obsnl.sensors` and
    :func:`obsnl.design.experiment.design` with one bad argument value of the right kind (a negative or
    fractional seed, a probability outside (0, 1), a non-positive time limit, an empty or unknown target or
    sensor, records with a missing input, a short, non-finite or non-increasing time column, bad scales,
    tolerance or input kinds between samples), or of the wrong type (a number as target, sensors, scales or records, a string as executor or
    as the model of ``design``). It must raise an :class:`~obsnl.errors.ObsnlError` of one line. ``design``
    is given a gap spring (one switching function), which it simulates, and for the key ``smooth_records``
    a model without switching functions, whose records are checked all the same.

The defects D1-D10 the first run found (``reports/hostile.md``: names over 255 bytes, scheduler hosts
with an empty label, counts past a machine integer, ``--opt=--``, 10 kB values echoed whole, overflow
warnings, options accepted without a word, unchecked records of smooth models, arguments of the wrong type)
were pinned as strict xfails; they are fixed, their values are in the draws, and the pinned examples below
are plain checks of each class, with the bound on ``--scales`` (at most 64).

The other tests here pin one defect each of the second design round: ``obsnl sensors``, ``obsnl design``,
``obsnl report``, ``obsnl bank`` and :func:`obsnl.sensors` / :func:`obsnl.design.experiment.design` (before the
fix: a hang, work done then a confusing refusal, files written into the current folder, or a meaningless request
answered); each ends in a one-line refusal now (exit 2 with the message on stderr, or an
:class:`~obsnl.errors.ObsnlError` from Python).
"""

from __future__ import annotations

import math
import os
import time
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import obsnl
from obsnl import Model, ObsnlError
from obsnl.cli import main
from obsnl.design.experiment import design
from obsnl.errors import OptionError
from obsnl.estimation.accelerogram import Record

from .helpers import _check_cli_refusal, _check_message, bad_float, bad_int, cpu_bounded

#: Examples per property (the ``ci`` profile); ``OBSNL_HYPOTHESIS_EXAMPLES`` overrides it.
EXAMPLES = int(os.environ.get("OBSNL_HYPOTHESIS_EXAMPLES", "100"))


_HEALTH = [HealthCheck.too_slow, HealthCheck.function_scoped_fixture, HealthCheck.filter_too_much,
           HealthCheck.data_too_large]


settings.register_profile("hostile-design-ci", max_examples=EXAMPLES, deadline=None, derandomize=True,
                          database=None, suppress_health_check=_HEALTH)


settings.register_profile("hostile-design-random", max_examples=EXAMPLES, deadline=None, derandomize=False,
                          database=None, suppress_health_check=_HEALTH)


SETTINGS = settings(settings.get_profile(
    "hostile-design-random" if os.environ.get("OBSNL_HYPOTHESIS_PROFILE") == "random" else "hostile-design-ci"))


# One state, one parameter, one known input, one output: every analysis is a few milliseconds, so a value
# that wrongly passes the checks costs little and shows as an exit 0, not as a timeout.
TINY_MODEL = """\
name = "tiny"
states = ["x"]
parameters = ["k"]
inputs = ["u"]
equations = { x = "-k*x + u" }
outputs = { y = "x" }

[values]
k = 1.0
"""


VALID_NAMES = ("x", "k")  # states and parameters of the tiny model


OUTPUTS = ("y",)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """The tiny model, a 200-sample record of its input, and the wrong things a path option can name."""
    d = tmp_path_factory.mktemp("hostile_design_options")
    model = d / "tiny.toml"
    model.write_text(TINY_MODEL, encoding="utf-8")
    record = d / "rec.csv"
    record.write_text("time_s,u\n" + "".join(f"{i * 0.01:.2f},{math.sin(i * 0.05):.6f}\n" for i in range(200)),
                      encoding="utf-8")
    (d / "folder").mkdir()
    (d / "folder.csv").mkdir()
    (d / "exists.txt").write_text("keep me\n", encoding="utf-8")
    (d / "empty.csv").write_text("", encoding="utf-8")
    (d / "header_only.csv").write_text("time_s,u\n", encoding="utf-8")
    (d / "binary.csv").write_bytes(b"\x00\xff\xfe" * 40)
    (d / "text.txt").write_text("time_s,u\n0,1\n0.01,2\n", encoding="utf-8")
    (d / "plot.png").mkdir()  # a folder named like the figure
    assert main(["sensors", str(model)]) == 0 and main(["design", str(model), "--record", str(record)]) == 0
    return {"dir": d, "model": model, "record": record}


def _run(capsys, argv: list[str]) -> tuple[int, str, str]:
    """``main(argv)``: exit code, stdout, stderr. A warning is what a user sees on stderr (pytest would
    otherwise swallow it), so each one is added to stderr as the line Python would print."""
    capsys.readouterr()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        code = main(argv)
    out, err = capsys.readouterr()
    shown = "".join(f"{w.filename}:{w.lineno}: {w.category.__name__}: {w.message}\n" for w in caught)
    return code, out, shown + err


def _snapshot(d) -> dict[str, float]:
    return {str(p.relative_to(d)): p.stat().st_mtime_ns for p in d.rglob("*")}


# --------------------------------------------------------------------------- strategies of bad values
LONG = "s" * 300  # over the 255 bytes a file name may have on common file systems


TEN_KB = "s" * 10_000  # a value no message may echo whole


short_text = st.text(max_size=40)


#: a name that is not a state or parameter of the tiny model (nor "all" / "parameters" once stripped)
bad_name = short_text.map(lambda s: s.replace(",", "")).filter(
    lambda s: s.strip() and s.strip() not in VALID_NAMES + ("all", "parameters")) | st.sampled_from(
    ["zz", "X", "K", "\u0430ll", "\u0445", "k_", "x\ny", "\x1b[31m", "all parameters", "_pexp0", "Integer", "y", TEN_KB])


@st.composite
def bad_target(draw):
    """A comma-separated list with at least one name that is not a state or parameter, or only blanks."""
    if draw(st.booleans()):
        return draw(st.sampled_from(["", " ", ",", " , ,", "\t"]))
    names = draw(st.lists(st.sampled_from(VALID_NAMES + ("", " ")), max_size=3))
    names.insert(draw(st.integers(0, len(names))), draw(bad_name))
    return ",".join(names)


@st.composite
def bad_sensors(draw):
    """A comma-separated list of outputs with one that is not an output of the model, or only blanks."""
    if draw(st.booleans()):
        return draw(st.sampled_from(["", " ", ",", ", ,"]))
    names = draw(st.lists(st.sampled_from(OUTPUTS + ("",)), max_size=2))
    names.insert(draw(st.integers(0, len(names))), draw(bad_name.filter(lambda s: s.strip() not in OUTPUTS)
                                                         | st.sampled_from(["x", "k", "u", "Y"])))
    return ",".join(names)


#: ``--opt=--`` (Python 3.11's argparse gives the option ``[]`` past its type and choices: D4) is drawn too
bad_format = st.text(max_size=12).filter(lambda s: s not in ("text", "json", "md", "tex")) | st.sampled_from(
    ["json-table", "TEXT", "latex", "png", " text", "--", TEN_KB])


#: a time limit that is not a positive finite number (``inf`` and ``1e400`` for every command: D7)
nonpositive = st.sampled_from(["nan", "-inf", "0", "-0.0", "-1", "-1e-300", "inf", "1e400"]) | \
    st.floats(max_value=0).map(repr)


bad_seconds = bad_float | nonpositive


bad_count = bad_int | st.just("0")


#: past a machine integer (D3)
huge_count = st.sampled_from(["9" * 20, "9" * 30, str(2 ** 63), str(2 ** 64)])


bad_noise = bad_float | st.sampled_from(["nan", "inf", "-inf", "0", "-0.01", "10", "10.0", "1e400", "1e3", TEN_KB]) | \
    st.floats(min_value=10.0).map(repr) | st.floats(max_value=0.0).map(repr)


bad_scale_item = bad_float.filter(lambda s: s.strip()) | st.sampled_from(["0", "-1", "nan", "inf", "-inf", "1e400", "-1e-300", "0.0"])


@st.composite
def bad_scales(draw):
    """A comma-separated grid with one value that is not a positive finite number, or nothing at all."""
    if draw(st.booleans()):
        return draw(st.sampled_from(["", ",", " , ", ",,,"]))
    good = draw(st.lists(st.sampled_from(["0.5", "1", "2", "1e-3", "16"]), max_size=3))
    if draw(st.integers(0, 9)) == 0:  # more than the 64 scales a design takes, each valid
        return ",".join(["1"] * draw(st.integers(65, 300)))
    good.insert(draw(st.integers(0, len(good))), draw(bad_scale_item.filter(lambda s: "," not in s)))  # blanks are skipped
    return ",".join(good)


#: scheduler addresses that are malformed or refused on this machine (no name lookup, no unroutable host)
bad_scheduler = st.sampled_from(["", "://", "tcp://", "tcp://:", "tcp://[", "inproc://x", "ucx://127.0.0.1:1",
                                 "tcp://127.0.0.1:0", "tcp://127.0.0.1:-1", "127.0.0.1:x", "tcp://127.0.0.1:1",
                                 "tls://127.0.0.1:1", "a..b", "tcp://a..b:8786", "tcp://" + "h" * 64 + ":8786", "."]) \
    | st.integers(65536, 10 ** 12).map(lambda p: f"tcp://127.0.0.1:{p}")


def _path_value(files, kind: str) -> str:
    d = files["dir"]
    return {"missing": str(d / "missing.csv"), "missing_dir": str(d / "no" / "such" / "rec.csv"),
            "folder": str(d / "folder"), "folder_csv": str(d / "folder.csv"), "empty": str(d / "empty.csv"),
            "header_only": str(d / "header_only.csv"), "binary": str(d / "binary.csv"),
            "text": str(d / "text.txt"), "model": str(files["model"]), "long": str(d / f"{LONG}.csv"),
            "ten_kb": TEN_KB}[kind]


RECORD_KINDS = ["missing", "missing_dir", "folder", "folder_csv", "empty", "header_only", "binary", "text", "model",
                "long", "ten_kb"]


OUT_KINDS = ["exists", "folder", "under_file", "under_file_deep", "long"]


def _out_value(files, kind: str) -> str:
    d = files["dir"]
    return {"exists": str(d / "exists.txt"), "folder": str(d / "folder"), "under_file": str(d / "exists.txt" / "o.txt"),
            "under_file_deep": str(d / "exists.txt" / "a" / "o.txt"), "long": str(d / f"{LONG}.txt")}[kind]


# --------------------------------------------------------------------------- (d) obsnl sensors
SENSORS_OPTIONS = ["--target", "--max-size", "--format", "--seed", "--max-seconds", "--record", "--rank-size",
                   "--noise", "--workers", "--scheduler", "-o"]


@st.composite
def invalid_sensors_options(draw, files):
    option = draw(st.sampled_from(SENSORS_OPTIONS))
    extra: list[str] = []
    if option == "--target":
        value = draw(bad_target())
    elif option in ("--max-size", "--seed", "--workers"):
        value = draw(bad_count | huge_count if option == "--workers" else bad_count if option != "--seed" else bad_int)
    elif option == "--format":
        value = draw(bad_format)
    elif option == "--max-seconds":
        value = draw(bad_seconds)
    elif option == "--record":
        value = _path_value(files, draw(st.sampled_from(RECORD_KINDS)))
    elif option == "--rank-size":  # sets of more sensors than the model has, not a size at all, or no --record
        value = draw(bad_count | huge_count | st.integers(2, 10 ** 6).map(str) | st.just("1"))
        extra = ["--record", str(files["record"])] if value != "1" else []
    elif option == "--noise":  # a bad level, or a good one without --record (ignored: refused)
        value = draw(bad_noise | st.just("0.05"))
        extra = ["--record", str(files["record"])] if value != "0.05" else []
    elif option == "--scheduler":
        value = draw(bad_scheduler)
    else:
        value = _out_value(files, draw(st.sampled_from(OUT_KINDS)))
    return option, value, extra


@SETTINGS
@given(data=st.data())
@cpu_bounded
def test_invalid_sensors_option_exits_2_in_one_line(files, data, capsys):
    option, value, extra = data.draw(invalid_sensors_options(files))
    event(f"sensors {option}")
    before = _snapshot(files["dir"])
    code, out, err = _run(capsys, ["sensors", str(files["model"]), *extra, f"{option}={value}"])
    _check_cli_refusal(code, out, err)
    assert not out.strip(), f"printed {out[:300]!r}"
    assert _snapshot(files["dir"]) == before, "a refused command wrote or touched a file"


# --------------------------------------------------------------------------- (e) obsnl design
DESIGN_OPTIONS = ["--record", "--target", "--sensors", "--format", "--figure", "--max-seconds", "--scales", "--seed",
                  "-o", "--intersample"]
#: Kinds of input between samples that design refuses (unknown kinds, inputs the model lacks, malformed entries).
bad_intersample = st.sampled_from(["cubic", "u=cubic", "v=zoh", "=zoh", "ZOH", "u==zoh", "", " ", "zoh,linear",
                                   "x" * 10_000, "u=" + "z" * 10_000])


@st.composite
def invalid_design_options(draw, files):
    """(argv after the model) with one invalid option value and a valid --record unless the record is the point."""
    option = draw(st.sampled_from(DESIGN_OPTIONS))
    rec = ["--record", str(files["record"])]
    if option == "--record":
        how = draw(st.sampled_from(["none", "twice", "thirteen", *RECORD_KINDS]))
        if how == "none":
            return option, []
        if how == "twice":
            return option, rec + rec
        if how == "thirteen":  # thirteen distinct records (the same file under thirteen names)
            d = files["dir"] / "many"
            d.mkdir(exist_ok=True)
            args = []
            for i in range(13):
                p = d / f"r{i}.csv"
                if not p.exists():
                    p.write_text(files["record"].read_text(encoding="utf-8"), encoding="utf-8")
                args += ["--record", str(p)]
            return option, args
        return option, ["--record", _path_value(files, how)]
    if option == "--target":
        value = draw(bad_target())
    elif option == "--sensors":
        value = draw(bad_sensors())
    elif option == "--format":
        value = draw(bad_format)
    elif option == "--figure":
        how = draw(st.sampled_from(["suffix", "same_as_o", "exists", "under_file", "folder_png"]))
        d = files["dir"]
        if how == "suffix":
            value = str(d / draw(st.sampled_from(["f.pdf", "f.PNG.txt", "f", ".png", "f.svg", "f.png.", "f.jpg",
                                                  f"{LONG}.png"])))
            value = draw(st.sampled_from([value, ""]))  # an empty name is refused, not ignored
        elif how == "same_as_o":
            return option, rec + ["-o", str(d / "same.png"), f"--figure={d / 'same.png'}"]
        elif how == "exists":
            (d / "old.png").write_bytes(b"not a plot")
            value = str(d / "old.png")
        elif how == "under_file":
            value = str(d / "exists.txt" / "f.png")
        else:
            value = str(d / "plot.png")
    elif option == "--max-seconds":
        value = draw(bad_seconds | st.sampled_from(["inf", "1e400"]))
    elif option == "--scales":
        value = draw(bad_scales())
    elif option == "--seed":
        value = draw(bad_int)
    elif option == "--intersample":
        value = draw(bad_intersample)
    else:
        value = _out_value(files, draw(st.sampled_from(OUT_KINDS)))
    return option, rec + [f"{option}={value}"]


@SETTINGS
@given(data=st.data())
@cpu_bounded
def test_invalid_design_option_exits_2_in_one_line(files, data, capsys):
    option, argv = data.draw(invalid_design_options(files))
    event(f"design {option}")
    before = _snapshot(files["dir"])
    code, out, err = _run(capsys, ["design", str(files["model"]), *argv])
    _check_cli_refusal(code, out, err)
    assert not out.strip(), f"printed {out[:300]!r}"
    assert _snapshot(files["dir"]) == before, "a refused command wrote or touched a file"


# --------------------------------------------------------------------------- (f) the Python functions
T = np.linspace(0.0, 2.0, 41)


U = np.sin(2 * T)


def _tiny():
    return obsnl.Model(name="tiny", states=["x"], parameters=["k"], inputs=["u"], equations={"x": "-k*x + u"},
                       outputs={"y": "x"}, values={"k": 1.0})


def _gap():
    """A gap spring (one switching function): design simulates it, so a record's samples are used."""
    return obsnl.Model(name="gap", states=["x", "v"], parameters=["c", "k", "kc", "g"], inputs=["u"],
                       equations={"x": "v", "v": "u - c*v - k*x - kc*Max(x - g, 0)"}, outputs={"y": "x"},
                       values={"c": 0.5, "k": 4.0, "kc": 40.0, "g": 0.1})


fraction = st.floats(min_value=0.01, max_value=0.99).filter(lambda f: f != int(f))


SENSORS_BAD = {
    "seed": st.integers(max_value=-1) | fraction | st.sampled_from(["a", "1", True, 1.5]),
    "prob": st.sampled_from([float("nan"), 0, 0.0, 1, 1.0, -0.5, float("inf"), "x", "0.9"])
    | st.floats(min_value=1.0) | st.floats(max_value=0.0),
    "max_seconds": st.sampled_from([float("nan"), 0, -1, -float("inf"), "1"]) | st.floats(max_value=0.0),
    "max_size": st.integers(max_value=0) | st.sampled_from([1.5, True, "2", 2.0]),
    "target": bad_target() | st.sampled_from([[], ["zz"], ("all", "zz"), ["x", "parameters"], ["", " "], 5, None,
                                              [5], {"x": 1}]),
    "executor": st.sampled_from(["x", 5, object()]),
    "model": st.sampled_from([5, None, 1.5, ["x"], object()]),
}


DESIGN_BAD = {
    "records": st.sampled_from(["empty", "missing_input", "short", "nan", "inf", "reversed", "constant_t", "no_samples",
                                "pair", "thirteen", "duplicate", "string", "none", "five", "text_times"]),
    "smooth_records": st.sampled_from(["short", "nan", "inf", "reversed", "constant_t", "no_samples", "missing_input"]),
    "scales": st.sampled_from([[], [0], [-1.0], [float("nan")], [float("inf")], [1.0, 0.0], [2.0, -float("inf")],
                               ["a"], 5, "1,2", [True], [1.0] * 65])
    | st.lists(st.floats(max_value=0.0), min_size=1, max_size=3),
    "tol": st.sampled_from([0, 0.0, 1, 1.0, 2.5, -1e-3, float("nan"), float("inf"), "a", True, 1e-13])
    | st.floats(min_value=1.0) | st.floats(max_value=1e-13),
    "seed": st.integers(max_value=-1) | fraction | st.sampled_from(["a", "1"]),
    "max_seconds": st.sampled_from([float("nan"), 0, -1, float("inf"), -float("inf"), "1"]) | st.floats(max_value=0.0),
    "target": bad_target() | st.sampled_from([[], ["zz"], 5]),
    "sensors": bad_sensors() | st.sampled_from([[], ["zz"], ["y", "zz"], [5], 5]),
    "model": st.sampled_from([5, None, "tiny.toml"]),
    "intersample": bad_intersample | st.sampled_from([5, 1.5, ["zoh", 5], {"u": 5}, {"zz": "zoh"}]),
}


def _records(kind: str):
    rec = ("push", T, {"u": U})
    return {"empty": [], "missing_input": [("a", T, {"w": U})], "short": [("a", T, {"u": U[:10]})],
            "nan": [("a", T, {"u": U * np.nan})], "inf": [("a", T, {"u": np.where(T > 1, np.inf, U)})],
            "reversed": [("a", T[::-1], {"u": U})], "constant_t": [("a", T * 0, {"u": U})],
            "no_samples": [("a", np.array([]), {"u": np.array([])})], "pair": [("a", T)],
            "thirteen": [(f"r{i}", T, {"u": U}) for i in range(13)], "duplicate": [rec, rec], "string": "rec.csv",
            "none": None, "five": 5, "text_times": [("a", "x", {"u": U})]}[kind]


@SETTINGS
@given(data=st.data())
@cpu_bounded
def test_bad_argument_of_the_design_functions_raises_an_obsnl_error(data):
    function = data.draw(st.sampled_from(["sensors", "design"]))
    table = SENSORS_BAD if function == "sensors" else DESIGN_BAD
    key = data.draw(st.sampled_from(sorted(table)))
    value = data.draw(table[key])
    event(f"{function}({key}=...)")
    with pytest.raises(ObsnlError) as info:
        if function == "sensors":
            obsnl.sensors(value) if key == "model" else obsnl.sensors(_tiny(), **{key: value})
        elif key in ("records", "smooth_records"):
            design(_gap() if key == "records" else _tiny(), _records(value), scales=[0.5, 1.0])
        elif key == "model":
            design(value, [("push", T, {"u": U})], scales=[0.5, 1.0])
        else:
            design(_gap(), [("push", T, {"u": U})], **{"scales": [0.5, 1.0], key: value})
    _check_message(info.value)


def _cli(files, capsys, *argv: str) -> tuple[int, str, str]:
    return _run(capsys, list(argv))


@pytest.mark.parametrize("how", ["sensors -o", "sensors --record", "design --figure", "design -o"])
def test_d1_a_file_name_over_255_bytes_is_refused_in_one_line(files, capsys, how):
    command, option = how.split()
    d = files["dir"]
    value = {"-o": str(d / f"{LONG}.txt"), "--record": str(d / f"{LONG}.csv"), "--figure": str(d / f"{LONG}.png")}[option]
    extra = ["--record", str(files["record"])] if command == "design" else []
    code, out, err = _cli(files, capsys, command, str(files["model"]), *extra, f"{option}={value}")
    _check_cli_refusal(code, out, err)
    assert "255 bytes" in err and "sssss..." in err and LONG not in err, err  # the path shortened, and the fix


def test_d1_any_os_error_of_a_command_is_one_line_with_the_path_and_the_reason(files, capsys, monkeypatch):
    """The one place (main) that turns the operating system's refusals into a line: here a full disk."""
    import errno

    import obsnl.commands.sensors

    def full(request):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(files["dir"] / f"{TEN_KB}.txt"))

    monkeypatch.setattr(obsnl.commands.sensors, "run_sensors", full)  # the command's run
    code, out, err = _cli(files, capsys, "sensors", str(files["model"]))
    _check_cli_refusal(code, out, err)
    assert os.strerror(errno.ENOSPC) in err and "free some space" in err and len(err) < 400, err


@pytest.mark.parametrize("address", ["a..b", "tcp://a..b:8786", "tcp://" + "h" * 64 + ":8786"])
def test_d2_a_scheduler_host_with_a_bad_label_is_refused_in_one_line(files, capsys, address):
    code, out, err = _cli(files, capsys, "sensors", str(files["model"]), f"--scheduler={address}")
    _check_cli_refusal(code, out, err)
    assert "is not a Dask scheduler address" in err and "1 to 63 characters" in err, err


@pytest.mark.parametrize("option", ["--rank-size", "--workers"])
def test_d3_a_count_past_a_machine_integer_is_refused_in_one_line(files, capsys, option):
    extra = ["--record", str(files["record"])] if option == "--rank-size" else []
    code, out, err = _cli(files, capsys, "sensors", str(files["model"]), *extra, f"{option}={'9' * 30}")
    _check_cli_refusal(code, out, err)
    assert ("from 1 to 1" if option == "--rank-size" else "more than 1024") in err, err


def test_d3_the_python_functions_bound_the_counts_too():
    from obsnl.design.sensors import rank_sufficient_sets
    from obsnl.executor import MAX_WORKERS, Executor

    with pytest.raises(ObsnlError, match="from 1 to 1024"):
        Executor(workers=10 ** 30)
    assert Executor(workers=MAX_WORKERS).workers == MAX_WORKERS
    search = obsnl.sensors(_tiny())
    with pytest.raises(ObsnlError, match="rank size") as info:
        rank_sufficient_sets(search, _tiny(), t=T, inputs=U, size=10 ** 20)
    _check_message(info.value)


@pytest.mark.parametrize("how", ["sensors --rank-size", "sensors --noise", "sensors --format", "sensors -o",
                                 "design --record"])
def test_d4_an_option_given_as_double_dash_is_refused_in_one_line(files, capsys, how):
    command, option = how.split()
    extra = ["--record", str(files["record"])] if option in ("--rank-size", "--noise") else []
    code, out, err = _cli(files, capsys, command, str(files["model"]), *extra, f"{option}=--")
    _check_cli_refusal(code, out, err)
    assert "expected one value, got '--'" in err, err


@pytest.mark.parametrize("how", ["sensors --target", "design --target", "design --sensors", "design --record",
                                 "sensors --noise"])
def test_d5_a_10kb_value_is_not_echoed_whole(files, capsys, how):
    command, option = how.split()
    extra = ["--record", str(files["record"])] if option != "--record" and (command == "design" or option == "--noise") \
        else []
    code, out, err = _cli(files, capsys, command, str(files["model"]), *extra, f"{option}={TEN_KB}")
    _check_cli_refusal(code, out, err)  # one line of at most MAX_MESSAGE characters
    assert max(map(len, err.splitlines())) < 300, err[:400]  # the value cut to SHOWN characters


@pytest.mark.parametrize("argv", [("--format", TEN_KB), (TEN_KB,), ("--seed", TEN_KB)])
def test_d5_argparse_own_messages_do_not_echo_a_10kb_value(files, capsys, argv):
    code, out, err = _cli(files, capsys, "sensors", str(files["model"]), *argv)
    _check_cli_refusal(code, out, err)
    assert max(map(len, err.splitlines())) < 400, err[:500]


def test_d6_a_scale_that_overflows_the_simulation_gives_one_line(files, capsys):
    gap = files["dir"] / "gap.toml"
    gap.write_text('name = "gap"\nstates = ["x", "v"]\nparameters = ["c", "k", "kc", "g"]\ninputs = ["u"]\n'
                   'equations = { x = "v", v = "u - c*v - k*x - kc*Max(x - g, 0)" }\noutputs = { y = "x" }\n\n'
                   '[values]\nc = 0.5\nk = 4.0\nkc = 40.0\ng = 0.1\n', encoding="utf-8")
    code, out, err = _cli(files, capsys, "design", str(gap), "--record", str(files["record"]), "--scales=1e308")
    _check_cli_refusal(code, out, err)  # the warnings, recorded as lines of stderr, would make three
    assert "blew up" in err and "amplitude" in err, err


def test_the_number_of_scales_is_bounded(files, capsys):
    """2000 scales on a gap spring ran 157 s: more than MAX_SCALES are refused at once, on the command line
    and in Python; MAX_SCALES themselves run."""
    import time

    from obsnl.design.arguments import MAX_SCALES

    t0 = time.perf_counter()
    code, out, err = _cli(files, capsys, "design", str(files["model"]), "--record", str(files["record"]),
                          "--scales=" + ",".join(str(1 + i / 1000) for i in range(2000)))
    _check_cli_refusal(code, out, err)
    assert f"at most {MAX_SCALES}" in err and time.perf_counter() - t0 < 5, err
    with pytest.raises(ObsnlError, match=f"at most {MAX_SCALES}"):
        design(_gap(), [("push", T, {"u": U})], scales=[1 + i / 1000 for i in range(MAX_SCALES + 1)])
    scales = ",".join(str(2.0 ** (k / 8)) for k in range(-MAX_SCALES // 2, MAX_SCALES // 2))
    code, out, err = _cli(files, capsys, "design", str(files["model"]), "--record", str(files["record"]),
                          f"--scales={scales}", "--format=json")
    assert code == 0, err


@pytest.mark.parametrize("argv", [("sensors", "--max-seconds=inf"), ("sensors", "--max-seconds=1e400"),
                                  ("sensors", "--noise=nan"), ("sensors", "--rank-size=7"),
                                  ("design", "--figure=")])
def test_d7_d8_an_option_that_does_nothing_is_refused(files, capsys, argv):
    command, option = argv
    extra = ["--record", str(files["record"])] if command == "design" else []
    code, out, err = _cli(files, capsys, command, str(files["model"]), *extra, option)
    _check_cli_refusal(code, out, err)
    assert {"--max-seconds=inf": "positive finite", "--max-seconds=1e400": "positive finite", "--noise=nan": "noise",
            "--rank-size=7": "add --record", "--figure=": "name a .png file"}[option] in err, err


def test_d7_max_seconds_follows_one_rule_in_python_too():
    """Positive and finite, as time_budget (analyze, design) wants: analyze() and sensors() refuse inf."""
    for call in (lambda: obsnl.analyze(_tiny(), max_seconds=float("inf")),
                 lambda: obsnl.sensors(_tiny(), max_seconds=float("inf")),
                 lambda: design(_tiny(), [("push", T, {"u": U})], scales=[1.0], max_seconds=float("inf"))):
        with pytest.raises(ObsnlError, match="finite|positive") as info:
            call()
        _check_message(info.value)


WRONG_TYPES = [
    ("sensors", {"target": 5}), ("sensors", {"target": None}), ("sensors", {"target": [5]}),
    ("sensors", {"executor": "x"}), ("sensors", {"model": 5}), ("sensors", {"model": None}),
    ("design", {"records": None}), ("design", {"records": 5}), ("design", {"records": [("a", "x", {"u": U})]}),
    ("design", {"scales": ["a"]}), ("design", {"scales": 5}), ("design", {"target": 5}), ("design", {"sensors": 5}),
    ("design", {"model": 5}), ("design", {"model": "tiny.toml"}),
]


@pytest.mark.parametrize("function,kwargs", WRONG_TYPES, ids=[f"{f}-{next(iter(k))}" for f, k in WRONG_TYPES])
def test_d10_an_argument_of_the_wrong_type_raises_an_obsnl_error(function, kwargs):
    kwargs = dict(kwargs)
    model = kwargs.pop("model", _tiny())
    with pytest.raises(ObsnlError) as info:
        if function == "sensors":
            obsnl.sensors(model, **kwargs)
        else:
            records = kwargs.pop("records", [("push", T, {"u": U})])
            design(model, records, **{"scales": [0.5, 1.0], **kwargs})
    _check_message(info.value)


@pytest.mark.parametrize("kind", ["short", "nan"])
def test_d9_a_bad_record_of_a_smooth_model_is_refused(kind):
    with pytest.raises(ObsnlError) as info:
        design(_tiny(), _records(kind), scales=[0.5, 1.0])
    _check_message(info.value)


T200 = np.arange(200) * 0.01


U200 = np.sin(5 * T200)


GAP = Model(name="gap", states=["x", "v"], parameters=["c", "k", "kc", "g"], inputs=["u"],
            equations={"x": "v", "v": "u - c*v - k*x - kc*Max(x - g, 0)"}, outputs={"y": "x"},
            values={"c": 0.5, "k": 4.0, "kc": 40.0, "g": 0.1})


def _many(n: int) -> Model:
    """One state, ``n`` outputs, each revealing everything alone."""
    return Model(name="many", states=["x"], parameters=["k"], inputs=["u"], equations={"x": "-k*x + u"},
                 outputs={f"y{i}": f"{i + 1}*x" for i in range(n)})


@pytest.fixture()
def tiny_files(tmp_path):
    model = tmp_path / "tiny.toml"
    model.write_text(TINY_MODEL, encoding="utf-8")
    record = tmp_path / "rec.csv"
    record.write_text("time_s,u\n" + "".join(f"{i * 0.01:.2f},{math.sin(i * 0.05):.6f}\n" for i in range(200)),
                      encoding="utf-8")
    return {"dir": tmp_path, "model": str(model), "record": str(record)}


def _run_args(capsys, *argv: str) -> tuple[int, str, str]:
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
    code, out, err = _run_args(capsys, "sensors", str(p), "--target", "a,b,c,d", "--max-size", "4")
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
            design(m, [("r", T200, {"u": U200})], scales=[1.0], target="parameters")


def test_a_progress_that_is_neither_a_flag_nor_a_callable_is_refused():
    with pytest.raises(OptionError, match="progress is True, False or a callable"):
        obsnl.sensors(GAP, target="all", progress="yes")


@pytest.mark.parametrize("record", [("r", T200, {"u": U200, "w": U200}), ("r", T200, {"U": U200, "u": U200}),
                                    Record("r", np.c_[U200, U200], 0.01, channels=("u", "w"))],
                         ids=["tuple", "misspelt", "channels"])
def test_a_record_input_the_model_does_not_have_is_refused_not_ignored(record):
    with pytest.raises(OptionError, match="is not an input of 'gap'"):
        design(GAP, [record], scales=[1.0])


@pytest.mark.parametrize("samples", [U200 + 1j, U200 + 0j], ids=["complex", "zero-imaginary"])
def test_a_complex_record_is_refused_not_cast(samples):
    """numpy cast it to float with a ComplexWarning and the imaginary part was dropped."""
    with pytest.raises(OptionError, match="real numbers, not complex"):
        design(GAP, [("r", T200, {"u": samples})], scales=[1.0])


# ----------------------------------------------------------------------------- empty output names
@pytest.mark.parametrize("argv", [["sensors", "-o", ""], ["analyze", "-o", " "], ["design", "--record", "REC", "-o", ""]])
def test_an_empty_output_file_is_refused_before_any_work(tiny_files, capsys, monkeypatch, argv):
    """The whole job ran, then '. is a folder; name a file'."""
    def no_work(*a, **k):
        raise AssertionError("the job ran")

    monkeypatch.setattr("obsnl.observability.analyze.run_analysis", no_work)
    monkeypatch.setattr("obsnl.design.sensors.sensors", no_work)
    monkeypatch.setattr("obsnl.design.experiment.design", no_work)
    argv = [a.replace("REC", tiny_files["record"]) for a in argv]
    code, out, err = _run_args(capsys, argv[0], tiny_files["model"], *argv[1:])
    _refused(code, err, "output file name is empty")
    assert not out


@pytest.mark.parametrize("command", ["report", "bank", "identify", "reproduce"])
def test_an_empty_out_folder_is_refused_not_the_current_folder(tiny_files, capsys, monkeypatch, command):
    """``--out ""`` wrote the tables (report) or the benchmark (bank) into the current folder; identify wrote
    nothing without saying so, reproduce wrote into its default folder."""
    work = tiny_files["dir"] / "cwd"
    work.mkdir()
    monkeypatch.chdir(work)
    argv = {"report": ["report", tiny_files["model"]], "bank": ["bank"], "reproduce": ["reproduce", "--quick"],
            "identify": ["identify", tiny_files["model"], "--record", tiny_files["record"]]}[command]
    code, out, err = _run_args(capsys, *argv, "--out", "")
    _refused(code, err, "--out is empty", "name a folder")
    assert list(work.iterdir()) == []


def test_an_empty_out_folder_is_refused_by_the_library(tiny_files):
    """The check is the library's (the jobs behind the commands, and every writer of a folder), not the CLI's."""
    from obsnl.errors import OutputError
    from obsnl.report.files import check_folder
    from obsnl.commands.identify import IdentifyRequest

    for out in ("", "  "):
        with pytest.raises(OutputError, match="out= is empty"):
            check_folder(out, ["a.json"], force=True)
    with pytest.raises(OutputError, match="out= is empty"):
        IdentifyRequest(model=tiny_files["model"], record=tiny_files["record"], out="")


# ----------------------------------------------------------------------------- an option that would be ignored
def test_unknown_input_derivatives_without_unknown_inputs_is_refused(tiny_files, capsys):
    """``--unknown-input-derivatives 2`` on a model without unknown inputs was accepted and ignored."""
    code, out, err = _run_args(capsys, "analyze", tiny_files["model"], "--unknown-input-derivatives", "2")
    _refused(code, err, "--unknown-input-derivatives", "has none")
    assert not out
    with pytest.raises(OptionError, match="has none"):
        obsnl.analyze(GAP, unknown_input_derivatives=0)
    ui = Model(name="ui", states=["x"], parameters=["a"], unknown_inputs=["w"], equations={"x": "-a*x + w"},
               outputs={"y": "x"})
    assert obsnl.analyze(ui, seed=1, unknown_input_derivatives=0).assumptions.unknown_input_derivatives == 0


def test_a_scale_with_an_underscore_is_refused_not_read_as_another_number(tiny_files, capsys):
    """``--scales 1_0`` was read as 10 (Python's float syntax); a record cell ``1_0`` is refused, so is this."""
    code, out, err = _run_args(capsys, "design", tiny_files["model"], "--record", tiny_files["record"], "--scales", "0.5,1_0")
    _refused(code, err, "'1_0'")
    assert not out


@pytest.mark.parametrize("argv", [["analyze", "MODEL", "--max-seconds", "1_0"],
                                  ["identify", "MODEL", "--record", "REC", "--guess", "k=1_0"],
                                  ["identify", "MODEL", "--record", "REC", "--noise", "y=0_01"],
                                  ["identify", "MODEL", "--record", "REC", "--noise", "0_01"]])
def test_a_number_option_with_an_underscore_is_refused(tiny_files, capsys, argv):
    """Every number option read ``1_0`` as 10 (Python's float); now each is refused as not a number."""
    argv = [tiny_files["model"] if a == "MODEL" else tiny_files["record"] if a == "REC" else a for a in argv]
    code, out, err = _run_args(capsys, *argv)
    assert code == 2 and "not a number" in err and "Traceback" not in err, err
    assert not out


def test_a_quoted_value_with_an_underscore_in_a_model_file_is_refused(tmp_path):
    """``k = "1_0"`` under [values] was read as 10 (a quoted plain number still reads)."""
    from obsnl.errors import ModelError

    p = tmp_path / "m.toml"
    for value, expect in (('"1_0"', None), ('"10"', 10.0)):
        p.write_text(TINY_MODEL.replace("k = 1.0", f"k = {value}"), encoding="utf-8")
        if expect is None:
            with pytest.raises(ModelError, match="values.k must be a number, got '1_0'"):
                obsnl.read_model(p)
        else:
            assert obsnl.read_model(p).values["k"] == expect
