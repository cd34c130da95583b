"""Writing a folder of analysis tables: one ``.md``, ``.tex`` and ``.json`` (branch table) per result,
``index.md`` and ``timings.md``. Nothing here runs an analysis (:func:`obsnl.batch.report_models` does).

File names come from model names, which come from files other people write: a name that is not a
plain file name (a path separator, ``..``, a leading dot, characters outside letters, digits,
``_ - .``) is refused, so every file lands inside the folder the user named.
"""

from __future__ import annotations

import os
import re
from collections.abc import Sequence
from pathlib import Path

from obsnl.errors import OutputError
from obsnl.observability.branch_table import SCHEMA_ID
from obsnl.observability.results import AnalysisResult
from obsnl.report.tables import to_json, to_latex, to_markdown, union_text

__all__ = ["report_files", "write_tables", "timing_table", "check_target", "check_folder", "safe_write"]

_SAFE_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]{0,120}$")


def check_target(path: str | Path, *, force: bool, root: str | Path | None = None) -> Path:
    """Check that ``path`` may be written: refuse what would surprise the user.

    Refused: an existing file or a symlink (even a dangling one) without ``force``; a folder; a parent
    that is a file; a parent folder that is a symlink without ``force``; a path that leaves ``root``
    (when given). Nothing is created.

    Parameters
    ----------
    path
        The file to write.
    force
        Allow replacing an existing file or symlink (the symlink itself is replaced, never followed).
    root
        The folder the user named; ``path`` must stay inside it.

    Returns
    -------
    Path

    Raises
    ------
    OutputError
        One line naming the path and the fix.

    Examples
    --------
    >>> check_target("out/x.md", force=False, root="out").name
    'x.md'
    >>> check_target("out/../x.md", force=False, root="out")
    Traceback (most recent call last):
    ...
    obsnl.errors.OutputError: out/../x.md would be written outside out; name a file inside the folder
    """
    p = Path(path)
    if root is not None:
        base = os.path.realpath(root)
        if os.path.commonpath([base, os.path.realpath(p.parent) if p.parent != Path("") else base]) != base or \
                p.name in ("", ".", ".."):
            raise OutputError(f"{p} would be written outside {root}; name a file inside the folder")
    if p.is_symlink() and not force:
        raise OutputError(f"{p} is a symlink; obsnl does not write through links (pass --force to replace the "
                          f"link by a file)")
    if p.is_dir() and not p.is_symlink():
        raise OutputError(f"{p} is a folder; name a file")
    if p.exists() and not force:
        raise OutputError(f"{p} exists; pass --force to overwrite it")
    if root is not None and Path(root).is_symlink() and not force:
        raise OutputError(f"{root} is a symlink; obsnl does not write through links (pass --force or name the "
                          f"real folder)")
    for parent in p.parents:
        if parent.exists() and not parent.is_dir():
            raise OutputError(f"{parent} is a file, not a folder; choose another output path")
    return p


def check_folder(out: str | Path, names: Sequence[str], *, force: bool) -> Path:
    """Check, before any work, that the files ``names`` may be written into the folder ``out``.

    Every file goes through :func:`check_target` (inside ``out``, no link followed, nothing replaced
    without ``force``), and the folder, or the nearest part of its path that exists, must be a folder
    this process may write into. Nothing is created.

    Parameters
    ----------
    out
        The folder the user named.
    names
        The file names to be written there.
    force
        Allow replacing existing files (and links, which are replaced, never followed).

    Returns
    -------
    Path
        ``out``.

    Raises
    ------
    OutputError
        One line naming the path and the fix.

    Examples
    --------
    >>> check_folder("new-folder", ["a.json"], force=False).name
    'new-folder'
    """
    folder = Path(out)
    for name in names:
        check_target(folder / name, force=force, root=folder)
    existing = next((q for q in (folder, *folder.parents) if q.exists() or q.is_symlink()), Path("."))
    if not existing.is_dir():
        raise OutputError(f"{existing} is a file, not a folder; choose another output folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise OutputError(f"cannot write into {existing} (permission denied); choose another output folder")
    return folder


def safe_write(path: str | Path, text: str, *, force: bool, root: str | Path | None = None) -> Path:
    """Write ``text`` to ``path`` after :func:`check_target`; a symlink at ``path`` is replaced, never followed.

    Parameters
    ----------
    path, force, root
        As :func:`check_target`.
    text
        UTF-8 text.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    OutputError
        As :func:`check_target`, or the file cannot be written.
    """
    p = check_target(path, force=force, root=root)
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        if p.is_symlink():
            p.unlink()
        flags = os.O_WRONLY | os.O_CREAT | os.O_TRUNC | getattr(os, "O_NOFOLLOW", 0)
        fd = os.open(p, flags, 0o666)
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
            fh.write(text)
    except OSError as exc:
        raise OutputError(f"cannot write {p}: {exc.strerror or exc}") from None
    return p


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
            raise OutputError(f"model name {n!r} cannot be a file name (letters, digits, '_', '-', '.' only, "
                             f"not starting with '.'); rename the model")
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
    for t in targets:  # every file checked before any is written
        check_target(t, force=force, root=out)
    texts = []
    for r in results:  # everything rendered before anything is written: a rendering error leaves no folder
        texts += [to_markdown(r), to_latex(r), to_json(r)]
    texts += [_index(results), timing_table([(r.model, r.method, len(r.branches), r.seconds) for r in results])]
    for t, text in zip(targets, texts):
        safe_write(t, text, force=force, root=out)
    return targets
