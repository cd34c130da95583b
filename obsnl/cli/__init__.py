"""The ``obsnl`` command line: thin argparse dispatch onto the public API.

Exit codes: 0 success, 2 bad input (one line on stderr, no traceback), 1 an internal error.
Each subcommand is one ``_cmd_*`` function plus its ``_add_*`` parser builder: the analysis side in
:mod:`obsnl.cli.analysis`, identification and the studies in :mod:`obsnl.cli.estimation`, what they
share in :mod:`obsnl.cli.common`.
"""

from __future__ import annotations

import argparse
import atexit
import os
import sys
from collections.abc import Sequence

from obsnl.cli.analysis import _add_show, _add_branches, _add_analyze, _add_report, _add_symmetries, _add_reparametrize
from obsnl.cli.common import _Exit, write_output
from obsnl.cli.estimation import _add_bank, _add_identify, _add_reproduce
from obsnl.cli.experiment import _add_design
from obsnl.cli.sensors import _add_sensors
from obsnl.errors import ObsnlError

__all__ = ["main", "run", "build_parser", "write_output"]


_BUILDERS = [_add_show, _add_branches, _add_analyze, _add_report, _add_symmetries, _add_reparametrize,
             _add_identify, _add_reproduce, _add_bank, _add_sensors, _add_design]


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser (exposed for tests and documentation)."""
    parser = argparse.ArgumentParser(
        prog="obsnl",
        description="Observability and identifiability of nonlinear, non-smooth mechanical models.",
    )
    from obsnl import __version__

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
    if not getattr(args, "func", None):  # no command: the usage and one error line on stderr, as argparse does
        parser.print_usage(sys.stderr)
        print("obsnl: error: choose a command (obsnl --help lists them)", file=sys.stderr)
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


def run() -> None:
    """The ``obsnl`` program: :func:`main`, then exit without tearing the interpreter down.

    Freeing the objects that importing sympy made, one by one, is about a sixth of the wall time of
    a small analysis (0.15 s). By the time :func:`main` returns every file it wrote is closed and
    its worker pools and Dask clients are shut down (they live in ``with`` blocks); the ``atexit``
    handlers still run and the standard streams are flushed, so nothing but the freeing is skipped.
    """
    code = main()
    try:
        atexit._run_exitfuncs()  # what a normal exit runs first (CPython)
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):  # a closed pipe: nothing more can reach it
                pass
        os._exit(code)


if __name__ == "__main__":  # pragma: no cover
    run()


