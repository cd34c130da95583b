"""The command line: exit codes, --help everywhere, one-line errors without tracebacks."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from obsnl.cli import build_parser, main

from .conftest import MODELS


def run(argv, capsys):
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_help_everywhere(capsys):
    code, out, _ = run(["--help"], capsys)
    assert code == 0 and "show" in out and "branches" in out
    sub = build_parser()._subparsers._group_actions[0].choices  # type: ignore[union-attr]
    for name in sub:
        code, out, _ = run([name, "--help"], capsys)
        assert code == 0 and "usage: obsnl " + name in out


def test_no_command_is_an_error_on_stderr(capsys):
    code, out, err = run([], capsys)  # used to print the whole help on stdout and exit 2
    assert code == 2 and out == "" and err.splitlines()[-1] == "obsnl: error: choose a command (obsnl --help lists them)"


def test_show(capsys):
    code, out, _ = run(["show", str(MODELS / "coulomb_friction.toml")], capsys)
    assert code == 0
    assert "d/dt v = " in out and "F_c*sign(v)" in out and "parameters: m, c, k, F_c" in out
    code, out, _ = run(["show", str(MODELS / "coulomb_friction.toml"), "--format", "json"], capsys)
    assert code == 0 and json.loads(out)["states"] == ["x", "v"]


def test_branches_json(capsys):
    code, out, _ = run(["branches", str(MODELS / "damage_healing.toml"), "--format", "json"], capsys)
    assert code == 0
    doc = json.loads(out)
    assert doc["model"] == "damage_healing"
    assert [b["label"] for b in doc["branches"]] == ["a", "b", "c", "d"]
    assert doc["branches"][2]["guard"] == "(sigma - eta < 0) & (x2 < 0)"
    assert set(doc) == {"model", "branches"} and all(set(b) == {"label", "guard"} for b in doc["branches"])


@pytest.mark.parametrize("content, match", [
    ('name = "m"\nstates = ["x"]\n[equations]\nx = "-k*x"\n', "undeclared symbol 'k'"),
    ('name = "m"\nstates = ["x"]\n[equations]\nx = "-(x"\n', "syntax error"),
    ('name = "m"\nstates = [\n', "not valid TOML"),
])
def test_bad_input_exits_2_with_one_line(tmp_path, capsys, content, match):
    p = tmp_path / "m.toml"
    p.write_text(content)
    for cmd in ("show", "branches"):
        code, out, err = run([cmd, str(p)], capsys)
        assert code == 2
        assert match in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_missing_file_and_usage_errors(capsys):
    code, _, err = run(["show", "no_such_model.toml"], capsys)
    assert code == 2 and "does not exist" in err
    code, _, _ = run(["branches"], capsys)  # missing argument: argparse usage error
    assert code == 2
    code, _, _ = run([], capsys)
    assert code == 2


def test_console_script_runs_as_module():
    r = subprocess.run([sys.executable, "-m", "obsnl", "branches", str(MODELS / "coulomb_friction.toml")],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and "(a) v > 0" in r.stdout


def _untimed(doc):
    """The document without its wall-clock fields (``seconds``)."""
    if isinstance(doc, dict):
        return {k: _untimed(v) for k, v in doc.items() if "seconds" not in k}
    return [_untimed(v) for v in doc] if isinstance(doc, list) else doc


def test_the_program_loses_nothing_at_exit(tmp_path, capsys):
    """``obsnl.cli.run`` (the program) ends in a normal exit: the printed output, a written file, the exit
    codes (0, and 2 with its one-line error) and the atexit handlers. Expected output: the in-process
    ``main`` on the same arguments."""
    model = str(MODELS / "coulomb_friction.toml")
    code, want, _ = run(["analyze", model, "--seed", "3", "--format", "json"], capsys)
    assert code == 0
    prog = ("import atexit, sys; atexit.register(lambda: print('atexit ran', file=sys.stderr)); "
            "from obsnl.cli import run; run()")
    r = subprocess.run([sys.executable, "-c", prog, "analyze", model, "--seed", "3", "--format", "json"],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and "atexit ran" in r.stderr
    assert _untimed(json.loads(r.stdout)) == _untimed(json.loads(want))  # a pipe is block-buffered: flushed
    out = tmp_path / "a.json"
    r = subprocess.run([sys.executable, "-m", "obsnl", "analyze", model, "--seed", "3", "--format", "json",
                        "-o", str(out)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and _untimed(json.loads(out.read_text())) == _untimed(json.loads(want))
    r = subprocess.run([sys.executable, "-m", "obsnl", "analyze", str(tmp_path / "missing.toml")],
                       capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
