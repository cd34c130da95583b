"""Commands of the analysis side: show, branches, analyze, report, symmetries, reparametrize."""

from __future__ import annotations

import argparse
import json
from typing import Any

from obsnl.cli.common import (_Exit, _add_executor, _executor, _load, _one_input_record, _progress,  # noqa: F401
                              _seed, write_output)
from obsnl.model.reading.unknown_inputs import DERIVATIVES_MARGIN
from obsnl.model.bounds.budget import time_budget
from obsnl.observability.limits import MAX_UNKNOWNS, check_analysis_limits, check_file_limits, out_of_memory


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
    from obsnl.model.branching.branches import split_branches

    model = _load(args.model)
    branches = split_branches(model, undecided=True)  # a branch no point was found in is listed as such
    if args.format == "json":
        doc = {"model": model.name, "branches": [{"label": b.label, "guard": b.guard_text,
                                                  **({"undecided": b.undecided} if b.undecided else {})}
                                                 for b in branches]}
        write_output(json.dumps(doc, indent=2), None, force=False)
        return 0
    lines = [f"{model.name}: {len(branches)} branch{'es' if len(branches) != 1 else ''}"]
    for b in branches:
        lines.append(f"  ({b.label}) {b.guard_text}" + (f"  [feasibility undecided: {b.undecided}]" if b.undecided
                                                         else ""))
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
        "printed (undecided variables are in neither list) and the reason goes to stderr. A model with more "
        f"than {MAX_UNKNOWNS} unknowns (states + parameters + unknown-input coefficients) is refused before any "
        "work: the engines' dense arrays grow as the cube of that number.",
    )
    p.add_argument("model", help="model file (.toml, or .json such as a peer case)")
    p.add_argument("--format", choices=("text", "json", "md", "tex", "json-table"), default="text",
                   help="text (default); json: the analysis; md/tex: branch tables for documents; json-table: the "
                   "branch table read by the DUKF (schema obsnl.branch-table/1)")
    p.add_argument("--method", choices=("auto", "orc", "sedoglavic"), default="auto",
                   help="observability engine (default: auto)")
    p.add_argument("--seed", type=_seed, default=None, help="seed of the random choices (default: drawn and reported)")
    p.add_argument("--max-seconds", type=float, default=None,
                   help="time limit of the whole command: reading and factoring the model, the --record "
                   "simulation, the split into branches and the analysis")
    p.add_argument("--branches", default=None, metavar="LABELS",
                   help="visit only these branches (comma-separated labels, e.g. a,c); default: every feasible branch")
    p.add_argument("--record", default=None, metavar="FILE",
                   help="simulate the model's [values] under this record (.csv or .AT2; it drives the model's one "
                   "input) and analyse the branches and crossings it visits: what this experiment reveals")
    p.add_argument("--no-joint", action="store_true", help="skip the joint verdict (per-branch results and union only)")
    p.add_argument("--unknown-input-derivatives", default=None, metavar="K|arbitrary",
                   help="what the unknown inputs are: 'arbitrary' (any function of time) or K, polynomials in t "
                   "with K non-zero derivatives (STRIKE-GOLDD nnzDerW; 0 = constants). K is at most the model's "
                   f"states + parameters + {DERIVATIVES_MARGIN}: the rank test reads no more derivatives of an "
                   "unknown input than that, so larger K add nothing and are refused. Default: the model "
                   "file's unknown_input_derivatives, else arbitrary")
    p.add_argument("-o", "--output", default=None, metavar="FILE", help="write to FILE instead of stdout")
    p.add_argument("--force", action="store_true", help="overwrite FILE if it exists")
    p.set_defaults(func=_cmd_analyze)


def _cmd_analyze(args: argparse.Namespace) -> int:
    from obsnl.observability.analyze import analyze

    from obsnl.report.files import check_target

    if args.output and args.output != "-":
        check_target(args.output, force=args.force)
    # one time budget from here: reading and factoring the model, the record's simulation, split and analysis
    with time_budget(args.max_seconds):
        model = _load(args.model, check=check_file_limits)  # a too large model refused before parsing
        # refused before any work (the record's simulation included): a too large model or K
        k = check_analysis_limits(model, args.unknown_input_derivatives, option="--unknown-input-derivatives")
        labels = [s.strip() for s in args.branches.split(",") if s.strip()] if args.branches else None
        try:
            visits = _record_visits(model, args.record) if args.record else None
            result = analyze(model, method=args.method, seed=args.seed, max_seconds=args.max_seconds,
                             branches=labels, visited=visits.patterns if visits else None,
                             crossings=visits.crossings if visits else None, joint=not args.no_joint,
                             unknown_input_derivatives=args.unknown_input_derivatives)
        except MemoryError:  # outside analyze itself (the record's simulation); raised below, arrays freed
            result = None
    if result is None:
        raise out_of_memory(model, k)
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

    from obsnl.observability.joint.visited import visited_patterns

    rec = _one_input_record(model, path)
    t = rec.dt * np.arange(len(rec.accel))
    return visited_patterns(model, t, {model.inputs[0].name: rec.accel})


# --------------------------------------------------------------------------- report
def _add_report(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "report",
        help="analyse models and write their branch tables (Markdown, LaTeX, JSON)",
        description="Analyse each model and write DIR/<model>.md, .tex (booktabs) and .json (branch table, "
        "schema obsnl.branch-table/1), an index (index.md) and a timing table (timings.md). Every model is "
        f"checked first: one with more than {MAX_UNKNOWNS} unknowns (states + parameters + unknown-input "
        "coefficients) is refused before any analysis.",
    )
    p.add_argument("models", nargs="+", metavar="MODEL", help="model files (.toml or .json)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--method", choices=("auto", "orc", "sedoglavic"), default="auto",
                   help="observability engine (default: auto)")
    p.add_argument("--seed", type=_seed, default=0, help="seed of the random point (default: 0)")
    p.add_argument("--max-seconds", type=float, default=None,
                   help="time limit of the whole command (reading, splitting and analysing every model; each "
                   "model on a worker gets the same limit); what is not finished is reported inconclusive")
    p.add_argument("--force", action="store_true", help="overwrite existing report files")
    _add_executor(p, workers=1)  # small analyses: processes cost more than they save (benchmarks/bench_report.py)
    p.set_defaults(func=_cmd_report)


def _cmd_report(args: argparse.Namespace) -> int:
    from obsnl.batch import report_models

    with time_budget(args.max_seconds):  # one budget from here, as for analyze
        models = [_load(m, check=check_file_limits) for m in args.models]
        for m in models:  # every model checked before the first is analysed
            check_analysis_limits(m)
        results = report_models(models, args.out, method=args.method, seed=args.seed, force=args.force,
                                max_seconds=args.max_seconds, executor=_executor(args))
    print(f"wrote {len(results)} table(s) with index.md and timings.md to {args.out}")
    stuck = [(r.model, b) for r in results for b in r.branches if b.verdict.value == "inconclusive"]
    if stuck:  # written, and said: an undecided branch is never passed over in silence
        name, b = stuck[0]
        more = f" (and {len(stuck) - 1} more branch(es))" if len(stuck) > 1 else ""
        raise _Exit(2, f"{name}: branch ({b.label}) is inconclusive: {b.reason}{more}")
    return 0


# --------------------------------------------------------------------------- bank
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
    from obsnl.model.branching.branches import split_branches
    from obsnl.observability.certificates.symmetry import symmetries

    model = _load(args.model, check=check_file_limits)
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

    model = _load(args.model, check=check_file_limits)
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


