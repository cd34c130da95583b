"""commands: one door per command, the library run as one command asks.

One module per command of ``obsnl``. Each holds a frozen request value (``IdentifyRequest`` in ``identify``...)
that checks every option and resolves its inputs once, when it is made (an output folder that cannot take the
files, an option that would be ignored and a Dask scheduler that does not answer are refused before the model is
read; the model is read once), a ``run_<command>(request)`` that calls the library and returns a typed result,
and a ``<command>_printed(result)`` that is what the command line prints of it
(:class:`~obsnl.report.printed.Printed`, made from :mod:`obsnl.report`'s renderings). Each name is the command's
own, so that a reader and every tool can follow a command by its names from the command line into the library.
The command line builds the request from its parsed options and imports the module plainly; Python callers make
the same request::

    from obsnl.commands.identify import IdentifyRequest, run_identify

    result = run_identify(IdentifyRequest(model="m.toml", data="d.csv", guess=["k=3"]))

May import: ``errors``, ``executor``, ``model``, ``observability``, ``recombination``, ``estimation``,
``report``, ``identification``, ``studies``, ``design``, ``batch``. Must never import ``cli``.
"""

__all__: list[str] = []
