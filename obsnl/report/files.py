"""Writing a folder of analysis tables: one ``.md``, ``.tex`` and ``.json`` (branch table) per result,
``index.md`` and ``timings.md``. Nothing here runs an analysis (:func:`obsnl.batch.report_models` does).

File names come from model names, which come from files other people write: a name that is not a
plain file name (a path separator, ``..``, a leading dot, characters outside letters, digits,
``_ - .``) is refused (by :func:`obsnl.report.folders.report_files`), so every file lands inside the folder the
user named.

Every command that writes goes through one writer, :class:`OutputFolder` (:func:`safe_write` for one
file): files are created exclusively in a private staging folder and moved onto their names only when
all are written; without ``--force`` a name is claimed atomically (a hard link, which fails when the
name exists), with ``--force`` a file is renamed over the old one, so a symlink or a hard-linked file
is replaced, never written through or truncated; the named folder itself is never a symlink. Only
regular files are written: a FIFO, a device or a socket at a file's name is refused even with ``--force``,
and so is a file name that names a folder (``new.toml/``).
"""

from __future__ import annotations

import errno
import os
import re
import secrets
import shutil
import stat
from collections.abc import Sequence
from pathlib import Path

from obsnl.errors import OutputError

__all__ = ["check_target", "check_folder", "safe_write", "OutputFolder"]


def check_target(path: str | Path, *, force: bool, root: str | Path | None = None) -> Path:
    """Check that ``path`` may be written: refuse what would surprise the user.

    Refused: an existing file or a symlink (even a dangling one) without ``force``; a folder; a FIFO, a
    device or a socket (even with ``force``: obsnl writes only regular files, and replacing one would break
    what reads it); a name given as text that names a folder (it ends with a path separator, ``.`` or
    ``..``, which :class:`~pathlib.Path` would drop); a parent that is a file; a ``root`` folder that is a
    symlink (even with ``force``: obsnl never writes through a link, and a link to a folder is the user's
    way of pointing elsewhere, not a file to replace); a path that leaves ``root`` (when given). Nothing
    is created.

    Parameters
    ----------
    path : str or Path
        The file to write.
    force : bool
        Allow replacing an existing file or symlink (the symlink itself is replaced, never followed; a
        file with other hard links is replaced by a new file, never written in place).
    root : str or Path or None
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
    >>> check_target("new.toml/", force=True)
    Traceback (most recent call last):
    ...
    obsnl.errors.OutputError: new.toml/ ends with '/': that names a folder, but a file is due; drop the slash
    """
    if isinstance(path, str) and (end := _FOLDER_END.search(path)) and end.group():
        fix = "drop the slash" if end.group() in _SEPS else f"name a file, not {end.group()!r}"
        raise OutputError(f"{path} ends with {end.group()!r}: that names a folder, but a file is due; {fix}")
    p = Path(path)
    if root is not None:
        base = os.path.realpath(root)
        if os.path.commonpath(
            [base, os.path.realpath(p.parent) if p.parent != Path("") else base]
        ) != base or p.name in ("", ".", ".."):
            raise OutputError(f"{p} would be written outside {root}; name a file inside the folder")
    if p.is_symlink() and not force:
        raise OutputError(
            f"{p} is a symlink; obsnl does not write through links (pass force=True to replace the link by a file)"
        )
    if p.is_dir() and not p.is_symlink():
        raise OutputError(f"{p} is a folder; name a file")
    _refuse_special(p)
    if p.exists() and not force:
        raise OutputError(f"{p} exists; pass force=True to overwrite it")
    if root is not None and Path(root).is_symlink():
        raise OutputError(
            f"{root} is a symlink; obsnl never writes through links, not even with force=True: name the "
            f"real folder ({os.path.realpath(root)}) or remove the link"
        )
    for parent in p.parents:
        if parent.exists() and not parent.is_dir():
            raise OutputError(f"{parent} is a file, not a folder; choose another output path")
    return p


