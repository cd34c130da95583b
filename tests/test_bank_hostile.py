"""Hostile link model files and output folders for ``obsnl bank`` (review of the cantilever-link benchmark).

Every bad model file must be refused with one line naming the key and the fix (an ``obsnl.errors`` exception;
``obsnl bank: error: ...`` with exit code 2 on the command line) before any simulation and before any file
is written; no output file may be written through a symbolic link.
"""

from __future__ import annotations

import dataclasses
import json
import os
import re
from pathlib import Path

import pytest

from obsnl.cli import main
from obsnl.errors import ModelError, ObsnlError, OutputError
from obsnl.studies.cantilever import DEFAULT_LINK_FILE, Cantilever, read_link_spec
from obsnl.studies.link_study import run_link_study


def edited(tmp_path: Path, *edits: str) -> Path:
    """A copy of the packaged link model with ``key = value`` lines replaced."""
    text = DEFAULT_LINK_FILE.read_text(encoding="utf-8")
    for edit in edits:
        key = edit.split(" =")[0]
        text, n = re.subn(rf"^{key} = .*$", edit, text, flags=re.MULTILINE)
        assert n == 1, edit
    path = tmp_path / "link.toml"
    path.write_text(text, encoding="utf-8")
    return path


@pytest.fixture
def no_simulation(monkeypatch):
    """Every check must come before the first simulation: simulating fails the test."""
    def simulate(*args, **kwargs):
        raise AssertionError("the link was simulated before the model file was checked")

    monkeypatch.setattr(Cantilever, "simulate", simulate)


def refusal(tmp_path: Path, *edits: str, seeds: int = 1) -> str:
    """The one-line message with which reading the edited model file and starting a study are refused."""
    with pytest.raises(ObsnlError) as info:
        run_link_study(seeds=seeds, spec=read_link_spec(edited(tmp_path, *edits)), gates=False)
    msg = str(info.value)
    assert "\n" not in msg and "Traceback" not in msg
    return msg


def refused_by_cli(capsys, args: list[str]) -> str:
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("obsnl bank: error: ") and "\n" not in err and "Traceback" not in err
    return err


# ----------------------------------------------------------------------------- 1 driven node
@pytest.mark.parametrize("edit", ["driven_node = 0", "driven_node = 9", "driven_node = 1.5"])
def test_1_driven_node_must_be_an_actuator(tmp_path, no_simulation, edit):
    with pytest.raises(ModelError, match=r"driven_node = .*actuator_nodes|driven_node = .*whole number"):
        read_link_spec(edited(tmp_path, edit))


# ----------------------------------------------------------------------------- 2 wrong types
@pytest.mark.parametrize("edit, key", [('dt = "x"', "dt"), ("q_v = [1e8]", "q_v"), ("zeta = true", "zeta"),
                                       ('channels = "moment"', "channels"), ('S1 = "theta1"', "S1")])
def test_2_wrong_types_are_named(tmp_path, no_simulation, edit, key):
    msg = refusal(tmp_path, edit)
    assert f"{key} = " in msg and "link.toml" in msg


# ----------------------------------------------------------------------------- 3 sizes
@pytest.mark.parametrize("edit, limit", [("duration = 1e9", "1,000,000"), ("dt = 1e-9", "1,000,000"),
                                         ("n_elements = 100000", "50"), ("n_elements = 10000000000000000000000", "50")])
def test_3_sizes_are_bounded_by_named_limits(tmp_path, no_simulation, edit, limit):
    msg = refusal(tmp_path, edit)
    assert edit.split(" =")[0] in msg and "limit" in msg and limit in msg


def test_3_memory_of_the_whole_study_is_bounded(no_simulation):
    with pytest.raises(ModelError, match=r"GiB of memory, over the limit of \d+ GiB"):
        run_link_study(seeds=200, gates=False)
    with pytest.raises(ObsnlError, match="at most 1000"):
        run_link_study(seeds=10**9, gates=False)
    spec = read_link_spec()
    many = dataclasses.replace(spec, bank={**spec.bank, "dt": 1e-5})  # 600 001 samples
    with pytest.raises(ModelError, match="limit"):
        run_link_study(seeds=20, spec=many, gates=False)


# ----------------------------------------------------------------------------- 4 checked before any file
@pytest.mark.parametrize("edit", ["evaluation_window = 0.0", "evaluation_window = 4.0", "detection_window = 0.0"])
def test_4_bad_windows_are_refused_before_any_file_is_written(tmp_path, capsys, edit):
    out = tmp_path / "out"
    err = refused_by_cli(capsys, ["bank", "--seeds", "1", "--out", str(out), "--model", str(edited(tmp_path, edit))])
    assert edit.split(" =")[0] in err
    assert not out.exists()


