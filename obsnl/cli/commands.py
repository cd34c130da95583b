"""The one runner of every subcommand: its parsed options to its request, the request run by its command's module
of :mod:`obsnl.commands`, what the command prints printed.

Each command's module is imported plainly in :func:`printed` (one ``case`` per command) and its request is built
field by field from the parsed options (one ``_<command>`` builder each), so that a reader and every tool can follow
a command from the command line into the library; nothing is imported by a computed name."""

from __future__ import annotations

import sys
from argparse import Namespace
from pathlib import Path
from typing import TYPE_CHECKING

from obsnl.errors import AnalysisError

if TYPE_CHECKING:
    from obsnl.executor import Executor
    from obsnl.report.printed import Printed


def _regenerating(folder: Path) -> None:
    print(
        f"obsnl reproduce: regenerating the default folder {folder} (committed results); pass --out DIR or "
        "--quick to keep them",
        file=sys.stderr,
    )


def _executor(a: Namespace) -> Executor | None:
    """The executor of ``--workers``/``--scheduler`` (None for a command that has neither)."""
    if "workers" not in vars(a):
        return None
    from obsnl.executor import Executor

    return Executor(scheduler=a.scheduler, workers=a.workers)


def _show(a: Namespace) -> Printed:
    """``obsnl show``: its request built from the parsed options, run, and what it prints."""
    from obsnl.commands.show import ShowRequest, run_show, show_printed

    return show_printed(run_show(ShowRequest(model=a.model, fmt=a.fmt)))


def _branches(a: Namespace) -> Printed:
    """``obsnl branches``: its request built from the parsed options, run, and what it prints."""
    from obsnl.commands.branches import BranchesRequest, branches_printed, run_branches

    return branches_printed(run_branches(BranchesRequest(model=a.model, fmt=a.fmt, equations=a.equations)))


def _symmetries(a: Namespace) -> Printed:
    """``obsnl symmetries``: its request built from the parsed options, run, and what it prints."""
    from obsnl.commands.symmetries import SymmetriesRequest, run_symmetries, symmetries_printed

    return symmetries_printed(run_symmetries(SymmetriesRequest(model=a.model, fmt=a.fmt, degree=a.degree, seed=a.seed)))


def _analyze(a: Namespace) -> Printed:
    """``obsnl analyze``: its request built from the parsed options, run, and what it prints."""
    from obsnl.commands.analyze import AnalyzeRequest, analyze_printed, run_analyze

    return analyze_printed(
        run_analyze(
            AnalyzeRequest(
                model=a.model,
                fmt=a.fmt,
                method=a.method,
                seed=a.seed,
                max_seconds=a.max_seconds,
                branches=a.branches,
                record=a.record,
                joint=a.joint,
                unknown_input_derivatives=a.unknown_input_derivatives,
                output=a.output,
                force=a.force,
            )
        )
    )


def _report(a: Namespace) -> Printed:
    """``obsnl report``: its request built from the parsed options, run, and what it prints."""
    from obsnl.commands.report import ReportRequest, report_printed, run_report

    return report_printed(
        run_report(
            ReportRequest(
                models=a.models,
                out=a.out,
                method=a.method,
                seed=a.seed,
                max_seconds=a.max_seconds,
                force=a.force,
                executor=_executor(a),
            )
        )
    )


def _reparametrize(a: Namespace) -> Printed:
    """``obsnl reparametrize``: its request built from the parsed options, run, and what it prints."""
    from obsnl.commands.reparametrize import ReparametrizeRequest, reparametrize_printed, run_reparametrize

    return reparametrize_printed(
        run_reparametrize(
            ReparametrizeRequest(
                model=a.model,
                output=a.output,
                force=a.force,
                seed=a.seed,
                eliminate=a.eliminate,
                keep=a.keep,
                names=a.names,
            )
        )
    )


def _identify(a: Namespace) -> Printed:
    """``obsnl identify``: its request built from the parsed options, run, and what it prints."""
    from obsnl.commands.identify import IdentifyRequest, identify_printed, run_identify

    return identify_printed(
        run_identify(
            IdentifyRequest(
                model=a.model,
                data=a.data,
                record=a.record,
                table=a.table,
                method=a.method,
                guess=a.guess,
                noise=a.noise,
                passes=a.passes,
                allow_unidentifiable=a.allow_unidentifiable,
                hold=a.hold,
                refine=a.refine,
                seed=a.seed,
                s0=a.s0,
                q_theta=a.q_theta,
                q_x=a.q_x,
                gate=a.gate,
                samples=a.samples,
                jit=a.jit,
                replicates=a.replicates,
                intersample=a.intersample,
                objective=a.objective,
                executor=_executor(a),
                out=a.out,
                force=a.force,
            )
        )
    )


