"""The report folder of analysed models: one table per model in every format, an index and the timings,
written through :class:`~obsnl.report.files.OutputFolder`.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

from obsnl.errors import OutputError
from obsnl.observability.contract.branch_table import SCHEMA_ID
from obsnl.observability.results import AnalysisResult
from obsnl.report.files import OutputFolder, check_folder
from obsnl.report.tables import joint_text, to_json, to_latex, to_markdown, union_text

__all__ = ["report_files", "write_tables", "timing_table", "tables_written_line"]

#: A model name that may become a file name (:func:`report_files`): letters, digits, ``_``, ``-`` and ``.``, not
#: starting with ``.`` or ``-``, at most 121 characters.
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
    lines = [
        "# obsnl observability reports",
        "",
        "| Model | Joint verdict | Branches | Union over branches (each on its own) | Files |",
        "|---|---|---:|---|---|",
    ]
    for r in results:
        files = ", ".join(f"[{ext}]({r.model}.{ext})" for ext in ("md", "tex", "json"))
        lines.append(f"| {r.model} | {joint_text(r)} | {len(r.branches)} | {union_text(r)} | {files} |")
    lines += [
        "",
        "Timings are in [timings.md](timings.md). The `.json` files are branch tables "
        f"(schema `{SCHEMA_ID}`), read by the DUKF.",
    ]
    return "\n".join(lines) + "\n"


def report_files(names: Sequence[str], out: str | Path) -> list[Path]:
    """The files a report of models with these names writes into ``out``.

    Parameters
    ----------
    names : sequence of str
        Model names (they become file names).
    out : str or Path
        The report folder.

    Returns
    -------
    list of Path

    Raises
    ------
    ObsnlError
        A name that is not a plain file name, two models with the same name, or a name whose table
        would overwrite ``index.md`` or ``timings.md``.

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
            raise OutputError(
                f"model name {n!r} cannot be a file name (letters, digits, '_', '-', '.' only, "
                f"not starting with '.'); rename the model"
            )
    if len(set(names)) != len(names):
        raise OutputError(f"two models share a name ({list(names)}); file names come from model names")
    for n in names:  # index.md and timings.md are the report's own
        if n.lower() in ("index", "timings"):
            raise OutputError(f"model name {n!r} would overwrite the report's own {n.lower()}.md; rename the model")
    out = Path(out)
    files = [out / f"{n}.{ext}" for n in names for ext in ("md", "tex", "json")]
    return files + [out / "index.md", out / "timings.md"]


def write_tables(results: Sequence[AnalysisResult], out: str | Path, *, force: bool = False) -> list[Path]:
    """Write one table per result (``.md``, ``.tex``, ``.json``), ``index.md`` and ``timings.md``.

    Parameters
    ----------
    results : sequence of AnalysisResult
        Analysis results of distinct models (each carries its model's signature).
    out : str or Path
        The report folder (created if missing).
    force : bool
        Overwrite existing files.

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    ObsnlError
        A file exists and ``force`` is False (nothing is written then), or a bad model name; a file that
        cannot be written (a full disk) leaves none of the others (:class:`OutputFolder`).
    """
    targets = report_files([r.model for r in results], out)
    check_folder(out, [t.name for t in targets], force=force)  # every file checked before any is written
    texts = []
    for r in results:  # everything rendered before anything is written: a rendering error leaves no folder
        texts += [to_markdown(r), to_latex(r), to_json(r)]
    texts += [_index(results), timing_table([(r.model, r.method, len(r.branches), r.seconds) for r in results])]
    with OutputFolder(out, [t.name for t in targets], force=force) as folder:
        for t, text in zip(targets, texts):
            folder.write_text(t.name, text)
        return folder.commit()


def tables_written_line(count: int, out: str | Path) -> str:
    """The line that says what :func:`write_tables` wrote for ``count`` models into the folder ``out``.

    Parameters
    ----------
    count : int
        The models whose tables were written.
    out : str or Path
        The folder.

    Returns
    -------
    str

    Examples
    --------
    >>> tables_written_line(2, "tables")
    'wrote 2 table(s) with index.md and timings.md to tables'
    """
    return f"wrote {count} table(s) with index.md and timings.md to {out}"
