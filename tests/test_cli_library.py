"""Issue 25, item 4: the checks, file workflows and lines the thin command line left to the library.

(1) A bound is the library's: Python and ``obsnl`` refuse the same value with the same message, the command
line's only in its flags (``cli_terms``); (2) the file workflows and requests refuse an output file that cannot be
written before any work (a tripwire on the work); (3) the renamings of a ``ReparametrizeRequest`` are ``OLD=NEW``;
(4) the undecided sensor sets make one line; (5) identify's refusal of workers nothing would use, and the probe of a
scheduler, are the requests' own; (6) a command prints (or writes to ``-o``) what its module of ``obsnl.commands``
returns. Every
check is exact, so no error probability to state.
"""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from obsnl.cli import build_parser, main
from obsnl.cli.common import cli_terms
from obsnl.errors import ObsnlError, OptionError, OutputError, in_terms
from obsnl.executor import Executor
from obsnl.identification.replicates import MAX_PASSES, MAX_REPLICATES, check_passes, check_replicates
from obsnl.model.bounds.budget import check_seconds

from .conftest import MODELS


def _sub(command: str):
    return build_parser()._subparsers._group_actions[0].choices[command]  # type: ignore[union-attr]


@pytest.mark.parametrize("command, flag, value, check", [
    ("reproduce", "--passes", MAX_PASSES + 1, check_passes),
    ("reproduce", "--replicates", MAX_REPLICATES + 1, check_replicates),
    ("reproduce", "--replicates", 2, check_replicates),
    ("report", "--max-seconds", float("inf"), check_seconds),
    ("sensors", "--workers", 1025, lambda n: Executor(workers=n)),
])
def test_python_and_the_command_line_refuse_a_value_alike(tmp_path, capsys, command, flag, value, check):
    with pytest.raises(ObsnlError) as info:
        check(value)
    args = {"reproduce": ["--out", str(tmp_path / "never")], "report": [str(MODELS / "bouc_wen.toml"), "--out",
            str(tmp_path / "never")], "sensors": [str(MODELS / "bouc_wen.toml")]}[command]
    assert main([command, *args, flag, str(value)]) == 2
    err = capsys.readouterr().err
    assert err == f"obsnl {command}: error: {cli_terms(str(info.value), _sub(command))}\n"
    assert flag in err and "=" not in err.split("error:")[1].split()[0]  # the flag, not the keyword
    assert not (tmp_path / "never").exists()


def test_the_switches_read_the_value_they_set():
    p = _sub("identify")
    assert cli_terms("pass refine=False or refine=True; jit=True", p) == (
        "pass --no-refine or without --no-refine; --jit")
    # a pair of switches of one option (--jit, --no-jit): each value is named by the switch that sets it
    for command in ("identify", "reproduce"):
        assert cli_terms("jit=False or jit=True", _sub(command)) == "--no-jit or --jit"
    assert in_terms("joint=False", {"joint": ("--no-joint", False)}) == "--no-joint"


@pytest.mark.parametrize("job", ["AnalyzeRequest", "SensorsRequest", "DesignRequest", "ReparametrizeRequest"])
def test_an_output_that_cannot_be_written_is_refused_before_any_work(tmp_path, monkeypatch, job):
    import obsnl.model.files as files
    from obsnl.commands import (AnalyzeRequest, DesignRequest, SensorsRequest, run_analyze, run_design,
                                run_sensors)
    from obsnl.commands.reparametrize import ReparametrizeRequest

    def tripwire(*a, **k):  # noqa: ANN002, ANN003
        raise AssertionError("the model was read before the output was checked")

    monkeypatch.setattr(files, "read_model", tripwire)  # every job reads a model file through it (as_model)
    out = tmp_path / "taken.md"
    out.write_text("keep me", encoding="utf-8")
    model = MODELS / "bouc_wen.toml"
    call = {"AnalyzeRequest": lambda: run_analyze(AnalyzeRequest(model=model, output=str(out))),
            "SensorsRequest": lambda: run_sensors(SensorsRequest(model=model, output=str(out))),
            "DesignRequest": lambda: run_design(DesignRequest(model=model, records=["r.csv"], output=str(out))),
            "ReparametrizeRequest": lambda: ReparametrizeRequest(model=MODELS / "bouc_wen.toml", output=str(out))}[job]
    with pytest.raises(OutputError, match="exists; pass force=True"):
        call()
    assert out.read_text(encoding="utf-8") == "keep me"


