"""``obsnl sensors``: the minimal sets of candidate sensors (the model's outputs) that make the targets
jointly identifiable (:func:`obsnl.design.sensors.sensors`), rendered by :mod:`obsnl.report.sensors`."""

from __future__ import annotations

import argparse

from obsnl.cli.common import (_Exit, _add_executor, _at_least, _executor, _load, _one_input_record, _seed,
                              write_output)
from obsnl.model.bounds.budget import time_budget
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
    p.add_argument("--record", default=None, metavar="FILE",
                   help="rank the sufficient sets of one size by the Cramer-Rao bound of the parameters along the "
                   "response of the model's [values] to this record (.csv or .AT2, driving the model's one input), "
                   "and give effective independence's choice")
    p.add_argument("--rank-size", type=_at_least(1), default=None, metavar="K",
                   help="size of the sets ranked (default: the smallest minimal set's)")
    p.add_argument("--noise", type=float, default=0.01, metavar="LEVEL",
                   help="relative noise of every output for the ranking: std = LEVEL x RMS (default 0.01)")
    _add_executor(p, workers=1)
    p.set_defaults(func=_cmd_sensors)


def _cmd_sensors(args: argparse.Namespace) -> int:
    from obsnl.design.sensors import rank_sufficient_sets, sensors
    from obsnl.report.files import check_target
    from obsnl.report.sensors import render_sensors

    if args.output and args.output != "-":
        check_target(args.output, force=args.force)
    with time_budget(None):
        model = _load(args.model, check=check_file_limits)
    if args.record is not None:
        if not (0.0 < args.noise < 10.0):
            raise _Exit(2, f"--noise {args.noise} is not a relative level between 0 and 10 (0.01 is 1 %)")
        rec = _one_input_record(model, args.record)  # read before the search: a bad record is refused before any work
    result = sensors(model, target=args.target, max_size=args.max_size, seed=args.seed,
                     max_seconds=args.max_seconds, executor=_executor(args), progress=args.progress)
    if args.record is not None:
        import numpy as np

        t = rec.dt * np.arange(len(rec.accel))
        result = rank_sufficient_sets(result, model, t=t, inputs=rec.accel, size=args.rank_size, noise=args.noise)
    write_output(render_sensors(result, args.format), args.output, force=args.force)
    if result.undecided_sets:  # written, and said: an undecided set is never passed over in silence
        first = result.answer(result.undecided_sets[0])
        raise _Exit(2, f"{len(result.undecided_sets)} sensor set(s) undecided, e.g. {{{', '.join(first.sensors)}}}: "
                    f"{first.reason or 'minimality undecided'}; raise --max-seconds")
    return 0
