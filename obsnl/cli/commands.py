"""One function per subcommand: the parsed options to one library call, its rendering printed."""

from __future__ import annotations

import sys
from argparse import Namespace
from typing import Any

from obsnl.cli.common import _Exit, _write


def _split(text: str | None) -> list[str]:
    return [x.strip() for x in (text or "").split(",") if x.strip()]


def _load(path: str, limits: bool = True) -> Any:
    from obsnl.model.files import read_model
    from obsnl.observability.limits import check_file_limits
    return read_model(path, check=check_file_limits if limits else None)  # the size checked before parsing


def _target(path: str | None, force: bool) -> None:
    from obsnl.report.files import check_target
    if path and path != "-":  # an output file that cannot be written is refused before any work
        check_target(path, force=force)


def _executor(a: Namespace) -> Any:
    from obsnl.executor import Executor
    return Executor(scheduler=a.scheduler, workers=a.workers).probe()  # a dead scheduler refused before any work


def _stuck(line: str | None) -> None:
    if line:  # written, and said: an undecided answer is never passed over in silence
        raise _Exit(2, line)


def show(a: Namespace) -> None:
    from obsnl.report.structure import render_model
    _write(render_model(_load(a.model, False), a.format))


def branches(a: Namespace) -> None:
    from obsnl.model.branching.branches import split_branches
    from obsnl.report.structure import render_branches
    model = _load(a.model, False)
    _write(render_branches(model, split_branches(model, undecided=True), a.format, equations=a.equations))


def analyze(a: Namespace) -> None:
    from obsnl.design.records import analyze_file
    from obsnl.report.structure import inconclusive_line
    from obsnl.report.tables import render
    _target(a.output, a.force)
    result = analyze_file(a.model, record=a.record, method=a.method, seed=a.seed, max_seconds=a.max_seconds,
                          branches=_split(a.branches) or None, joint=not a.no_joint,
                          unknown_input_derivatives=a.unknown_input_derivatives)
    _write(render(result, a.format), a.output, force=a.force)
    _stuck(inconclusive_line([result]))


def report(a: Namespace) -> None:
    from obsnl.batch import report_paths
    from obsnl.report.structure import inconclusive_line
    results = report_paths(a.models, a.out, method=a.method, seed=a.seed, force=a.force, max_seconds=a.max_seconds,
                           executor=_executor(a))
    print(f"wrote {len(results)} table(s) with index.md and timings.md to {a.out}")
    _stuck(inconclusive_line(results, named=True))


def symmetries(a: Namespace) -> None:
    from obsnl.observability.certificates.symmetry import branch_symmetries
    from obsnl.report.structure import render_symmetries
    _write(render_symmetries(branch_symmetries(_load(a.model), seed=a.seed, degree=a.degree), a.format))


def reparametrize(a: Namespace) -> None:
    from obsnl.recombination.reparametrize import reparametrize
    from obsnl.report.structure import reparametrization_lines
    if bad := [n for n in a.name if n.count("=") != 1 or not all(n.split("="))]:
        raise _Exit(2, f"--name takes OLD=NEW, got {bad[0]!r}")
    names = {old.strip(): new.strip() for old, new in (n.split("=") for n in a.name)}
    r = reparametrize(_load(a.model), keep=_split(a.keep), eliminate=_split(a.eliminate), names=names, seed=a.seed)
    _write(r.to_toml(), a.output, force=a.force)
    if a.output not in (None, "-"):
        print(reparametrization_lines(r, a.output))


def identify(a: Namespace) -> None:
    from obsnl.report.identification import identify_text
    from obsnl.studies.jobs import identify_job, tuning_from
    if (a.workers is not None or a.scheduler) and a.replicates == 0 and a.no_refine:  # ignored: refused, not dropped
        raise _Exit(2, "--workers/--scheduler applies to the profile likelihoods and the Monte-Carlo replicates: "
                    "drop --no-refine or add --replicates N (nothing else of identify runs in parallel)")
    res, files = identify_job(
        a.model, data=a.data, record=a.record, guess=a.guess, noise=a.noise, samples=a.samples, out=a.out,
        force=a.force, tuning=tuning_from(a.s0, a.q_theta, a.q_x, a.gate), method=a.method, table=a.table,
        passes=a.passes, replicates=a.replicates, seed=a.seed, allow_unidentifiable=a.allow_unidentifiable,
        jit=a.jit, hold=a.hold, refine=not a.no_refine, progress=True, executor=_executor(a))
    _write(identify_text(res))
    if files:
        print(f"wrote {', '.join(str(f) for f in files)}")


def reproduce(a: Namespace) -> None:
    from obsnl.studies.jobs import reproduce_job
    out, files = reproduce_job(
        out=a.out, record=a.record, quick=a.quick, force=a.force, executor=_executor(a), seeds=a.seeds,
        tuning_seeds=a.tuning_seeds, passes=a.passes, samples=a.samples, replicates=a.replicates,
        jit=False if a.no_jit else None, regenerating=lambda folder: print(
            f"obsnl reproduce: regenerating the default folder {folder} (committed results); pass --out DIR or "
            "--quick to keep them", file=sys.stderr))
    print(f"wrote {len(files)} files to {out}: " + ", ".join(f.name for f in files))


def bank(a: Namespace) -> None:
    from obsnl.studies.jobs import bank_job
    files = bank_job(out=a.out, model=a.model, seeds=a.seeds, force=a.force)
    print(f"wrote {', '.join(str(f) for f in files[:2])} and {len(files) - 2} force plots")


def sensors(a: Namespace) -> None:
    from obsnl.design.records import sensors_file
    from obsnl.report.sensors import render_sensors
    _target(a.output, a.force)
    result = sensors_file(a.model, record=a.record, rank_size=a.rank_size, noise=a.noise,
                          target=a.target, max_size=a.max_size, seed=a.seed, max_seconds=a.max_seconds,
                          executor=_executor(a), progress=a.progress)
    _write(render_sensors(result, a.format), a.output, force=a.force)
    if undecided := result.undecided_sets:
        first = result.answer(undecided[0])
        _stuck(f"{len(undecided)} sensor set(s) undecided, e.g. {{{', '.join(first.sensors)}}}: "
               f"{first.reason or 'minimality undecided'}; raise --max-seconds")


def design(a: Namespace) -> None:
    from obsnl.design.records import design_file
    from obsnl.report.experiment import render_design
    _target(a.output, a.force)
    result = design_file(a.model, a.record, target=a.target, sensors=a.sensors, scales=a.scales, seed=a.seed,
                         max_seconds=a.max_seconds, figure=a.figure, output=a.output, force=a.force)
    _write(render_design(result, a.format), a.output, force=a.force)
    _stuck(f"inconclusive: {result.reason}" if result.status == "inconclusive" else None)