@pytest.mark.parametrize("names", [["x"], ["a=b=c"], ["=b"], ["a="]])
def test_the_reparametrize_request_takes_old_equals_new(names):
    from obsnl.commands.reparametrize import ReparametrizeRequest

    with pytest.raises(OptionError, match="names= takes OLD=NEW"):
        ReparametrizeRequest(model=MODELS / "bouc_wen.toml", names=names)


def test_the_undecided_sensor_sets_make_one_line():
    from obsnl.report.sensors import undecided_line

    first = SimpleNamespace(sensors=("a", "b"), reason="")
    search = SimpleNamespace(undecided_sets=(("a", "b"), ("c",)), answer=lambda s: first)
    assert undecided_line(search) == ("2 sensor set(s) undecided, e.g. {a, b}: minimality undecided; raise "
                                      "max_seconds=")
    assert undecided_line(SimpleNamespace(undecided_sets=())) is None


def test_the_identify_request_refuses_an_executor_nothing_would_use(tmp_path, capsys, monkeypatch):
    """Without the refinement and without replicates nothing of identify runs in parallel: workers or a scheduler
    named there are refused, not dropped, from Python and from ``obsnl identify`` alike (before the model is read)."""
    import obsnl.model.files as files
    from obsnl.commands.identify import IdentifyRequest

    def tripwire(*a, **k):  # noqa: ANN002, ANN003
        raise AssertionError("the model was read before the options were checked")

    monkeypatch.setattr(files, "read_model", tripwire)
    with pytest.raises(OptionError) as info:
        IdentifyRequest(model=MODELS / "bouc_wen.toml", record="r.csv", refine=False, replicates=0,
                        executor=Executor(workers=2))
    assert "workers= or scheduler=" in str(info.value) and "refine=False" in str(info.value)
    assert main(["identify", str(MODELS / "bouc_wen.toml"), "--record", "r.csv", "--no-refine", "--workers", "2"]) == 2
    err = capsys.readouterr().err
    assert err == f"obsnl identify: error: {cli_terms(str(info.value), _sub('identify'))}\n"
    assert err.startswith("obsnl identify: error: --workers or --scheduler applies") and "--no-refine" in err
    # an executor that names neither (the default) or a run that uses it passes the check: the model is read next
    for options in ({"refine": False, "executor": Executor()}, {"refine": False, "replicates": 3,
                                                                  "executor": Executor(workers=2)}):
        with pytest.raises(AssertionError, match="the model was read"):
            IdentifyRequest(model=MODELS / "bouc_wen.toml", record="r.csv", **options)


def test_one_obsnl_identify_probes_its_scheduler_once_and_checks_its_data_when_the_request_is_made(
        tmp_path, monkeypatch):
    """The request probed the scheduler, then the library's identify probed it again (a second connection to a Dask
    scheduler per run), and the data were read only when the request ran: now the request holds the identification
    checked once (``check_identify``), and the run (``run_identification``) checks nothing again."""
    import numpy as np

    import obsnl.identification.identify as ident
    from obsnl.commands.identify import IdentifyRequest, run_identify

    probes = []
    monkeypatch.setattr(Executor, "probe", lambda self, timeout=5.0: probes.append(self) or self)
    model = tmp_path / "leak.toml"
    model.write_text('name = "leak"\nstates = ["x"]\nparameters = ["a"]\ninputs = ["u"]\n'
                     '[equations]\nx = "u - a*x"\n[outputs]\ny = "x"\n[guess]\na = 1.0\n')
    with pytest.raises(ObsnlError, match="does not exist"):  # a missing data file: when the request is made
        IdentifyRequest(model=model, data=tmp_path / "none.csv", executor=Executor(workers=2))
    t = np.arange(60) * 0.1
    csv = tmp_path / "d.csv"
    csv.write_text("t,u,y\n" + "".join(f"{a:.1f},{np.sin(a):.6f},{0.1 * np.sin(a):.6f}\n" for a in t))
    probes.clear()
    request = IdentifyRequest(model=model, data=csv, executor=Executor(workers=2))
    assert len(probes) == 1 and request.checked.data is not None and len(request.checked.data.y) == 60

    def no_filter(*a, **k):  # noqa: ANN002, ANN003
        raise SystemExit("the filter was reached")

    monkeypatch.setattr(ident, "identify_measured", no_filter)
    with pytest.raises(SystemExit, match="the filter was reached"):
        run_identify(request)
    assert len(probes) == 1  # the run did not probe again
    with pytest.raises(SystemExit, match="the filter was reached"):
        ident.identify(model, csv, executor=Executor(workers=2), progress=False)
    assert len(probes) == 2  # the library's own door probes once too