def _reproduce(a: Namespace) -> Printed:
    """``obsnl reproduce``: its request built from the parsed options, run, and what it prints."""
    from obsnl.commands.reproduce import ReproduceRequest, reproduce_printed, run_reproduce

    return reproduce_printed(
        run_reproduce(
            ReproduceRequest(
                quick=a.quick,
                record=a.record,
                seeds=a.seeds,
                tuning_seeds=a.tuning_seeds,
                passes=a.passes,
                samples=a.samples,
                jit=a.jit,
                replicates=a.replicates,
                out=a.out,
                force=a.force,
                executor=_executor(a),
                regenerating=_regenerating,
            )
        )
    )


def _bank(a: Namespace) -> Printed:
    """``obsnl bank``: its request built from the parsed options, run, and what it prints."""
    from obsnl.commands.bank import BankRequest, bank_printed, run_bank

    return bank_printed(run_bank(BankRequest(out=a.out, model=a.model, seeds=a.seeds, force=a.force)))


def _sensors(a: Namespace) -> Printed:
    """``obsnl sensors``: its request built from the parsed options, run, and what it prints."""
    from obsnl.commands.sensors import SensorsRequest, run_sensors, sensors_printed

    return sensors_printed(
        run_sensors(
            SensorsRequest(
                model=a.model,
                target=a.target,
                max_size=a.max_size,
                fmt=a.fmt,
                output=a.output,
                force=a.force,
                seed=a.seed,
                max_seconds=a.max_seconds,
                progress=a.progress,
                record=a.record,
                rank_size=a.rank_size,
                noise=a.noise,
                executor=_executor(a),
            )
        )
    )


def _design(a: Namespace) -> Printed:
    """``obsnl design``: its request built from the parsed options, run, and what it prints."""
    from obsnl.commands.design import DesignRequest, design_printed, run_design

    return design_printed(
        run_design(
            DesignRequest(
                model=a.model,
                records=a.record,
                target=a.target,
                sensors=a.sensors,
                fmt=a.fmt,
                output=a.output,
                force=a.force,
                figure=a.figure,
                max_seconds=a.max_seconds,
                scales=a.scales,
                seed=a.seed,
                intersample=a.intersample,
            )
        )
    )


def _validate(a: Namespace) -> Printed:
    """``obsnl validate``: its request built from the parsed options, run, and what it prints."""
    from obsnl.commands.validate import ValidateRequest, run_validate, validate_printed

    return validate_printed(
        run_validate(
            ValidateRequest(
                model=a.model,
                params=a.params,
                data=a.data,
                warmup=a.warmup,
                intersample=a.intersample,
                out=a.out,
                force=a.force,
            )
        )
    )


def printed(a: Namespace) -> Printed:
    """What the command ``a.command`` prints: its request built from the parsed options, run by its module of
    :mod:`obsnl.commands` (imported plainly, on first use: ``obsnl --help`` loads no numeric library).

    Parameters
    ----------
    a : Namespace
        The parsed options.

    Returns
    -------
    Printed

    Raises
    ------
    KeyError
        For a command that has no module (a programming error: the parser knows every command).
    """
    match a.command:
        case "show":
            return _show(a)
        case "branches":
            return _branches(a)
        case "symmetries":
            return _symmetries(a)
        case "analyze":
            return _analyze(a)
        case "report":
            return _report(a)
        case "reparametrize":
            return _reparametrize(a)
        case "identify":
            return _identify(a)
        case "reproduce":
            return _reproduce(a)
        case "bank":
            return _bank(a)
        case "sensors":
            return _sensors(a)
        case "design":
            return _design(a)
        case "validate":
            return _validate(a)
        case _:
            raise KeyError(f"no command {a.command!r}")  # a programming error: the parser knows every command


def run(a: Namespace) -> None:
    """Run the command (:func:`printed`) and print the text of the :class:`~obsnl.report.printed.Printed` it
    returns (a character UTF-8 cannot encode, a lone surrogate, as its escape); its undecided line is then said
    as an error, never passed over."""
    text, stuck = printed(a)
    if text is not None:
        sys.stdout.write(
            (text if text.endswith("\n") else text + "\n").encode("utf-8", "backslashreplace").decode("utf-8")
        )
    if stuck:
        raise AnalysisError(stuck)
