"""Issue 25, item 4: the checks, file workflows and lines the thin command line left to the library.

(1) A bound is the library's: Python and ``obsnl`` refuse the same value with the same message, the command
line's only in its flags (``cli_terms``); (2) the file jobs refuse an output file that cannot be written
before any work (a tripwire on the work); (3) the renamings of ``reparametrize_job`` are ``OLD=NEW``; (4) the
undecided sensor sets make one line. Every check is exact, so no error probability to state.
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
    assert in_terms("joint=False", {"joint": ("--no-joint", False)}) == "--no-joint"


@pytest.mark.parametrize("job", ["analyze_file", "sensors_file", "design_file", "reparametrize_job"])
def test_an_output_that_cannot_be_written_is_refused_before_any_work(tmp_path, monkeypatch, job):
    import obsnl.design.records as records
    import obsnl.model.files as files
    from obsnl.studies import jobs

    def tripwire(*a, **k):  # noqa: ANN002, ANN003
        raise AssertionError("the model was read before the output was checked")

    monkeypatch.setattr(records, "read_model", tripwire)
    monkeypatch.setattr(files, "read_model", tripwire)
    out = tmp_path / "taken.md"
    out.write_text("keep me", encoding="utf-8")
    call = {"analyze_file": lambda: records.analyze_file(MODELS / "bouc_wen.toml", output=str(out)),
            "sensors_file": lambda: records.sensors_file(MODELS / "bouc_wen.toml", output=str(out)),
            "design_file": lambda: records.design_file(MODELS / "bouc_wen.toml", ["r.csv"], output=str(out)),
            "reparametrize_job": lambda: jobs.reparametrize_job(MODELS / "bouc_wen.toml", output=str(out))}[job]
    with pytest.raises(OutputError, match="exists; pass force=True"):
        call()
    assert out.read_text(encoding="utf-8") == "keep me"


@pytest.mark.parametrize("names", [["x"], ["a=b=c"], ["=b"], ["a="]])
def test_reparametrize_job_takes_old_equals_new(names):
    from obsnl.studies.jobs import reparametrize_job

    with pytest.raises(OptionError, match="names= takes OLD=NEW"):
        reparametrize_job(MODELS / "bouc_wen.toml", names=names)


def test_the_undecided_sensor_sets_make_one_line():
    from obsnl.report.sensors import undecided_line

    first = SimpleNamespace(sensors=("a", "b"), reason="")
    search = SimpleNamespace(undecided_sets=(("a", "b"), ("c",)), answer=lambda s: first)
    assert undecided_line(search) == ("2 sensor set(s) undecided, e.g. {a, b}: minimality undecided; raise "
                                      "max_seconds=")
    assert undecided_line(SimpleNamespace(undecided_sets=())) is None