@pytest.mark.parametrize("job", ["IdentifyRequest", "ReproduceRequest", "report_paths", "SensorsRequest"])
def test_the_jobs_refuse_a_dead_scheduler_before_any_work(tmp_path, monkeypatch, job):
    """A scheduler address where nothing listens (port 1 of the loopback: refused at once) is refused by the job
    itself, from Python too, before a model or a record is read."""
    import obsnl.batch as batch
    import obsnl.model.files as files
    from obsnl.commands import SensorsRequest, run_sensors
    from obsnl.commands.identify import IdentifyRequest
    from obsnl.commands.reproduce import ReproduceRequest

    def tripwire(*a, **k):  # noqa: ANN002, ANN003
        raise AssertionError("work started before the scheduler was probed")

    for module in (batch, files):
        monkeypatch.setattr(module, "read_model", tripwire)
    dead = Executor(scheduler="tcp://127.0.0.1:1")
    call = {"IdentifyRequest": lambda: IdentifyRequest(model=MODELS / "bouc_wen.toml", record="r.csv", executor=dead),
            "ReproduceRequest": lambda: ReproduceRequest(out=tmp_path / "o", record="r.csv", executor=dead),
            "report_paths": lambda: batch.report_paths([MODELS / "bouc_wen.toml"], tmp_path / "o", executor=dead),
            "SensorsRequest": lambda: run_sensors(SensorsRequest(model=MODELS / "bouc_wen.toml", executor=dead))}[job]
    with pytest.raises(OptionError, match="cannot reach the Dask scheduler"):
        call()
    assert not (tmp_path / "o").exists()


def test_a_printed_rendering_goes_to_standard_output_or_to_its_file(tmp_path):
    from obsnl.report.printed import Printed, printed

    assert printed("table", None, undecided="branch (b) is inconclusive: t") == Printed("table",
                                                                                       "branch (b) is inconclusive: t")
    out = tmp_path / "t.md"
    assert printed("table", str(out)) == Printed(None, None)
    assert out.read_text(encoding="utf-8") == "table\n"  # one final newline, as on standard output
    with pytest.raises(OutputError, match="exists; pass force=True"):
        printed("other", str(out))
    assert printed("other\n", str(out), force=True).text is None and out.read_text(encoding="utf-8") == "other\n"