#: The path separators of this system, and the end of a name that names a folder (``x/``, ``x/.``, ``..``).
_SEPS = os.sep + (os.altsep or "")
_FOLDER_END = re.compile(rf"(?:^|[{re.escape(_SEPS)}])\.{{0,2}}\Z")
#: What a name may be other than a regular file, a symlink or a folder.
_SPECIAL = (
    (stat.S_ISFIFO, "a FIFO"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def _refuse_special(path: Path, name: str | None = None, dir_fd: int | None = None) -> None:
    """Refuse ``path`` (looked at as ``name`` in the open folder ``dir_fd`` when given) if it is there and is
    neither a regular file, a symlink nor a folder: a FIFO, a device or a socket is never replaced."""
    try:
        mode = os.lstat(path if name is None else name, dir_fd=dir_fd).st_mode
    except OSError:  # missing (or unreadable: the checks that follow, or the write, say so)
        return
    if stat.S_ISREG(mode) or stat.S_ISLNK(mode) or stat.S_ISDIR(mode):
        return
    kind = next((what for test, what in _SPECIAL if test(mode)), "a special file")
    raise OutputError(
        f"{path} is {kind}, not a regular file: obsnl writes only regular files (force=True does not "
        f"replace it); choose another path"
    )


def check_folder(out: str | Path, names: Sequence[str], *, force: bool) -> Path:
    """Check, before any work, that the files ``names`` may be written into the folder ``out``.

    Every file goes through :func:`check_target` (inside ``out``, no link followed, nothing replaced
    without ``force``; ``out`` itself must not be a link), and the folder, or the nearest part of its
    path that exists, must be a folder this process may write into. Nothing is created.

    Parameters
    ----------
    out : str or Path
        The folder the user named.
    names : sequence of str
        The file names to be written there.
    force : bool
        Allow replacing existing files (and links, which are replaced, never followed).

    Returns
    -------
    Path
        ``out``.

    Raises
    ------
    OutputError
        One line naming the path and the fix (an empty ``out`` too).

    Examples
    --------
    >>> check_folder("new-folder", ["a.json"], force=False).name
    'new-folder'
    """
    if not str(out).strip():  # Path("") is the current folder: never where an empty name meant to write
        raise OutputError("out= is empty; name a folder (. for the current one)")
    folder = Path(out)
    for name in names:
        check_target(folder / name, force=force, root=folder)
    existing = next((q for q in (folder, *folder.parents) if q.exists() or q.is_symlink()), Path("."))
    if not existing.is_dir():
        raise OutputError(f"{existing} is a file, not a folder; choose another output folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise OutputError(f"cannot write into {existing} (permission denied); choose another output folder")
    return folder


_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
#: errno values of a file system without hard links (then a name is claimed by an exclusive create).
_NO_LINKS = {
    errno.EPERM,
    errno.EMLINK,
    errno.ENOSYS,
    errno.EXDEV,
    getattr(errno, "ENOTSUP", errno.EPERM),
    getattr(errno, "EOPNOTSUPP", errno.EPERM),
}


class OutputFolder:
    """The one output writer: every file of one run, written into ``out`` together or not at all.

    The files are written into a private staging folder inside ``out`` (mode 0700, a random hidden name),
    each created exclusively (``O_CREAT | O_EXCL | O_NOFOLLOW``); :meth:`commit` moves them onto their names
    only when all are written. Without ``force`` a name is claimed with a hard link, which fails when
    the name exists, so a file another run wrote meanwhile is never replaced (this run then undoes its
    own files and refuses); with ``force`` a file is renamed over the old name, which replaces a symlink
    or a hard-linked file by a new file and never writes through either. ``out`` itself is opened
    without following links. On any error, and on leaving the ``with`` block without a commit, the
    staging folder is removed, and so are the folders this run created: a full disk leaves nothing
    that blocks the rerun.

    Parameters
    ----------
    out : str or Path
        The folder (created if missing; it must not be a symlink).
    names : sequence of str
        The plain file names this run writes (checked with :func:`check_folder` first).
    force : bool
        Replace existing files (and links).
    folder_link_ok : bool
        Accept ``out`` being a symlink (only :func:`safe_write` of a file the user named, whose parent
        folder is the user's business).

    Examples
    --------
    >>> import tempfile
    >>> d = tempfile.mkdtemp()
    >>> with OutputFolder(d, ["a.md", "b.md"], force=False) as o:
    ...     o.write_text("a.md", "A")
    ...     o.write_text("b.md", "B")
    ...     [p.name for p in o.commit()]
    ['a.md', 'b.md']
    >>> sorted(os.listdir(d))
    ['a.md', 'b.md']
    """

    def __init__(self, out: str | Path, names: Sequence[str], *, force: bool, folder_link_ok: bool = False) -> None:
        self.folder, self.names, self.force = Path(out), list(names), force
        if folder_link_ok:
            for name in self.names:
                check_target(self.folder / name, force=force)
        else:
            check_folder(self.folder, self.names, force=force)
        self._made: list[Path] = []
        self._fd: int | None = None
        self._stage: str | None = None
        self._stage_fd: int | None = None
        self._follow = folder_link_ok
        self._committed = False

    def __enter__(self) -> OutputFolder:
        try:
            for q in reversed([self.folder, *self.folder.parents]):
                if not q.exists() and not q.is_symlink():
                    q.mkdir()
                    self._made.append(q)
            self._fd = os.open(self.folder, os.O_RDONLY | os.O_DIRECTORY | (0 if self._follow else _NOFOLLOW))
            for _ in range(100):
                name = f".obsnl-{secrets.token_hex(6)}"
                try:
                    os.mkdir(name, 0o700, dir_fd=self._fd)
                except FileExistsError:
                    continue
                self._stage = name
                break
            else:  # 100 random names all taken (never seen): no staging folder of our own
                raise FileExistsError(errno.EEXIST, "no free name for a staging folder")
            self._stage_fd = os.open(name, os.O_RDONLY | os.O_DIRECTORY | _NOFOLLOW, dir_fd=self._fd)
        except OSError as exc:
            self._cleanup(committed=False)
            if exc.errno == errno.ELOOP:
                raise OutputError(
                    f"{self.folder} is a symlink; obsnl never writes through links: name the real "
                    f"folder or remove the link"
                ) from None
            raise OutputError(f"cannot write into {self.folder}: {exc.strerror or exc}") from None
        return self

    def __exit__(self, *exc: object) -> None:
        self._cleanup(committed=self._committed)

    def _check(self, name: str) -> str:
        if name not in self.names or self._stage_fd is None:
            raise OutputError(f"{name!r} is not one of the files this run was checked for ({self.names})")
        return name

    def path(self, name: str) -> Path:
        """Where a writer that needs a path (matplotlib) writes the file ``name``: in the staging folder."""
        return self.staging / self._check(name)

    @property
    def staging(self) -> Path:
        """The private staging folder, for a writer that fills a folder with several of the files (only
        the files named at construction are moved in by :meth:`commit`; anything else there is dropped)."""
        if self._stage is None:
            raise OutputError("the output folder is not open; use it in a with block")
        return self.folder / self._stage

    def write_bytes(self, name: str, data: bytes) -> None:
        """Write the file ``name`` (into the staging folder: it appears under its name at :meth:`commit`)."""
        self._check(name)
        try:
            fd = os.open(name, os.O_WRONLY | os.O_CREAT | os.O_EXCL | _NOFOLLOW, 0o666, dir_fd=self._stage_fd)
            with os.fdopen(fd, "wb") as fh:
                fh.write(data)
        except OSError as exc:
            raise OutputError(
                f"cannot write {self.folder / name}: {exc.strerror or exc}; nothing was written"
            ) from None

    def write_text(self, name: str, text: str) -> None:
        """:meth:`write_bytes` of UTF-8 text."""
        self.write_bytes(name, text.encode("utf-8"))

    def commit(self) -> list[Path]:
        """Move every file onto its name (all of them: a file not written is an error); the files, in order."""
        missing = [n for n in self.names if not self._staged(n)]
        if missing:
            raise OutputError(f"{self.folder / missing[0]} was not written; nothing was written")
        for name in self.names:  # a FIFO or a device that appeared meanwhile: refused before any file is moved
            _refuse_special(self.folder / name, name, self._fd)
        done: list[str] = []
        try:
            for name in self.names:
                if self.force:
                    os.replace(name, name, src_dir_fd=self._stage_fd, dst_dir_fd=self._fd)
                else:
                    self._claim(name)
                done.append(name)
        except FileExistsError:
            self._undo(done)
            raise OutputError(
                f"{self.folder / name} appeared while this run was writing (another run into the same "
                f"folder?); nothing was written: pass force=True to replace it or choose another "
                f"folder"
            ) from None
        except OSError as exc:
            self._undo(done)
            raise OutputError(f"cannot write {self.folder / name}: {exc.strerror or exc}") from None
        self._committed = True
        return [self.folder / n for n in self.names]

    def _staged(self, name: str) -> bool:
        try:
            return stat.S_ISREG(os.stat(name, dir_fd=self._stage_fd, follow_symlinks=False).st_mode)
        except OSError:
            return False

    def _claim(self, name: str) -> None:
        """Give the staged file ``name`` its name in the folder unless the name exists (atomic)."""
        try:
            os.link(name, name, src_dir_fd=self._stage_fd, dst_dir_fd=self._fd, follow_symlinks=False)
        except OSError as exc:
            if exc.errno not in _NO_LINKS:
                raise
            os.close(os.open(name, os.O_WRONLY | os.O_CREAT | os.O_EXCL | _NOFOLLOW, 0o600, dir_fd=self._fd))
            os.replace(name, name, src_dir_fd=self._stage_fd, dst_dir_fd=self._fd)

    def _undo(self, done: Sequence[str]) -> None:
        """Remove the files this run already moved in (only while they are still this run's)."""
        if self.force:
            return
        for name in done:
            try:
                ours = os.stat(name, dir_fd=self._stage_fd, follow_symlinks=False)
                there = os.stat(name, dir_fd=self._fd, follow_symlinks=False)
                if (ours.st_ino, ours.st_dev) == (there.st_ino, there.st_dev):
                    os.unlink(name, dir_fd=self._fd)
            except OSError:
                pass

    def _cleanup(self, *, committed: bool) -> None:
        if self._stage is not None and self._fd is not None:
            shutil.rmtree(self._stage, ignore_errors=True, dir_fd=self._fd)
        for fd in (self._stage_fd, self._fd):
            if fd is not None:
                os.close(fd)
        self._stage = self._stage_fd = self._fd = None
        if not committed:
            for q in reversed(self._made):
                try:
                    q.rmdir()
                except OSError:
                    break
        self._made = []


def safe_write(path: str | Path, text: str, *, force: bool, root: str | Path | None = None) -> Path:
    """Write one file through :class:`OutputFolder`: checked with :func:`check_target`, created
    exclusively, moved onto ``path`` atomically; a symlink or a hard-linked file at ``path`` is replaced
    (with ``force``), never written through, and without ``force`` a file that appears meanwhile is kept.

    Parameters
    ----------
    path : str or Path
        As :func:`check_target`.
    force : bool
        As :func:`check_target`.
    root : str or Path or None
        As :func:`check_target` (the folder the user named; without it the parent folder of ``path`` may be
        a link, the user named the file).
    text : str
        UTF-8 text.

    Returns
    -------
    Path
        The file written.

    Raises
    ------
    OutputError
        As :func:`check_target`, or the file cannot be written (nothing is left behind then).
    """
    p = check_target(path, force=force, root=root)
    parent = p.parent if p.parent != Path("") else Path(".")
    with OutputFolder(parent, [p.name], force=force, folder_link_ok=root is None) as out:
        out.write_text(p.name, text)
        out.commit()
    return p
