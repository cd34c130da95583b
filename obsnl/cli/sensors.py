"""``obsnl sensors``: the minimal sets of candidate sensors (the model's outputs) that make the targets
jointly identifiable (:func:`obsnl.design.sensors.sensors`), rendered by :mod:`obsnl.report.sensors`."""

from __future__ import annotations

import argparse

from obsnl.cli.common import _add_executor, _at_least, _executor, _load, _seed, write_output
from obsnl.model.budget import time_budget
from obsnl.observability.limits import check_file_limits


def _add_sensors(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "sensors",
        help="which sensors make every target identifiable (minimal sets of the model's outputs)",
        description="Search the minimal sets of the model's outputs (the candidate sensors) for which the targets "
        "are jointly identifiable, smallest first, on the monotonicity of the joint verdict (a superset of a "
        "sufficient set is sufficient). Each set is certified as the analysis is; when even every sensor "
        "together is not enough, the answer says which targets stay hidden and which symmetry no sensor breaks.",
    )
    p.add_argument("model", help="model file (.toml or .json) or obsnl:NAME; its outputs are the candidate sensors")
    p.add_argument("--target", default="all", metavar="all|parameters|NAMES",
                   help="what must be identifiable: all (every state and parameter, default), parameters, or "
                   "comma-separated names")
    p.add_argument("--max-size", type=_at_least(1), default=None, metavar="K",
                   help="largest set searched (default: every size)")
    p.add_argument("--format", choices=("text", "json", "md", "tex"), default="text",
                   help="output format (default: text)")
    p.add_argument("-o", "--output", default=None, metavar="FILE", help="write here instead of standard output")
    p.add_argument("--force", action="store_true", help="overwrite FILE")
    p.add_argument("--seed", type=_seed, default=0, help="seed of every analysis (default: 0)")
    p.add_argument("--max-seconds", type=float, default=None,
                   help="time limit of each analysis (a set it cuts short is reported undecided)")
    p.add_argument("--progress", action="store_true", help="show a progress bar on standard error")
    _add_executor(p, workers=1)
    p.set_defaults(func=_cmd_sensors)


def _cmd_sensors(args: argparse.Namespace) -> int:
    from obsnl.design.sensors import sensors
    from obsnl.report.files import check_target
    from obsnl.report.sensors import render_sensors

    if args.output and args.output != "-":
        check_target(args.output, force=args.force)
    with time_budget(None):
        model = _load(args.model, check=check_file_limits)
    result = sensors(model, target=args.target, max_size=args.max_size, seed=args.seed,
                     max_seconds=args.max_seconds, executor=_executor(args), progress=args.progress)
    write_output(render_sensors(result, args.format), args.output, force=args.force)
    return 0
