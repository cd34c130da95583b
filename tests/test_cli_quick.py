"""``obsnl reproduce --quick``: the quick preset, its own folder (never the committed results), no overwrite
without --force; Table 2 never calls the 5 % goal met when most parameters are flagged; the program exits
normally (its atexit handlers run)."""

from __future__ import annotations

import copy
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

from obsnl.cli import main

ROOT = Path(__file__).resolve().parents[1]


class _Called(Exception):
    pass


@pytest.fixture
def fake_reproduce(monkeypatch):
    """``seed_paper.reproduce`` replaced by a recorder that stops the command (no filter runs)."""
    import obsnl.studies.seed_paper as seed_paper

    seen = {}

    def fake(**kwargs):
        seen.update(kwargs)
        raise _Called

    monkeypatch.setattr(seed_paper, "reproduce", fake)
    return seen


def test_quick_is_the_preset_and_writes_into_its_own_folder(tmp_path, monkeypatch, capsys, fake_reproduce):
    from obsnl.studies.seed_paper import QUICK

    monkeypatch.chdir(tmp_path)
    (tmp_path / "reports" / "identification").mkdir(parents=True)
    with pytest.raises(_Called):
        main(["reproduce", "--quick"])
    assert {k: fake_reproduce[k] for k in QUICK} == QUICK
    assert "regenerating" not in capsys.readouterr().err  # the committed folder is not announced, not touched
    assert list((tmp_path / "reports" / "identification").iterdir()) == []
    with pytest.raises(_Called):  # an option given wins over the preset
        main(["reproduce", "--quick", "--seeds", "2"])
    assert fake_reproduce["seeds"] == 2 and fake_reproduce["samples"] == QUICK["samples"]


def test_quick_writes_reproduce_quick_and_never_the_committed_folder(tmp_path, monkeypatch, capsys):
    import obsnl.studies.seed_paper as seed_paper
    import obsnl.studies.seed_reproduction as seed_reproduction

    written = []
    monkeypatch.setattr(seed_paper, "reproduce", lambda **kw: "rep")
    monkeypatch.setattr(seed_reproduction, "write_reproduction",
                        lambda rep, out, force: written.append((Path(out), force)) or [Path(out) / "table2.md"])
    monkeypatch.chdir(tmp_path)
    assert main(["reproduce", "--quick"]) == 0
    assert written == [(Path("reproduce-quick"), False)]
    assert "wrote 1 files to reproduce-quick: table2.md" in capsys.readouterr().out


def test_quick_refuses_to_overwrite_without_force(tmp_path, monkeypatch, capsys, fake_reproduce):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "reproduce-quick").mkdir()
    (tmp_path / "reproduce-quick" / "table2.md").write_text("mine")
    assert main(["reproduce", "--quick"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "table2.md" in err and "--force" in err and not fake_reproduce
    assert (tmp_path / "reproduce-quick" / "table2.md").read_text() == "mine"
    with pytest.raises(_Called):  # with --force the run starts
        main(["reproduce", "--quick", "--force"])


def _goal_cells(markdown: str, filter_name: str) -> list[str]:
    """The '5 % goal (worst seed, unflagged)' cell of ``filter_name``'s cost rows."""
    return [line.split(" | ")[-2] for line in markdown.splitlines() if line.startswith(f"| {filter_name} | ")
            and line.count("|") == 11]


def test_the_goal_is_not_called_met_when_most_parameters_are_flagged():
    from obsnl.report.identification import table2_markdown
    from obsnl.studies.seed_reproduction import Reproduction

    doc = json.loads((ROOT / "reports" / "identification" / "table2.json").read_text())
    assert _goal_cells(table2_markdown(Reproduction.from_dict(doc)), "UKF")[0] == "met"  # 3 of 9 flagged
    params = list(doc["experiment"]["truth"])
    flagged = copy.deepcopy(doc)
    for r in flagged["runs"]:
        if r["method"] == "ukf" and r["passes"] == 1:  # most flagged, the others as committed (within 5 %)
            prac = r["practical_identifiability"]
            prac["flagged"] = r["practically_unidentifiable"] = sorted(set(prac["flagged"]) | set(params[:6]))
    cell = _goal_cells(table2_markdown(Reproduction.from_dict(flagged)), "UKF")[0]
    assert cell.startswith("not judged (") and not re.search(r"\bmet\b", cell), cell
    assert int(re.search(r"(\d) of 9 parameters flagged", cell)[1]) > 4


def test_the_program_exits_normally():
    """``obsnl.cli.run`` ends in a normal interpreter exit: atexit handlers run, a pipe is flushed, the codes kept."""
    prog = ("import atexit, sys; atexit.register(lambda: print('atexit ran', file=sys.stderr)); "
            "from obsnl.cli import run; run()")
    r = subprocess.run([sys.executable, "-c", prog, "show", "obsnl:coulomb_friction"], capture_output=True,
                       text=True, timeout=120)
    assert r.returncode == 0 and "atexit ran" in r.stderr and "parameters: m, c, k, F_c" in r.stdout
    r = subprocess.run([sys.executable, "-c", prog, "show", "missing.toml"], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 2 and "atexit ran" in r.stderr and "does not exist" in r.stderr
    src = (ROOT / "obsnl" / "cli" / "__init__.py").read_text()
    assert "os._exit" not in src and "_run_exitfuncs" not in src
