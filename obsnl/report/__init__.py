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

__getattr__, __dir__ = lazy_exports(__name__, globals(), _LAZY)

__all__ = [*_TABLES, *_LAZY]
