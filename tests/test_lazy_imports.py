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


#: What the analysis of a small model and its text rendering need not load: the other rooms' numerics and
#: plotting, and the parts of the analysis and the report that only other models and other commands use (the
#: ORC's Lie derivatives, the representatives of many switching functions, the estimators' branch-table
#: contract, the report folders' writer, the bank's and Table 2's renderers, the spelling suggestions).
NOT_FOR_A_SMALL_ANALYSIS = (
    "scipy", "networkx", "casadi", "matplotlib", "dask", "distributed", "jsonschema", "difflib", "sysconfig",
    "obsnl.estimation", "obsnl.identification", "obsnl.linear", "obsnl.recombination", "obsnl.studies",
    "obsnl.executor", "obsnl.batch", "obsnl.observability.engines.orc", "obsnl.observability.engines.lie",
    "obsnl.model.branching.representatives", "obsnl.observability.contract.branch_table",
    "obsnl.report.files", "obsnl.report.folders", "obsnl.report.bank", "obsnl.report.identification",
)


def test_analysis_of_a_small_model_loads_only_what_it_uses():
    # `obsnl analyze obsnl:bouc_wen --seed 1` in a fresh interpreter (the command line's own path, output
    # captured): 4 branches, 2 switching functions, the series engine decides every one at this seed (no ORC
    # second opinion); the seed is fixed so that the run, and so what it imports, is the same every time
    code = ("import sys, contextlib, io\nfrom obsnl.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()) as buf:\n"
            "    code = main(['analyze', 'obsnl:bouc_wen', '--seed', '1'])\n"
            "print(code, 'jointly identifiable' in buf.getvalue())\n"
            "print(sorted(m for m in sys.modules if any(m == n or m.startswith(n + '.') for n in %r)))\n"
            "print('sympy' in sys.modules, 'numpy' in sys.modules)" % (NOT_FOR_A_SMALL_ANALYSIS,))
    ran, loaded, needed = fresh(code).splitlines()
    assert ran == "0 True"
    assert loaded == "[]"
    assert needed == "True True"  # the check sees what the analysis loads: it does need sympy and numpy


def test_the_parts_left_out_still_load_when_asked_for():
    # the lazy names of the report room, a branch table, a misspelt name's suggestion, a model with many
    # switching functions (representatives), the ORC: each imports its module on first use
    code = ("import sys, obsnl\nfrom obsnl.model.core import Model\nfrom obsnl.report import write_tables, table2_summary\n"
            "from obsnl.report.tables import branch_table\nfrom obsnl.model.branching.structure import branching\n"
            "from obsnl.observability.engines.smooth import orc\n"
            "m = Model(name='m', states=['x'], parameters=['k'], equations={'x': '-k*x'}, outputs={'y': 'x'})\n"
            "r = obsnl.analyze(m, seed=0)\nprint(type(branch_table(r)).__name__, orc(m, seed=1).method)\n"
            "try:\n    Model(name='m', states=['x'], parameters=['kk'], equations={'x': '-k*x'}, outputs={'y': 'x'})\n"
            "except obsnl.ModelError as e:\n    print('kk' in str(e))\n"
            "two = Model(name='two', states=['x', 'y'], parameters=['a', 'b'], equations={'x': '-a*sign(x)', "
            "'y': '-b*sign(y)'}, outputs={'o': 'x + y'})\n"
            "print([b.label for b in branching(two, enumerate_up_to=1).branches])\n"
            "print(sorted(n for n in ('obsnl.report.folders', 'obsnl.report.identification', "
            "'obsnl.observability.contract.branch_table', 'obsnl.observability.engines.orc', "
            "'obsnl.model.branching.representatives', 'difflib') if n in sys.modules))")
    table, misspelt, reps, loaded = fresh(code).splitlines()
    assert table == "BranchTable orc"
    assert misspelt == "True"
    assert reps == "['r0', 'r1', 'r2']"  # as the docstring of branching() derives: 2 switching functions, 3 representatives
    assert loaded == ("['difflib', 'obsnl.model.branching.representatives', 'obsnl.observability.contract.branch_table', "
                      "'obsnl.observability.engines.orc', 'obsnl.report.folders', 'obsnl.report.identification']")
