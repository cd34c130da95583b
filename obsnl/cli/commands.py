"""One function per subcommand: the parsed options to one library call, its rendering printed."""

from __future__ import annotations

import sys
from argparse import Namespace
from typing import Any

from obsnl.cli.common import _write
from obsnl.errors import AnalysisError, OptionError

#: Parsed values that are not the library's: the command, its function, the rendering's format, the executor's parts.
_OWN = {"command", "func", "format", "workers", "scheduler"}


def _opts(a: Namespace, *drop: str) -> dict[str, Any]:
    """The command's options as the library's keyword arguments (an option's ``dest`` is its keyword), the
    executor built from ``--workers``/``--scheduler`` (a dead scheduler refused before any work)."""
    opts = {k: v for k, v in vars(a).items() if k not in _OWN.union(drop)}
    if "workers" in vars(a):
        from obsnl.executor import Executor
        opts["executor"] = Executor(scheduler=a.scheduler, workers=a.workers).probe()
    return opts


def _load(path: str, limits: bool = True) -> Any:
    from obsnl.model.files import read_model
    from obsnl.observability.limits import check_file_limits
    return read_model(path, check=check_file_limits if limits else None)  # the size checked before parsing


def _show(text: str, a: Namespace | None = None, stuck: str | None = None) -> None:
    """``text`` printed (or written to ``-o``); then ``stuck``, an undecided answer, is said, never passed over."""
    _write(text, getattr(a, "output", None), force=getattr(a, "force", False))
    if stuck:
        raise AnalysisError(stuck)


def show(a: Namespace) -> None:
    from obsnl.report.structure import render_model
    _show(render_model(_load(a.model, False), a.format))


def branches(a: Namespace) -> None:
    from obsnl.model.branching.branches import split_branches
    from obsnl.report.structure import render_branches
    model = _load(a.model, False)
    _show(render_branches(model, split_branches(model, undecided=True), a.format, equations=a.equations))


def analyze(a: Namespace) -> None:
    from obsnl.design.records import analyze_file
    from obsnl.report.structure import inconclusive_line
    from obsnl.report.tables import render
    result = analyze_file(**{**_opts(a), "branches": a.branches or None})
    _show(render(result, a.format), a, inconclusive_line([result]))


def report(a: Namespace) -> None:
    from obsnl.batch import report_paths
    from obsnl.report.structure import inconclusive_line
    results = report_paths(a.models, **_opts(a, "models"))
    _show(f"wrote {len(results)} table(s) with index.md and timings.md to {a.out}", None,
          inconclusive_line(results, named=True))


def symmetries(a: Namespace) -> None:
    from obsnl.observability.certificates.symmetry import branch_symmetries
    from obsnl.report.structure import render_symmetries
    _show(render_symmetries(branch_symmetries(_load(a.model), seed=a.seed, degree=a.degree), a.format))


def reparametrize(a: Namespace) -> None:
    from obsnl.report.structure import reparametrization_lines
    from obsnl.studies.jobs import reparametrize_job
    r = reparametrize_job(**_opts(a))
    _show(r.to_toml() if a.output in (None, "-") else reparametrization_lines(r, a.output))


def identify(a: Namespace) -> None:
    from obsnl.report.identification import identify_text
    from obsnl.studies.jobs import identify_job
    if (a.workers is not None or a.scheduler) and a.replicates == 0 and not a.refine:  # ignored: refused, not dropped
        raise OptionError("--workers/--scheduler applies to the profile likelihoods and the Monte-Carlo replicates: "
                          "drop --no-refine or add --replicates N (nothing else of identify runs in parallel)")
    res, files = identify_job(progress=True, **_opts(a))
    _show(identify_text(res))
    if files:
        _show(f"wrote {', '.join(str(f) for f in files)}")


def reproduce(a: Namespace) -> None:
    from obsnl.studies.jobs import reproduce_job
    out, files = reproduce_job(**_opts(a), regenerating=lambda folder: print(
        f"obsnl reproduce: regenerating the default folder {folder} (committed results); pass --out DIR or "
        "--quick to keep them", file=sys.stderr))
    _show(f"wrote {len(files)} files to {out}: " + ", ".join(f.name for f in files))


def bank(a: Namespace) -> None:
    from obsnl.studies.jobs import bank_job
    files = bank_job(**_opts(a))
    _show(f"wrote {', '.join(str(f) for f in files[:2])} and {len(files) - 2} force plots")


def sensors(a: Namespace) -> None:
    from obsnl.design.records import sensors_file
    from obsnl.report.sensors import render_sensors, undecided_line
    result = sensors_file(**_opts(a))
    _show(render_sensors(result, a.format), a, undecided_line(result))


def design(a: Namespace) -> None:
    from obsnl.design.records import design_file
    from obsnl.report.experiment import render_design
    result = design_file(a.model, a.record, **_opts(a, "model", "record"))
    _show(render_design(result, a.format), a, f"inconclusive: {result.reason}" if result.status == "inconclusive"
          else None)
