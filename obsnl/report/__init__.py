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

from typing import TYPE_CHECKING

from obsnl._exports import lazy_exports
from obsnl.report.tables import *  # noqa: F403
from obsnl.report.tables import __all__ as _TABLES

# The tables load with the room (a result's display needs them); the rest on first use, so that rendering one
# analysis loads neither the report folders' writer nor the bank's and Table 2's renderers: name -> module.
_LAZY: dict[str, str] = {
    "BranchGroup": "groups",
    "branch_groups": "groups",
    "tex_escape": "tex",
    "bank_table_markdown": "bank",
    "report_files": "folders",
    "timing_table": "folders",
    "write_tables": "folders",
    "table2_latex": "identification",
    "table2_markdown": "identification",
    "table2_summary": "identification",
}

if TYPE_CHECKING:  # the public names as type checkers see them; at run time each loads on first use (_LAZY)
    from obsnl.report.bank import bank_table_markdown as bank_table_markdown
    from obsnl.report.folders import report_files as report_files
    from obsnl.report.folders import timing_table as timing_table
    from obsnl.report.folders import write_tables as write_tables
    from obsnl.report.groups import BranchGroup as BranchGroup
    from obsnl.report.groups import branch_groups as branch_groups
    from obsnl.report.identification import table2_latex as table2_latex
    from obsnl.report.identification import table2_markdown as table2_markdown
    from obsnl.report.identification import table2_summary as table2_summary
    from obsnl.report.tex import tex_escape as tex_escape

__getattr__, __dir__ = lazy_exports(__name__, globals(), _LAZY)

__all__ = [*_TABLES, *_LAZY]
