"""Every rendering of obsnl's results: analysis tables (text, Markdown, LaTeX, JSON), the observer-bank
table, the identification tables and the figures. Nothing here runs an analysis."""

from obsnl.report.tables import *  # noqa: F401,F403
from obsnl.report.tables import __all__  # noqa: F401

from obsnl.observability.results import DISPLAY as _DISPLAY
from obsnl.report.tables import to_latex as _to_latex, to_markdown as _to_markdown

_DISPLAY.setdefault("md", _to_markdown)
_DISPLAY.setdefault("tex", lambda result: _to_latex(result, environment=False))
