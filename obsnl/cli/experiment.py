"""The ``design`` command: which amplitude of a record, and which of several records, make a model's
targets jointly identifiable (:func:`obsnl.design.experiment.design`). Thin: parse, call, print."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from obsnl.cli.common import _Exit, _load, _one_input_record, _seed, write_output
from obsnl.model.bounds.budget import time_budget
from obsnl.observability.limits import check_analysis_limits, check_file_limits


def _scales(text: str) -> list[float]:
    """An argparse type: comma-separated positive numbers."""
    try:
        values = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        values = []
    if not values or not all(0 < v < float("inf") for v in values):
        raise argparse.ArgumentTypeError(f"{text[:30]!r} is not a list of positive numbers such as 0.1,1,10")
    return values


def _add_design(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "design",
        help="the smallest record scale and the records that make a model identifiable",
        description="Simulate the model's [values] under each record scaled by 2**-10 .. 2**10, list the branches "
        "visited per scale, bisect the smallest scale at which every target is jointly identifiable (the joint "
        "verdict over the visited branches), and list the minimal sets of records (at scale 1) that suffice "
        "together. Exit code 2 when the answer is inconclusive (the result is still printed).",
    )
    p.add_argument("model", help="model file (.toml or .json) or obsnl:NAME; its [values] are simulated")
    p.add_argument("--record", action="append", default=[], metavar="FILE",
                   help="a record (.csv or .AT2) driving the model's one input; repeat for several experiments")
    p.add_argument("--target", default="all", metavar="all|parameters|NAMES",
                   help="what must be identifiable: all (default), parameters, or comma-separated names")
    p.add_argument("--sensors", default=None, metavar="a,b", help="the outputs measured (default: every output)")
    p.add_argument("--format", choices=("text", "json", "md", "tex"), default="text",
                   help="output format (default: text)")
    p.add_argument("-o", "--output", default=None, metavar="FILE", help="write to FILE instead of stdout")
    p.add_argument("--figure", default=None, metavar="FILE.png", help="also plot the visited branches per scale")
    p.add_argument("--force", action="store_true", help="overwrite FILE (and the figure) if it exists")
    p.add_argument("--max-seconds", type=float, default=None,
                   help="time limit of the whole command (reading, simulations, verdicts)")
    p.add_argument("--scales", type=_scales, default=None, metavar="S1,S2,...",
                   help="the grid of factors on every record (default: the powers of 2 from 2**-10 to 2**10)")
    p.add_argument("--seed", type=_seed, default=0, help="seed of the analyses (default: 0)")
    p.set_defaults(func=_cmd_design)


def _cmd_design(args: argparse.Namespace) -> int:
    from obsnl.design.experiment import design
    from obsnl.report.experiment import plot_visits, render_design
    from obsnl.report.files import OutputFolder, check_target

    if not args.record:
        raise _Exit(2, "give at least one --record FILE (.csv or .AT2)")
    if args.output and args.output != "-":
        check_target(args.output, force=args.force)  # refused before any work
    if args.figure:
        if Path(args.figure).suffix.lower() != ".png":
            raise _Exit(2, f"--figure writes a PNG; name a .png file, not {args.figure!r}")
        if args.output and Path(args.output).resolve() == Path(args.figure).resolve():
            raise _Exit(2, "--figure and -o name the same file; give two files")
        check_target(args.figure, force=args.force)
    with time_budget(args.max_seconds):
        model = _load(args.model, check=check_file_limits)
        check_analysis_limits(model)
        records = [_one_input_record(model, path) for path in args.record]
        stems = [r.name for r in records]
        if len(set(stems)) < len(stems):  # same file names in different folders: name them by their paths
            records = [dataclasses.replace(r, name=path) for r, path in zip(records, args.record)]
        result = design(model, records, target=args.target, sensors=args.sensors, scales=args.scales,
                        seed=args.seed, max_seconds=args.max_seconds)
    write_output(render_design(result, args.format), args.output, force=args.force)
    if args.figure:
        fig = Path(args.figure)
        with OutputFolder(fig.parent, [fig.name], force=args.force, folder_link_ok=True) as out:
            plot_visits(result, out.path(fig.name))
            out.commit()
    if result.status == "inconclusive":
        raise _Exit(2, f"inconclusive: {result.reason}")
    return 0
