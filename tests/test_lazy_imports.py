"""``import obsnl`` and ``obsnl --help`` load no numeric library; the names still resolve on first use (issue 25:
start-up kept short by importing less). Each check runs in a fresh interpreter, where ``sys.modules`` is clean."""

from __future__ import annotations

import subprocess
import sys

HEAVY = ("sympy", "casadi", "scipy", "matplotlib", "numpy")


def fresh(code: str) -> str:
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return out.stdout.strip()


def test_import_obsnl_loads_no_numeric_library_until_a_name_is_used():
    code = ("import sys, obsnl; print(sorted(m for m in %r if m in sys.modules)); "
            "obsnl.Model; print('sympy' in sys.modules); print(len(obsnl.__all__), callable(obsnl.analyze))" % (HEAVY,))
    loaded, after, names = fresh(code).splitlines()
    assert loaded == "[]"  # nothing numeric for the bare import
    assert after == "True"  # the model class brings sympy when it is asked for
    count, ok = names.split()
    assert int(count) <= 35 and ok == "True"


def test_help_of_the_command_line_loads_no_numeric_library():
    code = ("import sys, contextlib, io\nfrom obsnl.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()) as buf:\n    code = main(['--help'])\n"
            "print(code, 'analyze' in buf.getvalue(), sorted(m for m in %r if m in sys.modules))" % (HEAVY,))
    assert fresh(code) == "0 True []"


def test_a_result_displays_in_a_notebook_without_importing_the_report_first():
    # the renderers register when the report room loads; the first display loads it by name
    code = ("from obsnl.observability.analyze import analyze\nfrom obsnl.model.core import Model\n"
            "r = analyze(Model(name='m', states=['x'], parameters=['k'], equations={'x': '-k*x'}, "
            "outputs={'y': 'x'}), seed=0)\nprint(r._repr_markdown_().lstrip().startswith(('|', '#', '**')))")
    assert fresh(code) == "True"


def test_a_room_is_reached_as_an_attribute_of_the_bare_import():
    # ``import obsnl; obsnl.report.branch_table(...)`` raised AttributeError unless something had imported
    # obsnl.report before (the test that analyses the model once failed when run alone)
    code = ("import sys, obsnl; print('obsnl.report' in sys.modules); "
            "print(obsnl.report.__name__, callable(obsnl.report.branch_table)); "
            "print(hasattr(obsnl, 'no_such_room'), hasattr(obsnl, '_no_such_module'))")
    before, reached, missing = fresh(code).splitlines()
    assert before == "False"
    assert reached == "obsnl.report True"
    assert missing == "False False"