def test_a_command_prints_what_its_module_returns(tmp_path, capsys):
    """A command's text is its module's text: ``obsnl branches`` prints what ``obsnl.commands.branches`` returns,
    ``obsnl analyze -o`` writes what ``obsnl.commands.analyze`` renders (the analysis seeded, its timings set
    aside)."""
    import json

    from obsnl.commands import analyze, branches

    assert main(["branches", str(MODELS / "coulomb_friction.toml"), "--equations"]) == 0
    shown = branches.branches_printed(branches.run_branches(branches.BranchesRequest(model=MODELS / "coulomb_friction.toml",
                                                                   equations=True)))
    assert capsys.readouterr().out == shown.text + "\n"
    out = tmp_path / "a.json"
    assert main(["analyze", str(MODELS / "coulomb_friction.toml"), "--seed", "3", "--format", "json", "-o",
                 str(out)]) == 0
    printed = analyze.analyze_printed(analyze.run_analyze(analyze.AnalyzeRequest(model=MODELS / "coulomb_friction.toml", seed=3,
                                                                 fmt="json")))

    def untimed(doc):  # the document without its wall-clock fields
        if isinstance(doc, dict):
            return {k: untimed(v) for k, v in doc.items() if "seconds" not in k}
        return [untimed(v) for v in doc] if isinstance(doc, list) else doc

    assert untimed(json.loads(out.read_text())) == untimed(json.loads(printed.text)) and printed.undecided is None


def test_the_guides_python_request_runs_what_the_command_runs(tmp_path, capsys):
    """The user guide's example: ``run_analyze(AnalyzeRequest(...))`` renders what ``obsnl analyze ... --format md``
    prints, and refuses a record that is not there with the command's one line (in Python's keyword terms)."""
    import math

    from obsnl.commands import AnalyzeRequest, run_analyze

    rec = tmp_path / "rec.csv"
    rec.write_text("time_s,u\n" + "".join(f"{i * 0.01:.2f},{math.sin(i * 0.05):.6f}\n" for i in range(200)),
                   encoding="utf-8")
    assert main(["analyze", "obsnl:coulomb_friction", "--record", str(rec), "--format", "md", "--seed", "0"]) == 0
    printed = capsys.readouterr().out
    result = run_analyze(AnalyzeRequest(model="obsnl:coulomb_friction", record=rec, fmt="md", seed=0))
    assert printed.rstrip("\n") == result.rendering.rstrip("\n") and result.analysis.visited.how == "record"
    missing = tmp_path / "none.csv"
    with pytest.raises(ObsnlError) as info:
        run_analyze(AnalyzeRequest(model="obsnl:coulomb_friction", record=missing))
    assert main(["analyze", "obsnl:coulomb_friction", "--record", str(missing)]) == 2
    assert capsys.readouterr().err == f"obsnl analyze: error: {cli_terms(str(info.value), _sub('analyze'))}\n"


@pytest.mark.parametrize("command", ["analyze", "sensors", "design", "show", "branches", "symmetries", "reparametrize",
                                     "identify"])
@pytest.mark.parametrize("model", [3, None, {"name": "m"}])
def test_a_model_of_the_wrong_kind_is_refused_in_one_line_from_python(command, model):
    """``run_analyze(AnalyzeRequest(model=3))`` raised a TypeError from deep in the file reader (``open(3)`` would even
    read file descriptor 3): every door now refuses what is neither a Model nor a path, naming the kinds it takes."""
    import obsnl.commands as commands

    request = getattr(commands, f"{command.capitalize()}Request")
    extra = {"design": {"records": ["r.csv"]}, "identify": {"data": "d.csv"}}.get(command, {})
    with pytest.raises(OptionError, match=r"a model is an obsnl Model, the path of a \.toml or \.json model file or "
                                          r"obsnl:NAME; got (int|NoneType|dict)"):
        getattr(commands, f"run_{command}")(request(model=model, **extra))


