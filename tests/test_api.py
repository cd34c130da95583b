"""The public API: every exported name resolves, and the package imports fast (numeric modules lazily)."""

from __future__ import annotations

import subprocess
import sys

import obsnl


def test_every_exported_name_resolves():
    for name in obsnl.__all__:
        assert getattr(obsnl, name) is not None, name
    assert len(set(obsnl.__all__)) == len(obsnl.__all__)


def test_import_does_not_load_the_numeric_stack():
    code = "import sys, obsnl; print(sorted(m for m in ('casadi', 'matplotlib', 'scipy.signal') if m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120).stdout.strip()
    assert out == "[]"


HEAVY = ('casadi', 'matplotlib', 'scipy', 'networkx', 'jsonschema', 'tqdm', 'dask', 'distributed')


def test_import_and_analyze_command_load_only_what_they_need():
    # `import obsnl` and `obsnl analyze` of a small model need sympy, numpy and flint only
    code = ("import sys, io, contextlib, obsnl.cli\n"
            "before = sorted(m for m in %r if m in sys.modules)\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n"
            "    try:\n"
            "        obsnl.cli.main(['analyze', 'obsnl:coulomb_friction'])\n"
            "    except SystemExit:\n"
            "        pass\n"
            "print(before, sorted(m for m in %r if m in sys.modules))" % (HEAVY, HEAVY))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.stdout.strip() == "[] []", out.stderr


def test_analyze_takes_a_model_file_as_identify_does(tmp_path):
    # obsnl.analyze("file.toml") was refused ("expected an obsnl Model, got str") although identify takes a path
    from pathlib import Path

    res = obsnl.analyze("obsnl:coulomb_friction", seed=0)
    path = Path(obsnl.__file__).resolve().parents[1] / "models" / "coulomb_friction.toml"
    assert obsnl.analyze(path, seed=0).overall_unobservable == res.overall_unobservable
    assert obsnl.analyze(str(path), seed=0).joint.unobservable == res.joint.unobservable


def test_every_error_class_is_exported_at_the_top():
    import inspect

    import obsnl.errors as errors

    classes = {n for n, c in vars(errors).items() if inspect.isclass(c) and issubclass(c, errors.ObsnlError)}
    assert classes <= set(obsnl.__all__), classes - set(obsnl.__all__)
    assert all(getattr(obsnl, n) is getattr(errors, n) for n in classes)
