"""The ``obsnl`` command line: each subcommand parses its options into its request and prints what its module of
:mod:`obsnl.commands` returns (:func:`obsnl.cli.commands.run`; the modules are imported plainly in
:func:`obsnl.cli.commands.printed`). The parser is the table :data:`COMMANDS`.

Exit codes: 0 success, 2 bad input (one line on stderr, no traceback), 1 an internal error. Nothing
numeric is imported before a command runs: ``obsnl --help`` loads argparse and the package only.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from obsnl._text import os_error_line
from obsnl.cli.commands import run as run_job
from obsnl.cli.common import OneValue, ShortErrorParser, cli_terms, comma_names, plain_number, whole_number
from obsnl.errors import ObsnlError
from obsnl.model.reading.unknown_inputs import DERIVATIVES_MARGIN
from obsnl.observability.limits import MAX_UNKNOWNS

__all__ = ["main", "run", "build_parser"]


def _o(*flags: str, **kw: object) -> tuple:
    return flags, kw


MODEL, SECONDS = _o("model", help="model file (.toml or .json) or obsnl:NAME"), _o("--max-seconds", type=plain_number)
FMT, FMT4 = (_o("--format", dest="fmt", choices=("text", "json", *c), default="text") for c in ((), ("md", "tex")))
FORCE = _o("--force", action="store_true", help="overwrite existing files")
SEED = _o("--seed", type=whole_number(), default=0)
OUT = [_o("-o", "--output", metavar="FILE", help="write here instead of stdout"), FORCE]
METHOD = _o("--method", choices=("auto", "orc", "sedoglavic"), default="auto", help="observability engine")
SCHEDULER = _o("--scheduler", metavar="ADDRESS", help="a Dask cluster instead (tcp://host:8786)")
EXECUTOR = [_o("--workers", type=whole_number(1), help="local processes (default: one per core)"), SCHEDULER]
ONE_WORKER = [_o("--workers", type=whole_number(1), default=1, help="local processes (default: 1)"), SCHEDULER]
RECORD = "(.csv or .AT2) driving the model's one input"
INTERSAMPLE = _o(
    "--intersample",
    action="append",
    default=[],
    metavar="[NAME=]KIND",
    help="an input between samples: zoh, "
    "linear or bandlimited (repeatable; a bare KIND: every input; default: the model's [intersample], "
    "else linear)",
)
BIG = f"A model with more than {MAX_UNKNOWNS} unknowns (states + parameters + unknown inputs) is refused first."

#: Each subcommand: its one-line help, its description and its options, in the order --help lists them. Its module of
#: :mod:`obsnl.commands` (the request built from the options, run, and what the command prints) is imported plainly
#: by :func:`obsnl.cli.commands.printed`.
COMMANDS: dict[str, tuple[str, str | None, list[tuple]]] = {
    "show": ("print a model's equations", None, [MODEL, FMT]),
    "branches": (
        "list the smooth branches of a non-smooth model",
        None,
        [MODEL, FMT, _o("--equations", action="store_true", help="print each branch's equations")],
    ),
    "analyze": (
        "observability/identifiability of every branch of a model",
        "Test each smooth branch (ORC "
        "or Sedoglavic's randomized test), then the branches jointly. Exit code 2 when a branch is "
        "inconclusive: the result is printed, the reason goes to stderr. " + BIG,
        [
            MODEL,
            _o("--format", dest="fmt", choices=("text", "json", "md", "tex", "json-table"), default="text"),
            METHOD,
            _o("--seed", type=whole_number(), default=0, help="default 0 (the same answer on every run)"),
            SECONDS,
            _o("--branches", type=comma_names, metavar="LABELS", help="only these branches (e.g. a,c)"),
            _o("--record", metavar="FILE", help=f"only what the [values] visit under a record {RECORD}"),
            _o("--no-joint", dest="joint", action="store_false", help="skip the joint verdict"),
            _o(
                "--unknown-input-derivatives",
                metavar="K|arbitrary",
                help=f"K non-zero derivatives; K is at most the model's states + parameters + {DERIVATIVES_MARGIN}",
            ),
            *OUT,
        ],
    ),
    "report": (
        "analyse models and write their branch tables (Markdown, LaTeX, JSON)",
        "Write DIR/<model>.md, .tex, .json, index.md and timings.md. " + BIG,
        [
            _o("models", nargs="+", metavar="MODEL"),
            _o("--out", required=True, metavar="DIR"),
            METHOD,
            SEED,
            SECONDS,
            FORCE,
            *ONE_WORKER,
        ],
    ),
    "symmetries": (
        "generators of the unobservable directions of each branch",
        None,
        [MODEL, FMT, _o("--degree", type=int, choices=(1, 2), default=1), SEED],
    ),
    "reparametrize": (
        "propose identifiable combinations and write the model in them",
        None,
        [
            MODEL,
            _o("-o", "--output", metavar="NEW.toml"),
            FORCE,
            SEED,
            _o("--eliminate", type=comma_names, default="", metavar="P,Q", help="parameters to normalise to 1"),
            _o("--keep", type=comma_names, default="", metavar="P,Q", help="parameters that must not be pivots"),
            _o("--name", dest="names", action="append", default=[], metavar="OLD=NEW", help="rename a symbol"),
        ],
    ),
    "identify": (
        "identify a model's parameters from measured data (or a simulated study) with a UKF/DUKF",
        "Analyse MODEL, then estimate its parameters from --data (CSV: time_s or t, one column per "
        "input and output) or a study of its [values] under --record, refined by maximum likelihood.",
        [
            MODEL,
            _o("--data", one_of=1, help="measured inputs and outputs (.csv)"),
            _o("--record", one_of=1, help=f"simulation study: a record {RECORD}"),
            _o("--table", help="branch table (for dukf)"),
            _o("--method", choices=("ukf", "dukf"), default="ukf"),
            _o(
                "--guess",
                action="append",
                nargs="+",
                default=[],
                metavar="P=V",
                help="initial guesses, several at once (--guess k=3 c=0.5), repeatable",
            ),
            _o(
                "--noise",
                action="append",
                default=[],
                metavar="NAME=RATIO",
                help="noise/signal RMS of a channel, or RATIO for all",
            ),
            _o("--passes", type=whole_number(1), default=3, help="passes over the record (default: 3)"),
            _o("--allow-unidentifiable", action="store_true", help="run despite the structural verdict"),
            _o("--hold", action="store_true", help="hold poorly informed parameters at their guess"),
            _o("--no-refine", dest="refine", action="store_false", help="skip the maximum-likelihood refinement"),
            SEED,
            *[_o(f, type=plain_number, help="default: tuned") for f in ("--s0", "--q-theta", "--q-x", "--gate")],
            _o("--samples", type=whole_number(2), help="only the first samples of a --record"),
            _o(
                "--jit",
                action=argparse.BooleanOptionalAction,
                help="compile the filter and the likelihood fit to C, or not (default: where a C compiler is on PATH)",
            ),
            _o("--replicates", type=whole_number(), default=0, help="Monte-Carlo replicates (0: off, else >= 3)"),
            INTERSAMPLE,
            _o(
                "--objective",
                choices=("output", "prediction"),
                default="output",
                help="what the likelihood fit minimises: output error of the free simulation (default) or the "
                "prediction error of a fitted constant-gain predictor (a plant that drifts, or runs in closed loop)",
            ),
            *EXECUTOR,
            _o("--out", metavar="DIR", help="write identify.json and the figures here"),
            FORCE,
        ],
    ),
    "reproduce": (
        "reproduce the seed paper's Table 2 and Figures 2-3 (analysis -> tables -> UKF and DUKF)",
        "The default folder reports/identification (/RECORD) holds the committed results and is REGENERATED; "
        "--quick writes reproduce-quick/ here; another --out is never overwritten without --force.",
        [
            _o("--quick", action="store_true", help="300 samples, 1 seed, 1 tuning seed, no Monte-Carlo (options win)"),
            _o("--record", help="another ground motion (.csv or .AT2)"),
            _o("--seeds", type=whole_number(1), help="reported noise seeds 0..K-1 (default: 5)"),
            _o("--tuning-seeds", type=whole_number(1), help="noise seeds of the tuning only (default: 5)"),
            _o("--passes", type=whole_number(1), help="passes of the refined protocol (default: 3)"),
            _o("--samples", type=whole_number(2), help="only the first samples of the record"),
            _o("--jit", action=argparse.BooleanOptionalAction, help="compile the filters to C (default)"),
            _o("--replicates", type=whole_number(), help="Monte-Carlo replicates per run (default: 32)"),
            _o("--out", help="output folder (default: reports/identification)"),
            FORCE,
            *EXECUTOR,
        ],
    ),
    "bank": (
        "run the observer-bank crack benchmark on the cantilever link",
        None,
        [
            _o("--seeds", type=whole_number(1), default=3),
            _o("--out", default="reports/bank"),
            _o("--model", help="link model file (default: obsnl:cantilever_link)"),
            FORCE,
        ],
    ),
    "sensors": (
        "which sensors make every target identifiable (minimal sets of the model's outputs)",
        None,
        [
            MODEL,
            _o("--target", default="parameters", help="parameters (default), all (states too) or names"),
            _o("--max-size", type=whole_number(1)),
            FMT4,
            *OUT,
            SEED,
            _o("--max-seconds", type=plain_number, help="of each analysis"),
            _o("--progress", action="store_true"),
            _o("--record", metavar="FILE", help=f"rank by the Cramer-Rao bound under a record {RECORD}"),
            _o("--rank-size", type=whole_number(1), help="with --record"),
            _o("--noise", type=plain_number, help="with --record (default 0.01)"),
            *ONE_WORKER,
        ],
    ),
    "design": (
        "the smallest record scale and the records that make a model identifiable",
        None,
        [
            MODEL,
            _o(
                "--record",
                action="append",
                default=[],
                metavar="FILE",
                help=f"a record {RECORD}; one at least, repeat for more",
            ),
            _o("--target", default="all"),
            _o("--sensors", metavar="a,b"),
            FMT4,
            *OUT,
            _o("--figure", metavar="FILE.png"),
            SECONDS,
            _o("--scales", metavar="S1,S2,..."),
            SEED,
            _o(
                "--intersample",
                action="append",
                default=[],
                metavar="[NAME=]KIND",
                help="an input between samples: zoh, linear or bandlimited (repeatable; a bare KIND: every input; "
                "default: the model's [intersample], else linear)",
            ),
        ],
    ),
    "validate": (
        "run a fitted model on a test record: RMSE, NRMSE, fit %% and dB",
        "Simulate MODEL at the estimates of an identify.json under the input of a test record, from "
        "rest or from the state estimated on the first --warmup samples (then not scored); write "
        "validate.json, validation.png and, for a hysteretic state z, loop.png.",
        [
            MODEL,
            _o("--params", required=True, metavar="DIR/identify.json", help="the fit to validate"),
            _o(
                "--data",
                required=True,
                metavar="TEST.csv",
                help="the test record: time_s or t, one column per input and output",
            ),
            _o(
                "--warmup",
                type=whole_number(),
                default=0,
                metavar="N",
                help="samples that estimate the initial state (not scored)",
            ),
            _o(
                "--intersample",
                action="append",
                default=[],
                metavar="[NAME=]KIND",
                help="zoh, linear or bandlimited (default: as the fit took them)",
            ),
            _o("--out", required=True, metavar="DIR"),
            FORCE,
        ],
    ),
}


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser, built from :data:`COMMANDS` (exposed for tests and documentation)."""
    from obsnl import __version__

    parser = ShortErrorParser(
        prog="obsnl", description="Observability and identifiability of nonlinear, non-smooth mechanical models."
    )
    parser.add_argument("--version", action="version", version=f"obsnl {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (short, description, options) in COMMANDS.items():
        p = sub.add_parser(name, help=short, description=description)
        group = None
        for flags, kw in options:
            one = {k: v for k, v in kw.items() if k != "one_of"}
            if "nargs" not in kw and kw.get("action") in (None, "append"):  # one value each: refused as '--'
                one["action"] = OneValue
            if kw.get("one_of"):  # one of these options is required
                if group is None:
                    group = p.add_mutually_exclusive_group(required=True)
                group.add_argument(*flags, **one)
            else:
                p.add_argument(*flags, **one)
    return parser


def _command_parser(parser: argparse.ArgumentParser, command: str) -> argparse.ArgumentParser:
    """The parser of ``command``, a subcommand of ``parser`` (its flags name the options in a message)."""
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return action.choices[command]


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit code (0 ok, 2 bad input, 1 internal error)."""
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: --help (0) or usage error (2)
        return int(exc.code or 0)
    if args.command is None:  # no command: the usage and one error line on stderr, as argparse does
        parser.print_usage(sys.stderr)
        print("obsnl: error: choose a command (obsnl --help lists them)", file=sys.stderr)
        return 2
    try:
        run_job(args)
        return 0
    except (ObsnlError, OSError) as exc:  # bad input, or the system's refusal (a name too long, a full disk)
        sub = _command_parser(parser, args.command)
        # the library names options as Python keywords (a result's reason too): this command's flags instead
        line = cli_terms(str(exc), sub) if isinstance(exc, ObsnlError) else os_error_line(exc)
        print(f"obsnl {args.command}: error: {line}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"obsnl {args.command}: interrupted", file=sys.stderr)
        return 130


def run() -> None:
    """The ``obsnl`` program: :func:`main`, then a normal exit with its code."""
    sys.exit(main())
