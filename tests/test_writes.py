"""Output-folder safety: every command writes only inside the file or folder the user named.

No file is written through a symbolic link, a hard link keeps its content (``--force`` replaces the file, it
never truncates it), a FIFO or socket is refused, names that leave the folder are refused, and a run writes
all of its files or none (``obsnl/report/folders.py``, ``obsnl/report/files.py``). Each test excludes a
behaviour the hostile-input reviews (issues 18 and 26) found; its comment or name says which.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

import numpy as np
import pytest

import obsnl

from .helpers import FAST_STUDY, REC, model_file, one_line_refusal, run


# ----------------------------------------------------------------------------- 1 path traversal
@pytest.mark.parametrize("name", ["../../x", "/tmp/abs", "..", ".hidden", "a/b"])
def test_1_report_refuses_model_names_that_leave_the_folder(tmp_path, capsys, name):
    out = tmp_path / "deep" / "out"
    code, err = run(capsys, "report", str(model_file(tmp_path, name=name)),
                    "--out", str(out), "--force")
    one_line_refusal(code, err, "cannot be a file name")
    assert sorted(p.name for p in tmp_path.rglob("*") if p.is_file()) == ["m.json"]


@pytest.mark.parametrize("name", ["index", "timings", "Index"])
def test_1_report_refuses_a_model_whose_table_would_overwrite_the_index(tmp_path, capsys, name):
    # a model named "index" used to have its table index.md overwritten by the report's index, exit 0
    code, err = run(capsys, "report", str(model_file(tmp_path, name=name)), "--out", str(tmp_path / "out"))
    one_line_refusal(code, err, name, "rename the model")
    assert not (tmp_path / "out").exists()


# ----------------------------------------------------------------------------- 5 symlinks
def test_5_output_symlinks_are_not_followed_without_force(tmp_path, capsys):
    link = tmp_path / "link.md"
    target = tmp_path / "elsewhere" / "created.md"
    link.symlink_to(target)  # dangling
    code, err = run(capsys, "analyze", "obsnl:coulomb_friction", "--format", "md", "-o", str(link))
    one_line_refusal(code, err, "symlink")
    assert not target.exists()
    code, err = run(capsys, "analyze", "obsnl:coulomb_friction", "--format", "md", "-o", str(link), "--force")
    assert code == 0 and not link.is_symlink() and link.is_file() and not target.exists()


def test_5_report_folder_that_is_a_symlink_needs_force(tmp_path, capsys):
    real = tmp_path / "real"
    real.mkdir()
    (tmp_path / "out").symlink_to(real)
    code, err = run(capsys, "report", "obsnl:coulomb_friction", "--out", str(tmp_path / "out"))
    one_line_refusal(code, err, "symlink")
    assert list(real.iterdir()) == []


@pytest.mark.slow
@pytest.mark.parametrize("name", ["identify.json", "fit.png", "traces.png"])
def test_5_identify_never_writes_through_a_link_in_its_folder(tmp_path, capsys, name):
    out = tmp_path / "out"
    out.mkdir()
    target = tmp_path / "elsewhere" / "victim"
    (out / name).symlink_to(target)  # dangling: it used to create the target outside the folder
    code, err = run(capsys, *FAST_STUDY, "--out", str(out))
    one_line_refusal(code, err, "symlink", "--force")
    assert "step/s" not in err and not target.exists()  # refused before the run
    kept = tmp_path / "kept"
    kept.write_text("mine")
    (out / name).unlink()
    (out / name).symlink_to(kept)
    code, err = run(capsys, *FAST_STUDY, "--out", str(out), "--force")  # --force replaces the link itself
    assert code == 0, err
    assert kept.read_text() == "mine" and not (out / name).is_symlink() and (out / name).stat().st_size > 0


def test_5_identify_refuses_a_folder_under_a_file_or_a_linked_folder_before_the_run(tmp_path, capsys):
    (tmp_path / "afile").write_text("x")
    code, err = run(capsys, *FAST_STUDY, "--out", str(tmp_path / "afile" / "sub"))
    one_line_refusal(code, err, "afile", "not a folder")
    assert "step/s" not in err
    real = tmp_path / "real"
    real.mkdir()
    (tmp_path / "lnk").symlink_to(real)
    code, err = run(capsys, *FAST_STUDY, "--out", str(tmp_path / "lnk"))
    one_line_refusal(code, err, "symlink")
    assert list(real.iterdir()) == []


def test_5_figures_replace_a_link_and_keep_its_target(tmp_path):
    from obsnl.report.identification.diagnostics import plot_fit_record

    kept = tmp_path / "kept.png"
    kept.write_bytes(b"mine")
    (tmp_path / "fit.png").symlink_to(kept)
    t = np.linspace(0.0, 1.0, 11)
    plot_fit_record(tmp_path / "fit.png", t=t, measured=t[:, None], simulated=t[:, None], outputs=["y"],
                    fit={"y": 0.0})
    assert kept.read_bytes() == b"mine" and not (tmp_path / "fit.png").is_symlink()
    assert (tmp_path / "fit.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fit.png", "kept.png"]  # no temporary file left


# ----------------------------------------------------------------------------- 11 reproduce overwrites
@pytest.mark.parametrize("existing", ["table2.md", "fig2_1pass.png", "branch_table.json"])
def test_11_reproduce_out_checks_every_file(tmp_path, capsys, existing):
    (tmp_path / existing).write_text("mine")
    code, err = run(capsys, "reproduce", "--out", str(tmp_path), "--seeds", "1", "--samples", "50")
    one_line_refusal(code, err, existing, "--force")
    assert (tmp_path / existing).read_text() == "mine"


# ----------------------------------------------------------------------------- 2 writes outside the named folder
@pytest.fixture(scope="module")
def small_reproduction():
    from obsnl.identification.experiments import DEFAULT_GRID
    from obsnl.studies.seed_paper import reproduce

    return reproduce(seeds=1, tuning_seeds=1, passes=1, grid=DEFAULT_GRID[:1], jit=False, samples=200, replicates=0,
                     refine=False)  # what is written, not the refinement


def _no_reproduce(**kwargs):
    raise AssertionError("the run should have been refused before it started")


def test_2_reproduce_never_writes_through_a_symlinked_default_folder(tmp_path, capsys, monkeypatch):
    import obsnl.studies.seed_paper as seed_paper

    monkeypatch.setattr(seed_paper, "reproduce", _no_reproduce)
    monkeypatch.chdir(tmp_path)
    victim = tmp_path / "victim"
    victim.mkdir()
    (tmp_path / "reports").mkdir()
    (tmp_path / "reports" / "identification").symlink_to(victim)  # it used to receive the six files
    code, err = run(capsys, "reproduce", "--seeds", "1", "--samples", "50")
    one_line_refusal(code, err, "reports/identification", "symlink")
    assert list(victim.iterdir()) == []


@pytest.mark.slow
def test_2_write_reproduction_refuses_a_linked_folder_even_with_force(tmp_path, small_reproduction):
    from obsnl.errors import OutputError
    from obsnl.studies.seed_reproduction import write_reproduction

    victim = tmp_path / "victim"
    victim.mkdir()
    (tmp_path / "out").symlink_to(victim)
    with pytest.raises(OutputError, match="symlink"):
        write_reproduction(small_reproduction, tmp_path / "out", force=True)
    assert list(victim.iterdir()) == []


def test_2_a_record_whose_stem_is_dotdot_cannot_lead_out_of_reports_identification(tmp_path, capsys, monkeypatch):
    import obsnl.studies.seed_paper as seed_paper

    monkeypatch.setattr(seed_paper, "reproduce", _no_reproduce)
    monkeypatch.chdir(tmp_path)
    (tmp_path / "reports" / "identification").mkdir(parents=True)
    (tmp_path / "...csv").write_bytes(REC.read_bytes())  # stem '..': reports/identification/.. is reports/
    code, err = run(capsys, "reproduce", "--record", "...csv", "--seeds", "1", "--samples", "50")
    one_line_refusal(code, err, "'..'", "rename the record file")
    assert sorted(p.name for p in (tmp_path / "reports").iterdir()) == ["identification"]


def test_2_report_force_into_a_linked_folder_does_not_write_into_its_target(tmp_path, capsys):
    real = tmp_path / "real"
    real.mkdir()
    (tmp_path / "out").symlink_to(real)
    code, err = run(capsys, "report", "obsnl:coulomb_friction", "--out", str(tmp_path / "out"), "--force")
    one_line_refusal(code, err, "symlink", "real folder")
    assert list(real.iterdir()) == [] and (tmp_path / "out").is_symlink()


@pytest.mark.parametrize("argv", [("analyze", "obsnl:coulomb_friction", "--format", "md", "-o"),
                                  ("reparametrize", "obsnl:coulomb_friction", "-o")])
def test_2_force_replaces_a_hard_linked_file_instead_of_truncating_it(tmp_path, capsys, argv):
    other = tmp_path / "other.md"
    other.write_text("mine\n")
    target = tmp_path / "out.md"
    os.link(other, target)  # the same file under two names: writing in place changed 'other.md' too
    code, err = run(capsys, *argv, str(target), "--force")
    assert code == 0, err
    assert other.read_text() == "mine\n" and os.stat(other).st_nlink == 1
    assert target.read_text() != "mine\n" and os.stat(target).st_ino != os.stat(other).st_ino
    assert sorted(p.name for p in tmp_path.iterdir()) == ["other.md", "out.md"]  # no temporary left


# ----------------------------------------------------------------------------- 6 no-overwrite is atomic
def _result():
    from obsnl.observability.analyze import analyze

    return analyze(obsnl.read_model("obsnl:coulomb_friction"), seed=0)


def test_6_a_file_another_run_wrote_meanwhile_is_kept_and_nothing_of_ours_lands(tmp_path, monkeypatch):
    from obsnl.errors import OutputError
    from obsnl.report import files, folders

    out = tmp_path / "out"
    real_write = files.OutputFolder.write_text

    def racing(self, name, text):  # the other run finishes its timings.md while this one writes
        real_write(self, name, text)
        if name == "timings.md":
            (out / "timings.md").write_text("the other run\n")

    monkeypatch.setattr(files.OutputFolder, "write_text", racing)
    with pytest.raises(OutputError, match="appeared while this run was writing"):
        folders.write_tables([_result()], out, force=False)
    assert sorted(p.name for p in out.iterdir()) == ["timings.md"]  # no .md/.tex/.json/index of ours, no staging
    assert (out / "timings.md").read_text() == "the other run\n"


def test_6_two_report_runs_into_one_folder_do_not_both_succeed(tmp_path, capsys, monkeypatch):
    import obsnl.batch as batch

    out = tmp_path / "out"
    real_analyze = batch.analyze

    def other_run_finishes_first(*args, **kwargs):
        res = real_analyze(*args, **kwargs)
        out.mkdir(exist_ok=True)
        (out / "index.md").write_text("the other run\n")
        return res

    monkeypatch.setattr(batch, "analyze", other_run_finishes_first)
    code, err = run(capsys, "report", "obsnl:coulomb_friction", "--out", str(out))
    one_line_refusal(code, err, "index.md")
    assert (out / "index.md").read_text() == "the other run\n"


def test_6_two_real_report_processes_into_one_folder_do_not_both_succeed(tmp_path):
    # the probe as run, two processes at once (the test above plants the other run's file instead):
    # both used to succeed, the second replacing the first. Whatever the interleaving, one run wins and the
    # other is refused in one line (at its first claimed file, or up front if the folder is already there).
    import subprocess
    import sys

    argv = [sys.executable, "-m", "obsnl", "report", "obsnl:coulomb_friction", "--out", "r"]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(Path(obsnl.__file__).parents[1]),
                                                          os.environ.get("PYTHONPATH", "")])}
    runs = [subprocess.Popen(argv, cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            for _ in range(2)]
    results = [(p.wait(timeout=300), p.communicate()[1].strip()) for p in runs]
    assert sorted(code for code, _ in results) == [0, 2], results
    (err,) = [e for code, e in results if code == 2]
    assert len(err.splitlines()) == 1 and "Traceback" not in err and "r" in err, err
    assert sorted(q.name for q in (tmp_path / "r").iterdir()) == sorted(
        ["coulomb_friction.md", "coulomb_friction.tex", "coulomb_friction.json", "index.md", "timings.md"])


def test_6_an_error_while_writing_leaves_no_file_no_staging_and_no_new_folder(tmp_path):
    from obsnl.report.files import OutputFolder

    out = tmp_path / "new" / "out"
    with pytest.raises(RuntimeError, match="drawing failed"):
        with OutputFolder(out, ["a.md", "b.png"], force=False) as folder:
            folder.write_text("a.md", "A")
            (folder.staging / "b.png").write_bytes(b"half")
            raise RuntimeError("drawing failed")
    assert list(tmp_path.iterdir()) == []
    with OutputFolder(out, ["a.md", "b.png"], force=False) as folder:  # the rerun needs no --force
        folder.write_text("a.md", "A")
        (folder.staging / "b.png").write_bytes(b"png")
        (folder.staging / "scratch.tmp").write_bytes(b"x")  # not one of the files: dropped
        folder.commit()
    assert sorted(p.name for p in out.iterdir()) == ["a.md", "b.png"]


@pytest.mark.slow
def test_6_a_full_disk_leaves_nothing_that_blocks_the_rerun(tmp_path):
    import resource
    import signal
    import subprocess
    import sys

    def small_files() -> None:  # every file above 1500 bytes fails to write, as on a full disk
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (1500, 1500))

    argv = [sys.executable, "-m", "obsnl", "report", "obsnl:coulomb_friction", "--out", "r"]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(Path(obsnl.__file__).parents[1]),
                                                          os.environ.get("PYTHONPATH", "")])}
    p = subprocess.run(argv, cwd=tmp_path, preexec_fn=small_files, capture_output=True, text=True, env=env)
    assert p.returncode == 2 and "Traceback" not in p.stderr and "nothing was written" in p.stderr, p.stderr
    assert not (tmp_path / "r").exists()  # it used to keep the .md and .tex written before the .json failed
    p = subprocess.run(argv, cwd=tmp_path, capture_output=True, text=True, env=env)  # the rerun needs no --force
    assert p.returncode == 0, p.stderr
    assert sorted(q.name for q in (tmp_path / "r").iterdir()) == sorted(
        ["coulomb_friction.md", "coulomb_friction.tex", "coulomb_friction.json", "index.md", "timings.md"])


# ----------------------------------------------------------------------------- 7 only regular files are written
#: Each command that writes one file the user names, as argv up to (and with) that file's option.
ONE_FILE = {"reparametrize": ("reparametrize", "obsnl:coulomb_friction", "-o"),
            "analyze": ("analyze", "obsnl:coulomb_friction", "--format", "md", "-o"),
            "sensors": ("sensors", "obsnl:coulomb_friction", "-o"),
            "design": ("design", "obsnl:coulomb_friction", "--record", str(REC), "--scales", "1", "--figure")}


def _fifo(path: Path) -> Path:
    os.mkfifo(path)  # only ever inside pytest's tmp_path
    return path


@pytest.mark.parametrize("force", [(), ("--force",)], ids=["", "force"])
@pytest.mark.parametrize("command", ONE_FILE)
def test_7_a_fifo_is_never_replaced_by_a_file_not_even_with_force(tmp_path, capsys, command, force):
    fifo = _fifo(tmp_path / ("P.png" if command == "design" else "P"))
    code, err = run(capsys, *ONE_FILE[command], str(fifo), *force)  # --force used to turn it into a regular file
    one_line_refusal(code, err, str(fifo), "is a FIFO, not a regular file", "choose another path")
    assert len(err.splitlines()) == 1 and "pass --force" not in err  # no invitation to force it
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert [p.name for p in tmp_path.iterdir()] == [fifo.name]  # no temporary, no staging folder left


@pytest.mark.parametrize("force", [(), ("--force",)], ids=["", "force"])
def test_7_a_fifo_in_an_out_folder_is_refused_before_any_file_is_written(tmp_path, capsys, force):
    out = tmp_path / "out"
    out.mkdir()
    fifo = _fifo(out / "index.md")
    code, err = run(capsys, "report", "obsnl:coulomb_friction", "--out", str(out), *force)
    one_line_refusal(code, err, "index.md", "is a FIFO", "choose another path")
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode) and [p.name for p in out.iterdir()] == ["index.md"]


def test_7_a_socket_is_refused_with_force_and_named_as_such(tmp_path, capsys, monkeypatch):
    import socket

    monkeypatch.chdir(tmp_path)  # a short relative name: a socket's path is limited to about 100 bytes
    with socket.socket(socket.AF_UNIX) as sock:
        sock.bind("S")
        code, err = run(capsys, "reparametrize", "obsnl:coulomb_friction", "-o", "S", "--force")
        one_line_refusal(code, err, "S is a socket, not a regular file")
        assert stat.S_ISSOCK(os.lstat("S").st_mode)


def test_7_a_fifo_that_appears_while_the_run_writes_is_refused_before_any_file_is_moved(tmp_path):
    from obsnl.errors import OutputError
    from obsnl.report.files import OutputFolder

    out = tmp_path / "out"
    with pytest.raises(OutputError, match=r"b\.md is a FIFO"):
        with OutputFolder(out, ["a.md", "b.md"], force=True) as folder:
            folder.write_text("a.md", "A")
            folder.write_text("b.md", "B")
            _fifo(out / "b.md")  # another process, after the check
            folder.commit()
    assert [p.name for p in out.iterdir()] == ["b.md"] and stat.S_ISFIFO(os.lstat(out / "b.md").st_mode)


def test_7_the_figure_writer_refuses_a_fifo_and_a_name_that_names_a_folder(tmp_path):
    import numpy as np

    from obsnl.errors import OutputError
    from obsnl.report.figures import figure2

    t = np.linspace(0.0, 1.0, 5)
    draw = dict(t=t, accel=t, y_measured=t, estimates={"ukf": t})
    fifo = _fifo(tmp_path / "f.png")
    with pytest.raises(OutputError, match="is a FIFO"):
        figure2(fifo, **draw)
    with pytest.raises(OutputError, match="ends with '/'"):
        figure2(f"{tmp_path / 'g.png'}/", **draw)
    assert [p.name for p in tmp_path.iterdir()] == ["f.png"] and stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert figure2(tmp_path / "link.png", **draw).is_file()  # a plain file is still written


@pytest.mark.parametrize("command", ONE_FILE)
@pytest.mark.parametrize("ending", ["/", "/."])
def test_7_a_file_name_that_ends_with_a_slash_is_refused_not_written_without_it(tmp_path, capsys, command, ending):
    name = str(tmp_path / ("new.png" if command == "design" else "new.toml")) + ending
    code, err = run(capsys, *ONE_FILE[command], name, "--force")  # it used to write new.toml
    one_line_refusal(code, err, f"ends with {ending!r}", "names a folder, but a file is due",
                     "drop the slash" if ending == "/" else "name a file")
    assert len(err.splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


def test_7_safe_write_refuses_a_trailing_slash_and_still_replaces_a_symlink_with_force(tmp_path):
    from obsnl.errors import OutputError
    from obsnl.report.files import safe_write

    with pytest.raises(OutputError, match="drop the slash"):
        safe_write(f"{tmp_path / 'x.md'}/", "x", force=True)
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "link").symlink_to(tmp_path / "target")  # a link keeps its treatment: replaced, never followed
    safe_write(tmp_path / "link", "x\n", force=True)
    assert not (tmp_path / "link").is_symlink() and not (tmp_path / "target").exists()
