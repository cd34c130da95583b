"""Identification renderings: the text of one identification run (``run``) and the seed paper's Table 2
analog over many runs (``table2``).

Owns how identification results read as text, Markdown and LaTeX, and how a fitted model's validation on
a new record reads and looks (``validation``). The run's text takes the run's value
(:class:`obsnl.identification.results.Identification`, read through the protocol
:class:`~obsnl.report.identification.run.IdentificationRun`); the Table 2 analog takes the reproduction's value
(:class:`obsnl.studies.seed_reproduction.Reproduction`, read through the protocol
:class:`~obsnl.report.identification.table2.Table2Document`), which a committed ``table2.json`` gives back (its
``from_dict``), so that a committed table is re-rendered without running anything.

May import: ``report.tex``, ``report.figures`` (the figures of a validation), ``_text``, ``errors``, numpy.
Must never import: ``identification``, ``studies``, ``cli`` (rooms above on the data flow: their values are
read, never imported), nor run an analysis or a filter.
"""

from obsnl.report.identification.run import IdentificationRun, identify_text
from obsnl.report.identification.table2 import table2_latex, table2_markdown, table2_ml_summary, table2_summary

__all__ = [
    "identify_text",
    "IdentificationRun",
    "table2_summary",
    "table2_ml_summary",
    "table2_markdown",
    "table2_latex",
]
