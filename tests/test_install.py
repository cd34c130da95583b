"""A non-editable install finds the catalogue: ``pip install .`` into a fresh virtual environment, then
``obsnl analyze obsnl:bouc_wen`` from another folder reads the installed copy of ``models/`` (not the
checkout), and the checkout holds the catalogue in its top-level ``models/`` folder, once."""

from __future__ import annotations

import os
import json
import subprocess
import sys
import venv
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_the_catalogue_lives_once_in_the_top_level_models_folder():
    models = sorted(p.name for p in (ROOT / "models").glob("*.toml"))
    assert {"bouc_wen.toml", "damage_healing.toml", "damage_healing_reparam.toml"} <= set(models)
    copies = [p for p in ROOT.rglob("bouc_wen.toml")
              if ".git" not in p.parts and "build" not in p.parts and not any(x.endswith(".egg-info") for x in p.parts)]
    assert copies == [ROOT / "models" / "bouc_wen.toml"]


@pytest.mark.slow
def test_pip_install_into_a_fresh_venv_reads_the_installed_catalogue(tmp_path):
    env_dir = tmp_path / "venv"
    # the dependencies come from this interpreter's site-packages; obsnl itself is built and installed afresh
    venv.EnvBuilder(system_site_packages=True, with_pip=True).create(env_dir)
    py = env_dir / ("Scripts" if os.name == "nt" else "bin") / "python"
    # the wheel is built as `pip install .` builds it (an isolated build environment), then installed in the venv
    wheels = tmp_path / "wheels"
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps",
                            "-w", str(wheels), str(ROOT)], capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert build.returncode == 0, build.stderr[-2000:]
    (wheel,) = wheels.glob("obsnl-*.whl")
    install = subprocess.run([str(py), "-m", "pip", "install", "-q", "--no-deps", str(wheel)],
                             capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert install.returncode == 0, install.stderr[-2000:]
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    probe = subprocess.run([str(py), "-c", "import obsnl, obsnl.model.files as f; print(obsnl.__file__); "
                            "print(f.catalogue_path('bouc_wen'))"],
                           capture_output=True, text=True, timeout=120, cwd=elsewhere, env=env)
    assert probe.returncode == 0, probe.stderr[-2000:]
    module, model = (Path(x) for x in probe.stdout.split())
    assert env_dir in module.parents, "the venv's own obsnl is imported, not the checkout's"
    assert env_dir in model.parents and ROOT not in model.parents
    run = subprocess.run([str(py), "-m", "obsnl", "analyze", "obsnl:bouc_wen", "--format", "json"],
                         capture_output=True, text=True, timeout=300, cwd=elsewhere, env=env)
    assert run.returncode == 0, run.stderr[-2000:]
    doc = json.loads(run.stdout)
    assert doc["model"] == "bouc_wen" and doc["overall"]
