"""Issue 25, item 6: the library names its options by their Python keywords (``allow_unidentifiable=True``,
``max_seconds=``, ``guess=``) and the command line prints its own flags for them.

(1) From Python, typical refusals name the keyword and no ``--flag``; (2) the same refusals from ``obsnl``
name the flag and not the keyword (the translation reads each option's ``dest`` off the parser); (3) no
module outside ``obsnl/cli`` has a string (other than a docstring) with a ``--flag``, but for the few
entries of :data:`ALLOWED`, each justified. Every check is exact, so no error probability to state."""

from __future__ import annotations

import argparse
import ast
import re

import pytest

import obsnl
from obsnl.cli import main
from obsnl.cli.common import cli_terms
from obsnl.errors import AnalysisError, OptionError
from obsnl.model.bounds.budget import time_budget

from .conftest import MODELS, ROOT

FLAG = re.compile(r"(?<![\w-])--[a-z][a-z-]*")
MSD = MODELS / "msd_force_accel.toml"  # (m, c, k, g) -> lambda (m, c, k, g): structurally unidentifiable
GUESS = {"m": 1.0, "c": 1.0, "k": 1.0, "g": 1.0}

#: (module, flag): the strings that may name a ``--flag``, and why.
ALLOWED = {
    ("obsnl/estimation/jitcache.py", "--version"): "the C compiler's own option, passed to the compiler",
}


@pytest.fixture()
def msd_csv(tmp_path):
    path = tmp_path / "msd.csv"
    path.write_text("t,u,y\n0,1,0\n0.1,1,0\n0.2,3,0\n", encoding="utf-8")
    return path


def _python(call) -> str:
    with pytest.raises((OptionError, AnalysisError)) as info:
        call()
    return str(info.value)


def test_python_refusals_name_keywords_not_flags(msd_csv):
    unidentifiable = _python(lambda: obsnl.identify(MSD, msd_csv, guess=GUESS))
    assert "structurally unidentifiable" in unidentifiable and "allow_unidentifiable=True" in unidentifiable
    bad_seconds = _python(lambda: obsnl.analyze(MODELS / "bouc_wen.toml", max_seconds=-1))
    assert bad_seconds.startswith("max_seconds= must be a positive") and bad_seconds.endswith("got -1")
    with time_budget(1e-9):  # what `obsnl analyze --max-seconds` opens before the model is read
        too_short = _python(lambda: obsnl.analyze(MODELS / "bouc_wen.toml"))
    assert "time limit" in too_short and "max_seconds=" in too_short
    misspelt = _python(lambda: obsnl.identify(MSD, msd_csv, guess={"kk": 3.0}, allow_unidentifiable=True))
    assert misspelt.startswith("guess= names 'kk', which is not a parameter")
    for message in (unidentifiable, bad_seconds, too_short, misspelt):
        assert not FLAG.search(message.replace("`obsnl reparametrize MODEL -o NEW.toml`", "")), message


def _cli(capsys, *argv: str) -> str:
    assert main(list(argv)) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1
    return err


def test_cli_refusals_name_flags_not_keywords(msd_csv, capsys):
    guesses = [a for k, v in GUESS.items() for a in ("--guess", f"{k}={v}")]
    err = _cli(capsys, "identify", str(MSD), "--data", str(msd_csv), *guesses)
    assert "structurally unidentifiable" in err and "pass --allow-unidentifiable" in err
    assert "allow_unidentifiable" not in err
    err = _cli(capsys, "analyze", str(MODELS / "bouc_wen.toml"), "--max-seconds", "1e-9")
    assert "time limit" in err and "(--max-seconds); raise --max-seconds" in err and "max_seconds" not in err
    err = _cli(capsys, "identify", str(MSD), "--data", str(msd_csv), "--guess", "kk=3", "--allow-unidentifiable")
    assert "--guess 'kk=3'" in err and "'kk' is not a parameter" in err and "guess=" not in err


def test_translation_reads_the_parser():
    p = argparse.ArgumentParser()
    for flag in ("--hold", "--no-refine", "--jit"):
        p.add_argument(flag, action="store_true")
    for flag in ("--s0", "--method", "--max-seconds", "--guess"):
        p.add_argument(flag)
    text = ("pass hold=True, refine=False or jit=False; s0=0.1 or method='dukf'; raise max_seconds=, give guess= "
            "(k=2, seed=3 and the word hold stay)")
    assert cli_terms(text, p) == ("pass --hold, --no-refine or without --jit; --s0 0.1 or --method dukf; raise "
                                  "--max-seconds, give --guess (k=2, seed=3 and the word hold stay)")


def _strings(tree: ast.AST) -> list[ast.Constant]:
    """Every string constant of a module but its docstrings (the parts of f-strings included)."""
    docs = {id(n.body[0].value) for n in ast.walk(tree)
            if isinstance(n, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and n.body
            and isinstance(n.body[0], ast.Expr) and isinstance(n.body[0].value, ast.Constant)}
    return [n for n in ast.walk(tree) if isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in docs]


def test_no_library_message_names_a_flag():
    found, used = [], set()
    for path in sorted((ROOT / "obsnl").rglob("*.py")):
        module = path.relative_to(ROOT).as_posix()
        if module.startswith("obsnl/cli/"):
            continue
        for node in _strings(ast.parse(path.read_text(encoding="utf-8"))):
            text = re.sub(r"`(obsnl|dask) [^`]*`", "", node.value)  # a command to run, quoted as such
            for flag in FLAG.findall(text):
                if (module, flag) in ALLOWED:
                    used.add((module, flag))
                else:
                    found.append(f"{module}:{node.lineno}: {flag}")
    assert found == []
    assert used == set(ALLOWED)  # no stale entry
