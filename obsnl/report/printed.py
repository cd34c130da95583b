"""What a command prints: its rendering (or the file it went to instead), the one line that names an undecided
answer, and the line that says which files it wrote.

Each command (:mod:`obsnl.commands`) says what it prints of its result as a :class:`Printed`; ``obsnl`` prints its
text and, when there is one, says its undecided line on standard error with exit code 2: an undecided answer is never
passed over.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import NamedTuple

__all__ = [
    "Printed",
    "printed",
    "STRUCTURE_FORMATS",
    "check_format",
    "check_rendering_target",
    "write_rendering",
    "written_line",
]


class Printed(NamedTuple):
    """What a job prints: its text (None when it went to a file instead) and the one line that names an
    undecided answer (None when every answer was decided)."""

    text: str | None
    undecided: str | None = None


def printed(
    text: str, output: str | Path | None = None, *, force: bool = False, undecided: str | None = None
) -> Printed:
    """A rendering for standard output, or written to the file ``output`` with a final newline.

    Parameters
    ----------
    text : str
        The rendering.
    output : str, Path or None
        A file, written through :func:`obsnl.report.files.safe_write`; None or ``"-"``: standard output
        (the text is returned).
    force : bool
        Overwrite ``output``.
    undecided : str or None
        The line that names an undecided answer.

    Returns
    -------
    Printed

    Examples
    --------
    >>> printed("2 branches", "-", undecided="branch (b) is inconclusive: timeout")
    Printed(text='2 branches', undecided='branch (b) is inconclusive: timeout')
    """
    written = write_rendering(text, output, force=force)
    return Printed(text if written is None else None, undecided)


#: The formats of the renderings of a model's structure (``obsnl show``, ``branches``, ``symmetries``).
STRUCTURE_FORMATS = ("text", "json")


def check_format(fmt: object, formats: Sequence[str]) -> None:
    """Refuse, before any work, a format the command does not render.

    Parameters
    ----------
    fmt : object
        The format asked for.
    formats : sequence of str
        The command's formats.

    Raises
    ------
    OptionError
        ``fmt`` is not one of them.

    Examples
    --------
    >>> check_format("md", ("text", "md")) is None
    True
    """
    if fmt not in formats:
        from obsnl._text import quote
        from obsnl.errors import OptionError

        raise OptionError(f"unknown format {quote(fmt, 30)}; formats are {', '.join(formats)}")


def check_rendering_target(output: str | Path | None, *, force: bool = False) -> None:
    """Refuse, before any work, a file a rendering is to be written to (:func:`write_rendering`) that cannot be
    written.

    Parameters
    ----------
    output : str, Path or None
        The file (None or ``"-"``: standard output).
    force : bool
        Whether it may be overwritten.

    Raises
    ------
    OptionError
        An empty name (else the work runs, then ``"."`` is refused as a folder).
    OutputError
        A file that exists without ``force``, a folder, a link (:func:`obsnl.report.files.check_target`).

    Examples
    --------
    >>> check_rendering_target("-") is None
    True
    """
    if output is not None and not str(output).strip():
        from obsnl.errors import OptionError

        raise OptionError("the output file name is empty; name a file, or - for standard output")
    if output and output != "-":
        from obsnl.report.files import check_target

        check_target(output, force=force)


def write_rendering(text: str, output: str | Path | None, *, force: bool = False) -> Path | None:
    """Write a rendering to the file ``output`` with a final newline; None or ``"-"``: nothing is written.

    Parameters
    ----------
    text : str
        The rendering.
    output : str, Path or None
        A file, written through :func:`obsnl.report.files.safe_write`; None or ``"-"``: standard output.
    force : bool
        Overwrite ``output``.

    Returns
    -------
    Path or None
        The file written, None when the text goes to standard output.

    Examples
    --------
    >>> write_rendering("2 branches", "-") is None
    True
    """
    if output is None or output == "-":
        return None
    from obsnl.report.files import safe_write

    return safe_write(output, text if text.endswith("\n") else text + "\n", force=force)


def written_line(files: Sequence[Path], folder: str | Path | None = None) -> str:
    """The line that says which files a job wrote: their paths, or their number and names in ``folder``.

    Parameters
    ----------
    files : sequence of Path
        The files written.
    folder : str, Path or None
        The folder they were written to (None: each path in full).

    Returns
    -------
    str

    Examples
    --------
    >>> written_line([Path("out/a.json"), Path("out/b.png")], "out")
    'wrote 2 files to out: a.json, b.png'
    >>> written_line([Path("a.json")])
    'wrote a.json'
    """
    if folder is None:
        return f"wrote {', '.join(str(f) for f in files)}"
    return f"wrote {len(files)} files to {folder}: " + ", ".join(f.name for f in files)