@pytest.mark.parametrize("command, options, words", [
    ("analyze", {"fmt": "xml"}, "unknown format 'xml'; formats are text, json, md, tex, json-table"),
    ("sensors", {"fmt": "xml"}, "unknown format 'xml'; formats are text, json, md, tex"),  # a ValueError, after the work
    ("design", {"records": ["r.csv"], "fmt": "json-table"}, "unknown format 'json-table'; formats are text, json, md"),
    ("show", {"fmt": "xml"}, "unknown format 'xml'; formats are text, json"),  # rendered as text
    ("branches", {"fmt": "md"}, "unknown format 'md'; formats are text, json"),
    ("symmetries", {"fmt": "tex"}, "unknown format 'tex'; formats are text, json"),
    ("analyze", {"record": 5}, "record= takes a file name (text or a path), got int 5"),  # open(5): a TypeError
    ("analyze", {"output": 7}, "output= takes a file name (text or a path), got int 7"),
    ("sensors", {"record": 2.5}, "record= takes a file name (text or a path), got float 2.5"),
    ("design", {"records": ["r.csv", 4]}, "record= takes a file name (text or a path), got int 4"),
    ("design", {"records": ["r.csv"], "figure": True}, "figure= takes a file name (text or a path), got bool True"),
])
def test_a_request_refuses_a_format_or_a_file_option_of_the_wrong_kind_before_the_model_is_read(
        monkeypatch, command, options, words):
    import obsnl.commands as commands
    import obsnl.model.files as files

    def tripwire(*a, **k):  # noqa: ANN002, ANN003
        raise AssertionError("the model was read before the request was checked")

    monkeypatch.setattr(files, "read_model", tripwire)
    with pytest.raises(OptionError) as info:
        getattr(commands, f"run_{command}")(getattr(commands, f"{command.capitalize()}Request")(
            model=MODELS / "coulomb_friction.toml", **options))
    assert str(info.value).startswith(words), str(info.value)


def test_a_request_reads_text_as_the_command_line_reads_it(tmp_path):
    """``branches="ab"`` is the label ab (it was the labels a and b: its characters), ``"a, b"`` two labels as
    ``--branches a,b``; ``records="r.csv"`` is the one record (its characters were read as the files 'r', '.', ...),
    ``models="m.toml"`` the one model."""
    from obsnl.commands import AnalyzeRequest, DesignRequest, ReportRequest

    assert AnalyzeRequest(model="m.toml", branches="a, b").branches == ["a", "b"]
    assert AnalyzeRequest(model="m.toml", branches="ab").branches == ["ab"]
    assert DesignRequest(model="m.toml", records="r.csv").records == ("r.csv",)
    assert DesignRequest(model="m.toml", records=tmp_path / "r.csv").records == (tmp_path / "r.csv",)
    assert ReportRequest(models="m.toml", out="o").models == ("m.toml",)  # its characters were read as model files


@pytest.mark.parametrize("request_, words", [
    (lambda c: c.ValidateRequest(model="m.toml", params="p.json", data="d.csv", out=3), "out= takes a folder name"),
    (lambda c: c.ValidateRequest(model="m.toml", params="p.json", data=2.0, out="o"), "data= takes a file name"),
    (lambda c: c.ReportRequest(models=["m.toml"], out=4), "out= takes a folder name"),
    (lambda c: c.ReportRequest(models=["m.toml", 5], out="o"), "models= takes a file name"),
    (lambda c: c.IdentifyRequest(model="m.toml", data="d.csv", out=3), "out= takes a folder name"),
    (lambda c: c.IdentifyRequest(model="m.toml", record=3), "record= takes a file name"),  # an AttributeError deep in
    (lambda c: c.ReproduceRequest(out=3), "out= takes a folder name"),
    (lambda c: c.ReproduceRequest(record=3, out="o"), "record= takes a file name"),
    (lambda c: c.BankRequest(out=3), "out= takes a folder name"),
    (lambda c: c.ReparametrizeRequest(model="m.toml", output=3), "output= takes a file name"),
], ids=["validate-out", "validate-data", "report-out", "report-models", "identify-out", "identify-record",
        "reproduce-out", "reproduce-record", "bank-out", "reparametrize-output"])
def test_every_request_refuses_a_file_or_folder_option_of_the_wrong_kind_when_made(monkeypatch, request_, words):
    """Each of these reached ``open()`` or ``Path()`` with a number (a TypeError, or file descriptor 3 read): refused
    when the request is made, before any file is read."""
    import obsnl.commands as commands
    import obsnl.model.files as files

    def tripwire(*a, **k):  # noqa: ANN002, ANN003
        raise AssertionError("a model was read before the request was checked")

    monkeypatch.setattr(files, "read_model", tripwire)
    with pytest.raises(OptionError, match=words + r" \(text or a path\), got (int|float)"):
        request_(commands)
