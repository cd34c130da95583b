"""Reading a document a user named (a model file, a branch table, a written result): untrusted, so only a regular
file of a bounded size is read.

A FIFO put where a file is expected would block the open, then the read, without end; a device (``/dev/zero``)
never ends; a file of gigabytes would be read into memory before any check of its content. :func:`read_document`
refuses each of them in one line, naming the file and the fix, before reading a byte. The records and measured
data, which are read line by line up to a larger bound, share :data:`FILE_KINDS` to name what they refuse.
"""

from __future__ import annotations

import os
import stat
from collections.abc import Callable
from pathlib import Path

__all__ = ["FILE_KINDS", "MAX_DOCUMENT_BYTES", "read_document"]

#: Largest document read (32 MiB): a model file or a branch table of the largest model obsnl analyses is well under
#: a megabyte; a larger file is not one.
MAX_DOCUMENT_BYTES = 32 * 2**20

#: What a path may name that is not a regular file, and how a message calls it.
FILE_KINDS: tuple[tuple[Callable[[int], bool], str], ...] = (
    (stat.S_ISFIFO, "FIFO"),
    (stat.S_ISCHR, "character device"),
    (stat.S_ISBLK, "block device"),
    (stat.S_ISSOCK, "socket"),
)


def read_document(
    path: str | os.PathLike[str],
    *,
    where: str,
    error: Callable[[str], Exception],
    fix: str,
    limit: int = MAX_DOCUMENT_BYTES,
) -> str:
    """The text of the regular file ``path``, read whole, refusing in one line what is not such a document.

    The file is opened without waiting (a FIFO put in its place between the check and the open does not block)
    and checked again once open.

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    where : str
        How messages name it (``"model file 'm.toml'"``).
    error : callable
        The error class of the caller (it takes the message).
    fix : str
        What the user should give instead, ending each message.
    limit : int
        Largest size read, in bytes.

    Returns
    -------
    str
        The text (UTF-8; a byte-order mark is kept for the caller's parser to refuse or drop).

    Raises
    ------
    Exception
        ``error(message)``: the file does not exist or cannot be opened, is a folder, a FIFO, a device or a socket,
        is over ``limit`` bytes, or is not UTF-8 text.

    Examples
    --------
    >>> read_document("/dev/null", where="model file '/dev/null'", error=ValueError, fix="give a .toml file")
    Traceback (most recent call last):
    ...
    ValueError: model file '/dev/null' is a character device, not a regular file; give a .toml file
    """
    fd = _open_regular(Path(path), where, error, fix)
    try:
        with os.fdopen(fd, "rb") as fh:
            raw = fh.read(limit + 1)
    except OSError as exc:
        raise error(f"cannot read {where}: {exc.strerror or exc}; {fix}") from None
    if len(raw) > limit:
        size = f"{limit >> 20} MiB" if limit >= 2**20 and limit % 2**20 == 0 else f"{limit:,} bytes"
        raise error(f"{where} is over {size}, too large for one; {fix}")
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{where} is not UTF-8 text (byte {exc.start}); {fix}") from None


def _open_regular(p: Path, where: str, error: Callable[[str], Exception], fix: str) -> int:
    """A descriptor of ``p`` open for reading, when it names a regular file (``error`` otherwise)."""
    try:
        st, fd = os.stat(p), None
        if stat.S_ISREG(st.st_mode):  # opened without waiting (a FIFO put in its place), then checked again
            fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
            st = os.fstat(fd)
    except FileNotFoundError:
        raise error(f"{where} does not exist; {fix}") from None
    except (OSError, ValueError) as exc:  # a name too long, no permission; ValueError: a NUL in the name
        why = (exc.strerror or exc) if isinstance(exc, OSError) else exc
        raise error(f"cannot read {where}: {why}; {fix}") from None
    if fd is not None and stat.S_ISREG(st.st_mode):
        return fd
    if fd is not None:
        os.close(fd)
    if stat.S_ISDIR(st.st_mode):
        raise error(f"{where} is a folder; {fix}")
    kind = next((name for test, name in FILE_KINDS if test(st.st_mode)), "special file")
    raise error(f"{where} is a {kind}, not a regular file; {fix}")