# ----------------------------------------------------------------------------- 5 silently accepted
@pytest.mark.parametrize("edit, words", [
    ("onset = 100.0", ["onset", "duration"]),
    ("onset = 6.0", ["onset", "duration"]),
    ('opens_when = "whenever"', ["opens_when", "'negative curvature'"]),
    ("n_elements = 6.7", ["n_elements", "whole number"]),
    ("observer_elements = [2, 2, 6]", ["observer_elements", "twice"]),
    ("observer_elements = [2, 4, 7]", ["observer_elements", "1..6"]),
    ("crack_elements = [0, 1]", ["crack_elements", "1..6"]),
    ("crack_elements = [3, 3]", ["crack_elements", "twice"]),
    ("actuator_nodes = [1, 2, 2]", ["actuator_nodes", "twice"]),
    ('S1 = ["theta1", "theta9"]', ["S1", "theta9"]),
])
def test_5_values_that_were_silently_accepted_are_refused(tmp_path, no_simulation, edit, words):
    msg = refusal(tmp_path, edit)
    assert all(w in msg for w in words), msg


# ----------------------------------------------------------------------------- 6 messages, obsnl:NAME
def test_6_model_path_messages_and_the_packaged_model(tmp_path, capsys):
    with pytest.raises(ModelError, match="is a folder") as info:
        read_link_spec(tmp_path)
    assert "not found" not in str(info.value)
    err = refused_by_cli(capsys, ["bank", "--seeds", "1", "--out", str(tmp_path / "o"), "--model", str(tmp_path)])
    assert "folder" in err and not (tmp_path / "o").exists()
    assert read_link_spec("obsnl:cantilever_link") == read_link_spec()
    missing = DEFAULT_LINK_FILE.read_text(encoding="utf-8").replace("\nonset = ", "\n# onset = ")
    (tmp_path / "m.toml").write_text(missing, encoding="utf-8")
    with pytest.raises(ModelError) as info:
        run_link_study(seeds=1, spec=read_link_spec(tmp_path / "m.toml"), gates=False)
    msg = str(info.value)
    assert "onset" in msg and "models/cantilever_link.toml" in msg and "obsnl/catalogue" not in msg


# ----------------------------------------------------------------------------- 7 links in the output folder
def _victim_and_links(tmp_path: Path, out: Path, names: list[str]) -> Path:
    victim = tmp_path / "victim.txt"
    victim.write_text("not yours", encoding="utf-8")
    out.mkdir()
    for name in names:
        os.symlink(victim, out / name)
    return victim


def _plain_files(out: Path, names: list[str]) -> bool:
    return all((out / n).is_file() and not (out / n).is_symlink() and (out / n).stat().st_size > 0 for n in names)


def test_7_the_report_writer_never_writes_through_a_link(tmp_path):
    from obsnl.report.bank import write_bank_report

    spec = read_link_spec()
    short = dataclasses.replace(spec, bank={**spec.bank, "dt": 1e-3, "duration": 0.6, "onset": 0.3,
                                            "evaluation_window": 0.3, "detection_window": 0.1, "crack_elements": [2]})
    study = run_link_study(seeds=1, spec=short, gates=False)
    out = tmp_path / "out"
    links = ["forces_healthy.png", "bank.md"]
    victim = _victim_and_links(tmp_path, out, links)
    with pytest.raises(OutputError, match="symlink"):
        write_bank_report(study, out)
    assert sorted(p.name for p in out.iterdir()) == sorted(links)  # nothing written, no temporary left
    files = write_bank_report(study, out, force=True)
    assert [p.name for p in files] == ["bank.json", "bank.md", "forces_healthy.png", "forces_crack2.png"]
    assert _plain_files(out, [p.name for p in files]) and sorted(p.name for p in out.iterdir()) == sorted(
        p.name for p in files)
    assert victim.read_text(encoding="utf-8") == "not yours"
    assert json.loads((out / "bank.json").read_text())["settings"]["duration"] == 0.6


def test_7_bank_force_replaces_links_instead_of_writing_through_them(tmp_path, capsys):
    out = tmp_path / "out"
    links = ["forces_healthy.png", "bank.json"]
    victim = _victim_and_links(tmp_path, out, links)
    err = refused_by_cli(capsys, ["bank", "--seeds", "1", "--out", str(out), "--model", "obsnl:cantilever_link"])
    assert "--force" in err and victim.read_text(encoding="utf-8") == "not yours"
    assert main(["bank", "--seeds", "1", "--out", str(out), "--force", "--model", "obsnl:cantilever_link"]) == 0
    assert victim.read_text(encoding="utf-8") == "not yours"
    assert _plain_files(out, links + ["bank.md", "forces_crack3.png"])


def test_a_model_of_equations_is_named_not_a_link_model(tmp_path, capsys):
    from obsnl.cli import main

    # used to say "unknown key 'states'"
    code = main(["bank", "--seeds", "1", "--out", str(tmp_path / "o"), "--model", "obsnl:bouc_wen"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "not a link model" in err and "obsnl:cantilever_link" in err
    assert not (tmp_path / "o").exists()
