"""Line coverage of the package by the whole test suite, written as a Markdown report.

Plain script (no pytest of its own; it runs the suite once, about as long as ``python -m pytest``):

    python benchmarks/coverage.py [--out reports/coverage.md] [-- extra pytest arguments]

It runs ``python -m pytest --cov=obsnl --cov-report=term-missing`` (the README's test command with pytest-cov, from
the ``test`` extra; the project's addopts apply, so the doctests of ``obsnl/`` count and two worker processes run
the tests) and writes the total line coverage, the coverage of each subpackage and the 15 least-covered modules.
Processes the tests start (``python -m obsnl ...``, local executor workers) are measured too (coverage's
``patch = subprocess``). Line coverage only: a line counts as covered when any test ran it, whatever the test
asserted. Arguments after ``--`` go to pytest (``-- -m "not slow"`` measures the quick tests only).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import textwrap
import time
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LEAST = 15
#: The total the report compares with; below it the report names the modules that pull the total down.
TARGET = 90.0

#: Coverage's settings for the run: the data files of every process in one folder, combined at the end.
COVERAGE_RC = """\
[run]
source = obsnl
patch = subprocess
parallel = true
data_file = {data_file}
"""


def _suite(pytest_args: list[str], json_path: Path) -> tuple[int, float, str, list[str]]:
    """Run the suite under coverage; its exit code, wall time in seconds, pytest's summary line and the tests that
    failed."""
    with tempfile.TemporaryDirectory() as tmp:
        rc = Path(tmp) / "coveragerc"
        rc.write_text(COVERAGE_RC.format(data_file=Path(tmp) / ".coverage"), encoding="utf-8")
        env = dict(os.environ, COVERAGE_RCFILE=str(rc))
        cmd = [
            sys.executable,
            "-m",
            "pytest",
            "--cov=obsnl",
            f"--cov-config={rc}",
            "--cov-report=term-missing",
            f"--cov-report=json:{json_path}",
            *pytest_args,
        ]
        t0 = time.perf_counter()
        out: list[str] = []
        with subprocess.Popen(
            cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
        ) as proc:
            assert proc.stdout is not None
            for line in proc.stdout:  # pytest's progress as it comes
                sys.stdout.write(line)
                sys.stdout.flush()
                out.append(line.rstrip("\n"))
        took = time.perf_counter() - t0
    lines = [ln for ln in out if ln.startswith("=") and any(w in ln for w in (" passed", " failed", " error"))]
    failed = [ln.split()[1] for ln in out if ln.startswith(("FAILED ", "ERROR ")) and len(ln.split()) > 1]
    return proc.returncode, took, lines[-1].strip("= ") if lines else "(no summary line)", failed


def _group(path: str) -> str:
    """The subpackage of a module path (``obsnl/model/bounds/work.py`` -> ``obsnl.model``)."""
    parts = Path(path).parts
    return "obsnl (top-level modules)" if len(parts) == 2 else f"obsnl.{parts[1]}"


def _pct(covered: int, statements: int) -> float:
    return 100.0 * covered / statements if statements else 100.0


def _row(path: str, s: dict) -> str:
    """A table row of one module: statements, not run, coverage."""
    pct = _pct(s["covered_lines"], s["num_statements"])
    return f"| `{path}` | {s['num_statements']} | {s['missing_lines']} | {pct:.1f} % |"


def render(
    data: dict, *, took: float, summary: str, code: int, pytest_args: list[str], failed: list[str] | None = None
) -> str:
    """The Markdown report of a coverage JSON report (coverage.py's ``json`` format)."""
    files = {p: f["summary"] for p, f in data["files"].items()}
    tot = data["totals"]
    total = _pct(tot["covered_lines"], tot["num_statements"])
    groups: dict[str, list[int]] = defaultdict(lambda: [0, 0, 0])
    for p, s in files.items():
        g = groups[_group(p)]
        g[0] += 1
        g[1] += s["num_statements"]
        g[2] += s["covered_lines"]
    commit = (
        subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
        or "unknown"
    )
    args = " ".join(pytest_args)
    out = [
        "# Test coverage of the package",
        "",
        f"Line coverage of `obsnl/` by the whole suite, measured by `python benchmarks/coverage.py` (pytest with "
        f"`--cov=obsnl --cov-report=term-missing`{', extra arguments `' + args + '`' if args else ''}) at commit "
        f"{commit}, Python {platform.python_version()}. The doctests of `obsnl/` count (pytest runs them); processes "
        "the tests start (`python -m obsnl ...`, local workers) are measured too. A line counts as covered when any "
        "test ran it: coverage says what no test runs, not what the tests check.",
        "",
        f"The run: {summary} ({took / 60:.1f} min of wall time with the coverage reports; 2 worker processes on a "
        f"machine of 2 cores shared with other jobs){'' if code == 0 else f'; pytest exited with code {code}'}.",
        *(
            [
                "",
                "Failed in this run (under coverage: a test that fails here and passes without coverage measures "
                "something coverage changes, such as the modules a fresh interpreter imports): "
                + ", ".join(f"`{t}`" for t in failed)
                + ".",
            ]
            if failed
            else []
        ),
        "",
        "## Total",
        "",
        f"**{total:.1f} %** of {tot['num_statements']} statements ({tot['missing_lines']} not run) in "
        f"{len(files)} modules.",
        "",
    ]
    if total < TARGET:
        by_missed = sorted(files.items(), key=lambda kv: -kv[1]["missing_lines"])[:10]
        need = math.ceil(TARGET / 100 * tot["num_statements"]) - tot["covered_lines"]
        out += [
            f"That is {TARGET - total:.1f} percentage points under {TARGET:.0f} % ({need} more statements would have "
            "to run). The modules with the most statements no test runs, which pull the total down most:",
            "",
            "| Module | Statements | Not run | Coverage |",
            "|--------|-----------:|--------:|---------:|",
            *(_row(p, s) for p, s in by_missed),
            "",
        ]
    out += [
        "## Per subpackage",
        "",
        "| Subpackage | Modules | Statements | Not run | Coverage |",
        "|------------|--------:|-----------:|--------:|---------:|",
        *(f"| `{g}` | {n} | {st} | {st - cov} | {_pct(cov, st):.1f} % |" for g, (n, st, cov) in sorted(groups.items())),
        "",
        f"## The {LEAST} least-covered modules",
        "",
        "| Module | Statements | Not run | Coverage |",
        "|--------|-----------:|--------:|---------:|",
    ]
    least = sorted(
        files.items(), key=lambda kv: (_pct(kv[1]["covered_lines"], kv[1]["num_statements"]), -kv[1]["missing_lines"])
    )[:LEAST]
    out += [_row(p, s) for p, s in least]
    out.append("")
    # prose within 118 characters a line; table rows stay whole
    return "\n".join(ln if ln.startswith("|") else textwrap.fill(ln, 118, break_on_hyphens=False) for ln in out)


def main() -> None:
    argv = sys.argv[1:]
    extra = argv[argv.index("--") + 1 :] if "--" in argv else []
    own = argv[: argv.index("--")] if "--" in argv else argv
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "reports" / "coverage.md"))
    args = ap.parse_args(own)
    with tempfile.TemporaryDirectory() as tmp:
        json_path = Path(tmp) / "coverage.json"
        code, took, summary, failed = _suite(extra, json_path)
        if not json_path.exists() or " passed" not in summary:
            sys.exit(
                f"coverage.py: error: the suite did not run (pytest exit code {code}: {summary}); no report written"
            )
        data = json.loads(json_path.read_text(encoding="utf-8"))
    text = render(data, took=took, summary=summary, code=code, pytest_args=extra, failed=failed)
    Path(args.out).write_text(text, encoding="utf-8")
    print(f"wrote {args.out}: total {data['totals']['percent_covered']:.1f} %")


if __name__ == "__main__":
    main()
