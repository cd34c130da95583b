"""report: every rendering of obsnl's results, and the one writer of files.

Owns the analysis tables in text, Markdown, LaTeX and JSON (``tables``, ``groups``, ``sentences``, ``tex``),
the renderings of a model's structure (``structure``), of sensor sets (``sensors``) and of experiment designs
(``experiment``), the observer-bank table (``bank``), the identification run and Table 2
(``identification``), the figures (``figures``), the report folders (``folders``) and the output writer that
never follows a link (``files``). Nothing here runs an analysis or a filter: renderers take result values.

May import: ``errors``, ``_text``, ``model``, ``observability``, ``linear``.
Must never import: ``algebra``, ``recombination``, ``estimation``, ``identification``, ``studies``,
``design``, ``batch``, ``cli``.
"""

from obsnl.observability.results import DISPLAY as _DISPLAY
from obsnl.report.bank import bank_table_markdown
from obsnl.report.folders import report_files, timing_table, write_tables
from obsnl.report.groups import BranchGroup, branch_groups
from obsnl.report.identification import table2_latex, table2_markdown, table2_summary
from obsnl.report.tables import *  # noqa: F403
from obsnl.report.tables import __all__ as _TABLES
from obsnl.report.tables import to_latex as _to_latex
from obsnl.report.tables import to_markdown as _to_markdown
from obsnl.report.tex import tex_escape

__all__ = [*_TABLES, "BranchGroup", "branch_groups", "tex_escape", "bank_table_markdown", "report_files",
           "timing_table", "write_tables", "table2_latex", "table2_markdown", "table2_summary"]

_DISPLAY.setdefault("md", _to_markdown)
_DISPLAY.setdefault("tex", lambda result: _to_latex(result, environment=False))
