"""Writing a folder of analysis tables: one ``.md``, ``.tex`` and ``.json`` (branch table) per result,
``index.md`` and ``timings.md``. Nothing here runs an analysis (:func:`obsnl.batch.report_models` does).

File names come from model names, which come from files other people write: a name that is not a
plain file name (a path separator, ``..``, a leading dot, characters outside letters, digits,
``_ - .``) is refused, so every file lands inside the folder the user named.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

from obsnl.errors import OutputError
from obsnl.observability.branch_table import SCHEMA_ID
from obsnl.observability.results import AnalysisResult
from obsnl.report.tables import to_json, to_latex, to_markdown, union_text

__all__ = ["report_files", "write_tables", "timing_table"]

_SAFE_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]{0,120}$")


def timing_table(entries: Sequence[tuple[str, str, int, float]]) -> str:
    """Markdown timing table from ``(model, method, number of branches, seconds)`` rows.

    Examples
    --------
    >>> print(timing_table([("friction", "auto", 2, 0.01)]), end="")
    | Model | Method | Branches | Seconds |
    |---|---|---:|---:|
    | friction | auto | 2 | 0.010 |
    """
    lines = ["| Model | Method | Branches | Seconds |", "|---|---|---:|---:|"]
    lines += [f"| {m} | {meth} | {n} | {s:.3f} |" for m, meth, n, s in entries]
    return "\n".join(lines) + "\n"


def _index(results: Sequence[AnalysisResult]) -> str:
    lines = ["# obsnl observability reports", "", "| Model | Branches | Union over branches | Files |",
             "|---|---:|---|---|"]
    for r in results:
        files = ", ".join(f"[{ext}]({r.model}.{ext})" for ext in ("md", "tex", "json"))
        lines.append(f"| {r.model} | {len(r.branches)} | {union_text(r)} | {files} |")
    lines += ["", "Timings are in [timings.md](timings.md). The `.json` files are branch tables "
              f"(schema `{SCHEMA_ID}`), read by the DUKF."]
    return "\n".join(lines) + "\n"


def report_files(names: Sequence[str], out: str | Path) -> list[Path]:
    """The files a report of models with these names writes into ``out``.

    Parameters
    ----------
    names
        Model names (they become file names).
    out
        The report folder.

    Returns
    -------
    list of Path

    Raises
    ------
    ObsnlError
        A name that is not a plain file name, or two models with the same name.

    Examples
    --------
    >>> [p.name for p in report_files(["friction"], "out")]
    ['friction.md', 'friction.tex', 'friction.json', 'index.md', 'timings.md']
    >>> report_files(["../x"], "out")
    Traceback (most recent call last):
    ...
    obsnl.errors.OutputError: model name '../x' cannot be a file name (letters, digits, '_', '-', '.' only, not starting with '.'); rename the model
    """
    for n in names:
        if not _SAFE_NAME.match(n) or n in (".", ".."):
            raise OutputError(f"model name {n!r} cannot be a file name (letters, digits, '_', '-', '.' only, "
                             f"not starting with '.'); rename the model")
    if len(set(names)) != len(names):
        raise OutputError(f"two models share a name ({list(names)}); file names come from model names")
    out = Path(out)
    files = [out / f"{n}.{ext}" for n in names for ext in ("md", "tex", "json")]
    return files + [out / "index.md", out / "timings.md"]


def write_tables(results: Sequence[AnalysisResult], out: str | Path, *, force: bool = False) -> list[Path]:
    """Write one table per result (``.md``, ``.tex``, ``.json``), ``index.md`` and ``timings.md``.

    Parameters
    ----------
    results
        Analysis results of distinct models (each carries its model's signature).
    out
        The report folder (created if missing).
    force
        Overwrite existing files.

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    ObsnlError
        A file exists and ``force`` is False (nothing is written then), or a bad model name.
    """
    targets = report_files([r.model for r in results], out)
    existing = [str(t) for t in targets if t.exists() or t.is_symlink()]
    if existing and not force:
        raise OutputError(f"{existing[0]} exists; pass --force to overwrite the report")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    for r in results:
        (out / f"{r.model}.md").write_text(to_markdown(r), encoding="utf-8")
        (out / f"{r.model}.tex").write_text(to_latex(r), encoding="utf-8")
        (out / f"{r.model}.json").write_text(to_json(r), encoding="utf-8")
    (out / "index.md").write_text(_index(results), encoding="utf-8")
    (out / "timings.md").write_text(
        timing_table([(r.model, r.method, len(r.branches), r.seconds) for r in results]), encoding="utf-8")
    return targets
