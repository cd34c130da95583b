"""The ``obsnl`` command line: thin argparse dispatch onto the public API.

Exit codes: 0 success, 2 bad input (one line on stderr, no traceback), 1 an internal error.
Each subcommand is one ``_cmd_*`` function plus its ``_add_*`` parser builder.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from obsnl.errors import ObsnlError

__all__ = ["main"]


class _Exit(Exception):
    def __init__(self, code: int, message: str = "") -> None:
        super().__init__(message)
        self.code = code
        self.message = message


def _seed(text: str) -> int:
    """``--seed``: a non-negative integer (numpy's generators refuse negative seeds)."""
    value = int(text) if text.lstrip("-").isdigit() else None
    if value is None or value < 0:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer >= 0")
    return value


def _load(path: str):
    from obsnl.model.files import load_model

    return load_model(path)


def write_output(text: str, out: str | None, *, force: bool) -> None:
    """Print ``text`` or write it to ``out``; never overwrite an existing file without ``force``."""
    from obsnl.report.files import safe_write

    text = text if text.endswith("\n") else text + "\n"
    if out is None or out == "-":
        sys.stdout.write(text.encode("utf-8", "backslashreplace").decode("utf-8"))
        return
    safe_write(out, text, force=force)  # refuses symlinks, folders, a parent that is a file


# --------------------------------------------------------------------------- show
def _add_show(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("show", help="print a model's equations", description="Print a model's equations and roles.")
    p.add_argument("model", help="model file (.toml or .json)")
    p.add_argument("--format", choices=("text", "json"), default="text", help="output format (default: text)")
    p.set_defaults(func=_cmd_show)


def _cmd_show(args: argparse.Namespace) -> int:
    model = _load(args.model)
    if args.format == "json":
        write_output(json.dumps(model.to_dict(), indent=2), None, force=False)
        return 0
    lines = [str(model)]
    for role in ("parameters", "inputs", "unknown_inputs", "known_constants"):
        syms = getattr(model, role)
        if syms:
            lines.append(f"  {role.replace('_', ' ')}: {', '.join(s.name for s in syms)}")
    if model.source:
        lines.append(f"  source: {model.source}")
    write_output("\n".join(lines), None, force=False)
    return 0


# --------------------------------------------------------------------------- branches
def _add_branches(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "branches",
        help="list the smooth branches of a non-smooth model",
        description="Split a model at its switching functions and list each branch's label and guard.",
    )
    p.add_argument("model", help="model file (.toml or .json)")
    p.add_argument("--format", choices=("text", "json"), default="text", help="output format (default: text)")
    p.add_argument("--equations", action="store_true", help="also print each branch's smooth equations (text format)")
    p.set_defaults(func=_cmd_branches)


def _cmd_branches(args: argparse.Namespace) -> int:
    from obsnl.model.branches import split_branches

    model = _load(args.model)
    branches = split_branches(model)
    if args.format == "json":
        doc = {"model": model.name, "branches": [{"label": b.label, "guard": b.guard_text} for b in branches]}
        write_output(json.dumps(doc, indent=2), None, force=False)
        return 0
    lines = [f"{model.name}: {len(branches)} branch{'es' if len(branches) != 1 else ''}"]
    for b in branches:
        lines.append(f"  ({b.label}) {b.guard_text}")
        if args.equations:
            for s in b.model.states:
                lines.append(f"      d/dt {s} = {b.model.equations[s]}")
    write_output("\n".join(lines), None, force=False)
    return 0


# --------------------------------------------------------------------------- more commands
# (one _add_*/_cmd_* pair per subcommand, listed in _BUILDERS above build_parser)


# --------------------------------------------------------------------------- analyze
def _add_analyze(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "analyze",
        help="observability/identifiability of every branch of a model",
        description="Split the model into smooth branches and test each with the ORC or Sedoglavic's randomized "
        "test. Exit code 2 when a branch is inconclusive (time limit, disagreeing points): the result is still "
        "printed (undecided variables are in neither list) and the reason goes to stderr.",
    )
    p.add_argument("model", help="model file (.toml, or .json such as a peer case)")
    p.add_argument("--format", choices=("text", "json", "md", "tex", "json-table"), default="text",
                   help="text (default); json: the analysis; md/tex: branch tables for documents; json-table: the "
                   "branch table read by the DUKF (schema obsnl.branch-table/1)")
    p.add_argument("--method", choices=("auto", "orc", "sedoglavic"), default="auto",
                   help="observability engine (default: auto)")
    p.add_argument("--seed", type=_seed, default=None, help="seed of the random choices (default: drawn and reported)")
    p.add_argument("--max-seconds", type=float, default=None, help="time limit of the whole analysis")
    p.add_argument("--branches", default=None, metavar="LABELS",
                   help="visit only these branches (comma-separated labels, e.g. a,c); default: every feasible branch")
    p.add_argument("--record", default=None, metavar="FILE",
                   help="simulate the model's [values] under this record (.csv or .AT2; it drives the model's one "
                   "input) and analyse the branches and crossings it visits: what this experiment reveals")
    p.add_argument("--no-joint", action="store_true", help="skip the joint verdict (per-branch results and union only)")
    p.add_argument("--unknown-input-derivatives", default=None, metavar="K|arbitrary",
                   help="what the unknown inputs are: 'arbitrary' (any function of time) or K, polynomials in t "
                   "with K non-zero derivatives (STRIKE-GOLDD nnzDerW; 0 = constants). Default: the model "
                   "file's unknown_input_derivatives, else arbitrary")
    p.add_argument("-o", "--output", default=None, metavar="FILE", help="write to FILE instead of stdout")
    p.add_argument("--force", action="store_true", help="overwrite FILE if it exists")
    p.set_defaults(func=_cmd_analyze)


def _cmd_analyze(args: argparse.Namespace) -> int:
    from obsnl.observability.analyze import analyze

    from obsnl.report.files import check_target

    if args.output and args.output != "-":
        check_target(args.output, force=args.force)
    model = _load(args.model)
    labels = [s.strip() for s in args.branches.split(",") if s.strip()] if args.branches else None
    visits = _record_visits(model, args.record) if args.record else None
    result = analyze(model, method=args.method, seed=args.seed, max_seconds=args.max_seconds, branches=labels,
                     visited=visits.patterns if visits else None, crossings=visits.crossings if visits else None,
                     joint=not args.no_joint, unknown_input_derivatives=args.unknown_input_derivatives)
    from obsnl.report.tables import render

    write_output(render(result, args.format), args.output, force=args.force)
    stuck = [b for b in result.branches if b.verdict.value == "inconclusive"]
    if stuck:
        b = stuck[0]
        more = f" (and {len(stuck) - 1} more branch(es))" if len(stuck) > 1 else ""
        raise _Exit(2, f"branch ({b.label}) is inconclusive: {b.reason}{more}")
    return 0


def _record_visits(model: Any, path: str) -> Any:
    """The sign patterns a simulation of the model's [values] under the record at ``path`` visits."""
    import numpy as np

    from obsnl.estimation.records import read_record
    from obsnl.observability.visited import visited_patterns

    if len(model.inputs) != 1:
        raise _Exit(2, f"--record drives one input, model {model.name!r} has {len(model.inputs)}; give a model with "
                    "one known input")
    rec = read_record(path)
    t = rec.dt * np.arange(len(rec.accel))
    return visited_patterns(model, t, {model.inputs[0].name: rec.accel})


# --------------------------------------------------------------------------- report
def _add_report(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "report",
        help="analyse models and write their branch tables (Markdown, LaTeX, JSON)",
        description="Analyse each model and write DIR/<model>.md, .tex (booktabs) and .json (branch table, "
        "schema obsnl.branch-table/1), an index (index.md) and a timing table (timings.md).",
    )
    p.add_argument("models", nargs="+", metavar="MODEL", help="model files (.toml or .json)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--method", choices=("auto", "orc", "sedoglavic"), default="auto",
                   help="observability engine (default: auto)")
    p.add_argument("--seed", type=_seed, default=0, help="seed of the random point (default: 0)")
    p.add_argument("--max-seconds", type=float, default=None, help="time limit per branch")
    p.add_argument("--force", action="store_true", help="overwrite existing report files")
    _add_executor(p, workers=1)  # small analyses: processes cost more than they save (benchmarks/bench_report.py)
    p.set_defaults(func=_cmd_report)


def _cmd_report(args: argparse.Namespace) -> int:
    from obsnl.batch import report_models

    models = [_load(m) for m in args.models]
    results = report_models(models, args.out, method=args.method, seed=args.seed, force=args.force,
                           max_seconds=args.max_seconds, executor=_executor(args))
    print(f"wrote {len(results)} table(s) with index.md and timings.md to {args.out}")
    return 0


# --------------------------------------------------------------------------- bank
def _add_bank(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "bank",
        help="run the observer-bank crack benchmark on the cantilever link",
        description="Run the observer-bank scenarios (healthy link, a breathing crack in each element) with "
        "several noise seeds; write a localisation table (bank.md), force plots (forces_*.png) and bank.json.",
    )
    p.add_argument("--seeds", type=int, default=3, help="noise seeds per scenario (default: 3); thresholds use as many other seeds")
    p.add_argument("--out", default="reports/bank", help="output folder (default: reports/bank)")
    p.add_argument("--model", default=None, help="link model file (default: models/cantilever_link.toml)")
    p.add_argument("--force", action="store_true", help="overwrite existing output files")
    p.set_defaults(func=_cmd_bank)


def _cmd_bank(args: argparse.Namespace) -> int:
    from obsnl.studies.link_study import run_link_study
    from obsnl.studies.cantilever import load_link_spec
    from obsnl.report.figures import FIGURE_PREFIX, plot_bank_forces
    from obsnl.report.bank import bank_table_markdown

    if args.seeds < 1:
        raise _Exit(2, f"--seeds must be at least 1, got {args.seeds}")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise _Exit(2, f"{args.out} is a file; --out needs a folder")
    taken = [p for p in (out / "bank.json", out / "bank.md") if p.exists() or p.is_symlink()]
    taken += sorted(out.glob(f"{FIGURE_PREFIX}*.png")) if out.is_dir() else []
    if taken and not args.force:
        raise _Exit(2, f"{taken[0]} exists; pass --force to overwrite it")
    study = run_link_study(seeds=args.seeds, spec=load_link_spec(args.model) if args.model else None)
    doc = study.to_dict()
    write_output(json.dumps(doc, indent=2), str(out / "bank.json"), force=True)
    write_output(bank_table_markdown(doc), str(out / "bank.md"), force=True)
    figs = plot_bank_forces(study, out)
    print(f"wrote {out / 'bank.json'}, {out / 'bank.md'} and {len(figs)} force plots")
    return 0


# --------------------------------------------------------------------------- symmetries, reparametrize
def _add_symmetries(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "symmetries",
        help="generators of the unobservable directions of each branch",
        description="Find, branch by branch, the translations, scalings and affine fields that leave the outputs "
        "unchanged (exact over Q, verified symbolically); directions with no closed form are counted.",
    )
    p.add_argument("model", help="model file (.toml or .json)")
    p.add_argument("--format", choices=("text", "json"), default="text", help="output format (default: text)")
    p.add_argument("--degree", type=int, choices=(1, 2), default=1, help="ansatz degree (default: 1, affine)")
    p.add_argument("--seed", type=_seed, default=0, help="seed of the random points (default: 0)")
    p.set_defaults(func=_cmd_symmetries)


def _cmd_symmetries(args: argparse.Namespace) -> int:
    from obsnl.model.branches import split_branches
    from obsnl.observability.symmetry import symmetries

    model = _load(args.model)
    out = []
    for i, b in enumerate(split_branches(model, seed=args.seed)):
        out.append((b, symmetries(b.model, seed=args.seed + i, degree=args.degree)))
    if args.format == "json":
        data = [{"label": b.label, "guard": b.guard_text, **s.to_dict()} for b, s in out]
        write_output(json.dumps(data, indent=2), None, force=False)
        return 0
    lines = []
    for b, s in out:
        lines.append(f"branch {b.label} ({b.guard_text}): {s.dimension} unobservable direction(s), "
                     f"{len(s.generators)} with a closed form, {s.missing} without")
        lines.extend(f"  {g.kind:<11} {g}" for g in s.generators)
        lines.extend(f"  note: {n}" for n in s.notes)
    write_output("\n".join(lines), None, force=False)
    return 0


def _add_reparametrize(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "reparametrize",
        help="propose identifiable combinations and write the model in them",
        description="Propose identifiable combinations (invariants of the symmetry groups, merged across branches) "
        "and write the reparametrized model file; each new symbol is defined in its [definitions] table.",
    )
    p.add_argument("model", help="model file (.toml or .json)")
    p.add_argument("-o", "--output", metavar="NEW.toml", help="write the new model here (default: print it)")
    p.add_argument("--force", action="store_true", help="overwrite an existing output file")
    p.add_argument("--eliminate", default="", metavar="P,Q", help="parameters to normalise to 1 (scaling pivots)")
    p.add_argument("--keep", default="", metavar="P,Q", help="parameters that must not be pivots")
    p.add_argument("--name", action="append", default=[], metavar="OLD=NEW",
                   help="rename a proposed symbol (repeatable), e.g. --name sigma_p=r")
    p.add_argument("--seed", type=_seed, default=0, help="seed of the random points (default: 0)")
    p.set_defaults(func=_cmd_reparametrize)


def _cmd_reparametrize(args: argparse.Namespace) -> int:
    from obsnl.recombination.reparametrize import reparametrize

    model = _load(args.model)
    names = {}
    for item in args.name:
        if item.count("=") != 1 or not all(item.split("=")):
            raise _Exit(2, f"--name takes OLD=NEW, got {item!r}")
        old, new = item.split("=")
        names[old.strip()] = new.strip()
    split = lambda s: [x.strip() for x in s.split(",") if x.strip()]  # noqa: E731
    r = reparametrize(model, keep=split(args.keep), eliminate=split(args.eliminate), names=names, seed=args.seed)
    if args.output is None or args.output == "-":
        write_output(r.to_toml(), None, force=False)
        return 0
    write_output(r.to_toml(), args.output, force=args.force)
    print(f"wrote {args.output}: {len(r.mapping)} variables ({'complete' if r.complete else 'incomplete'}, "
          f"method {r.method}, verified {'yes' if r.verified else 'no'})")
    for k, v in r.mapping.items():
        print(f"  {k} = {v}")
    for g in r.divided:
        print(f"  divided out: {g}")
    for n in r.notes:
        print(f"  note: {n}")
    return 0


# --------------------------------------------------------------------------- identify, reproduce
def _add_identify(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "identify", help="identify a model's parameters from measured data (or a simulated study) with a UKF/DUKF",
        description="Analyse MODEL (a structurally unidentifiable parameter stops the run), then estimate its "
        "parameters with the UKF or the DUKF from --data (CSV: time_s or t, one column per model input and output) "
        "or, as a simulation study, from the model's [values] driven by --record. Guesses: the model's [guess] table, "
        "then --guess. Writes DIR/identify.json, fit.png and traces.png with --out.")
    p.add_argument("model", help="model file (.toml or .json)")
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--data", help="measured inputs and outputs (.csv)")
    src.add_argument("--record", help="simulation study: ground motion (.csv or PEER .AT2) driving the [values]")
    p.add_argument("--table", help="branch table JSON (required for --method dukf)")
    p.add_argument("--method", choices=("ukf", "dukf"), default="ukf", help="filter (default: ukf)")
    p.add_argument("--guess", action="append", default=[], metavar="P=V", help="initial guess (repeatable)")
    p.add_argument("--noise", action="append", default=[], metavar="NAME=RATIO",
                   help="noise-to-signal RMS ratio of a channel (repeatable) or RATIO for all; measured channels not "
                   "named are estimated from their high-frequency residual (default in a study: 0.001)")
    p.add_argument("--passes", type=int, default=3, help="passes over the record (default: 3)")
    p.add_argument("--allow-unidentifiable", action="store_true", help="run despite the structural verdict")
    p.add_argument("--hold", action="store_true", help="measured data: hold poorly informed parameters at their guess")
    p.add_argument("--seed", type=_seed, default=0, help="noise seed of a study and the Monte-Carlo (default: 0)")
    for flag, what in (("--s0", "prior std of log-parameters"), ("--q-theta", "random walk of log-parameters"),
                       ("--q-x", "factor on the state noise"), ("--gate", "innovation gate")):
        p.add_argument(flag, type=float, default=None, help=f"{what} (default: tuned on measured data)")
    p.add_argument("--samples", type=int, default=None, help="use only the first samples of a --record")
    p.add_argument("--jit", action="store_true", help="compile the filter to C (needs a C compiler)")
    p.add_argument("--replicates", type=int, default=0, help="Monte-Carlo replicates (0: off, else >= 3)")
    p.add_argument("--out", default=None, metavar="DIR", help="output folder (default: print only)")
    p.add_argument("--force", action="store_true", help="overwrite existing output files")
    p.set_defaults(func=_cmd_identify)


def _cmd_identify(args: argparse.Namespace) -> int:
    from obsnl.estimation.experiments import Tuning
    from obsnl.estimation.identify import MEASURED_GRID
    from obsnl.report.identification import identify_text
    from obsnl.studies.identify import IDENTIFY_FILES, identify, parse_assignments, study, write_identification

    taken = [Path(args.out) / f for f in IDENTIFY_FILES if args.out and (Path(args.out) / f).exists()]
    if taken and not args.force:
        raise _Exit(2, f"{taken[0]} exists; pass --force to overwrite it")
    model = _load(args.model)
    names = [s.name for s in model.parameters]
    guess = parse_assignments(args.guess, names, option="--guess", what="parameter")
    channels = [s.name for s in model.inputs] + list(model.outputs)
    plain = [v for v in args.noise if "=" not in v]
    try:
        noise = {c: float(plain[-1]) for c in channels} if plain else {}
    except ValueError:
        raise _Exit(2, f"--noise {plain[-1]!r}: give NAME=RATIO or one RATIO for every channel") from None
    named = [v for v in args.noise if "=" in v]
    noise.update(parse_assignments(named, channels, option="--noise", what="model input or output"))
    if args.record and named:
        raise _Exit(2, "a simulation study (--record) takes one --noise RATIO for every channel")
    t = (args.s0, args.q_theta, args.q_x, args.gate)
    tuning = None if t == (None,) * 4 else Tuning(*(d if v is None else v for v, d in zip(t, (0.2, 0.0, 1.0, float("inf")))))
    opts = dict(guess=guess, method=args.method, table=args.table, passes=args.passes, replicates=args.replicates,
                seed=args.seed, allow_unidentifiable=args.allow_unidentifiable, jit=args.jit)
    tuned = args.data is not None and tuning is None
    bars: list[Any] = []  # the bar starts with the first pass (after the checks: a refusal prints one line)

    def tick() -> None:
        if not bars:
            bars.append(_progress("identify", args.passes + (len(MEASURED_GRID) if tuned else 0), "pass"))
        if bars[0] is not None:
            bars[0].update(1)
    try:
        if args.data:
            res = identify(model, args.data, noise=noise, tuning=tuning, hold=args.hold, progress=tick, **opts)
        else:
            res = study(model, args.record, noise=float(plain[-1]) if plain else 1e-3, samples=args.samples,
                        tuning=tuning or Tuning(0.2, 0.0, 1.0), progress=tick, **opts)
    finally:
        if bars and bars[0] is not None:
            bars[0].close()
    write_output(identify_text(res.to_dict()), None, force=False)
    if args.out:
        files = write_identification(res, args.out, force=args.force)
        print(f"wrote {', '.join(str(f) for f in files)}")
    return 0


def _progress(desc: str, total: int | None, unit: str) -> Any:
    """A progress bar on stderr (tqdm), or None when tqdm is missing."""
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover
        return None
    return tqdm(desc=desc, total=total, unit=unit, file=sys.stderr)


def _add_reproduce(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "reproduce",
        help="reproduce the seed paper's Table 2 and Figures 2-3 (analysis -> tables -> UKF and DUKF)",
        description="The whole seed pipeline: analyse the damage-healing model, write its branch table, tune the "
        "UKF and the DUKF on noise seeds that are not reported, run both on --seeds noise seeds and write "
        "table2.json/.md/.tex and fig2_*.png, fig3_*.png into --out. The default output folder "
        "reports/identification (or reports/identification/RECORD with --record) is REGENERATED on every run; "
        "another --out is never overwritten without --force.",
    )
    p.add_argument("--record", default=None, help="another ground motion (.csv or .AT2); resampled to 100 Hz, first 2000 samples")
    p.add_argument("--seeds", type=int, default=5, help="reported noise seeds 0..K-1 (default: 5)")
    p.add_argument("--tuning-seeds", type=int, default=5, help="noise seeds used for tuning only (default: 5)")
    p.add_argument("--passes", type=int, default=3, help="passes of the refined protocol (default: 3)")
    p.add_argument("--samples", type=int, default=None, help="use only the first samples (quick runs)")
    p.add_argument("--no-jit", action="store_true", help="do not compile the filters to C (slower runs)")
    p.add_argument("--replicates", type=int, default=None,
                   help="Monte-Carlo replicates of the practical-identifiability check per reported run "
                        "(default: 32; 0: off)")
    p.add_argument("--out", default=None, help="output folder (default: reports/identification)")
    p.add_argument("--force", action="store_true", help="overwrite files in a non-default --out")
    _add_executor(p)
    p.set_defaults(func=_cmd_reproduce)


def _add_executor(p: argparse.ArgumentParser, workers: int | None = None) -> None:
    p.add_argument("--workers", type=int, default=workers,
                   help=f"local processes (default: {workers or 'one per core'}; 1: none)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS", help="a Dask cluster instead (tcp://host:8786)")


def _executor(args: argparse.Namespace) -> Any:
    from obsnl.executor import Executor

    return Executor(scheduler=args.scheduler, workers=args.workers)


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from obsnl.estimation.records import read_record
    from obsnl.studies.seed_paper import reproduce, write_reproduction

    if args.seeds < 1 or args.tuning_seeds < 1 or args.passes < 1:
        raise _Exit(2, "--seeds, --tuning-seeds and --passes must be at least 1")
    record = read_record(args.record) if args.record else None
    default = Path("reports/identification") / (record.name if record is not None else "")
    out = Path(args.out) if args.out else default
    from obsnl.report.files import check_target
    from obsnl.studies.seed_paper import REPRODUCTION_FILES

    regenerate = args.out is None  # the default folder holds the committed results and is regenerated on purpose
    for f in [out / n for n in REPRODUCTION_FILES] + (sorted(out.glob("fig[23]_*.png")) if out.is_dir() else []):
        check_target(f, force=args.force or regenerate, root=out)
    if regenerate:
        print(f"obsnl reproduce: regenerating the default folder {out} (committed results); pass --out DIR to "
              f"keep them", file=sys.stderr)
    bar = _progress("reproduce", None, "run")
    try:
        rep = reproduce(record=record, seeds=args.seeds, tuning_seeds=args.tuning_seeds, passes=args.passes,
                        jit=not args.no_jit, samples=args.samples, progress=bar, executor=_executor(args),
                        **({} if args.replicates is None else {"replicates": args.replicates}))
    finally:
        if bar is not None:
            bar.close()
    files = write_reproduction(rep, out)
    print(f"wrote {len(files)} files to {out}: " + ", ".join(f.name for f in files))
    return 0


#: Subcommands in the order ``obsnl --help`` lists them.
_BUILDERS = [_add_show, _add_branches, _add_analyze, _add_report, _add_symmetries, _add_reparametrize,
             _add_identify, _add_reproduce, _add_bank]


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser (exposed for tests and documentation)."""
    parser = argparse.ArgumentParser(
        prog="obsnl",
        description="Observability and identifiability of nonlinear, non-smooth mechanical models.",
    )
    from . import __version__

    parser.add_argument("--version", action="version", version=f"obsnl {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for build in _BUILDERS:
        build(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code (0 ok, 2 bad input, 1 internal error)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: --help (0) or usage error (2)
        return int(exc.code or 0)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except _Exit as exc:
        if exc.message:
            print(f"obsnl {args.command}: error: {exc.message}", file=sys.stderr)
        return exc.code
    except ObsnlError as exc:
        print(f"obsnl {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except (FileNotFoundError, IsADirectoryError, PermissionError) as exc:
        print(f"obsnl {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"obsnl {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

