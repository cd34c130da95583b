"""commands: one door per command, the library run as one command asks.

One module per command of ``obsnl``, and ``inputs``: the kinds of file option every request checks and a record as
a model's one known input, which the file commands share. Each command's module holds a frozen request value
(``IdentifyRequest`` in ``identify``...) that checks every option and resolves its inputs once, when it is made (an output folder that cannot take the
files, an option that would be ignored and a Dask scheduler that does not answer are refused before the model is
read; the model is read once), a ``run_<command>(request)`` that calls the library and returns a typed result,
and a ``<command>_printed(result)`` that is what the command line prints of it
(:class:`~obsnl.report.printed.Printed`, made from :mod:`obsnl.report`'s renderings). Each name is the command's
own, so that a reader and every tool can follow a command by its names from the command line into the library.
The command line builds the request from its parsed options and imports the module plainly; Python callers make
the same request::

    from obsnl.commands.identify import IdentifyRequest, run_identify

    result = run_identify(IdentifyRequest(model="m.toml", data="d.csv", guess=["k=3"]))

May import: ``errors``, ``_exports``, ``executor``, ``model``, ``observability``, ``recombination``, ``estimation``,
``report``, ``identification``, ``studies``, ``design``, ``batch``. Must never import ``cli``.
"""

from typing import TYPE_CHECKING

from obsnl._exports import lazy_exports

#: The room's public names, each imported from the module that defines it on first use (so that importing
#: one command loads no other): name -> module.
_LAZY: dict[str, str] = {
    "ShowRequest": "show",
    "run_show": "show",
    "BranchesRequest": "branches",
    "run_branches": "branches",
    "SymmetriesRequest": "symmetries",
    "run_symmetries": "symmetries",
    "AnalyzeRequest": "analyze",
    "run_analyze": "analyze",
    "SensorsRequest": "sensors",
    "run_sensors": "sensors",
    "DesignRequest": "design",
    "run_design": "design",
    "ReportRequest": "report",
    "run_report": "report",
    "ValidateRequest": "validate",
    "run_validate": "validate",
    "IdentifyRequest": "identify",
    "run_identify": "identify",
    "ReproduceRequest": "reproduce",
    "run_reproduce": "reproduce",
    "BankRequest": "bank",
    "run_bank": "bank",
    "ReparametrizeRequest": "reparametrize",
    "run_reparametrize": "reparametrize",
}

if TYPE_CHECKING:  # the public names as type checkers see them; at run time each loads on first use (_LAZY)
    from obsnl.commands.analyze import AnalyzeRequest as AnalyzeRequest
    from obsnl.commands.analyze import run_analyze as run_analyze
    from obsnl.commands.bank import BankRequest as BankRequest
    from obsnl.commands.bank import run_bank as run_bank
    from obsnl.commands.branches import BranchesRequest as BranchesRequest
    from obsnl.commands.branches import run_branches as run_branches
    from obsnl.commands.design import DesignRequest as DesignRequest
    from obsnl.commands.design import run_design as run_design
    from obsnl.commands.identify import IdentifyRequest as IdentifyRequest
    from obsnl.commands.identify import run_identify as run_identify
    from obsnl.commands.reparametrize import ReparametrizeRequest as ReparametrizeRequest
    from obsnl.commands.reparametrize import run_reparametrize as run_reparametrize
    from obsnl.commands.report import ReportRequest as ReportRequest
    from obsnl.commands.report import run_report as run_report
    from obsnl.commands.reproduce import ReproduceRequest as ReproduceRequest
    from obsnl.commands.reproduce import run_reproduce as run_reproduce
    from obsnl.commands.sensors import SensorsRequest as SensorsRequest
    from obsnl.commands.sensors import run_sensors as run_sensors
    from obsnl.commands.show import ShowRequest as ShowRequest
    from obsnl.commands.show import run_show as run_show
    from obsnl.commands.symmetries import SymmetriesRequest as SymmetriesRequest
    from obsnl.commands.symmetries import run_symmetries as run_symmetries
    from obsnl.commands.validate import ValidateRequest as ValidateRequest
    from obsnl.commands.validate import run_validate as run_validate

__all__ = list(_LAZY)


__getattr__, __dir__ = lazy_exports(__name__, globals(), _LAZY)
