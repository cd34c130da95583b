"""Compiled casadi Functions cached on disk, so that a second run (or another worker) compiles nothing.

:func:`jit_compile` generates the C code of a casadi Function, names it by the hash of that code,
the compiler flags, the casadi version, the compiler (its path and ``--version`` line) and the CPU
(``platform.machine()`` with the model name and the flags of ``/proc/cpuinfo``: the code is built with
``-march=native``), and loads the shared library from a private per-user cache folder
(:func:`cache_directory`), compiling it only when it is not there. The key is the code itself: the
same model, filter options and record step give the same file, a changed model or option a new one,
and a stale library can never be loaded. The flags are those of
:func:`obsnl.estimation.numeric.jit_options` (``-O3 -march=native -ffp-contract=off``, no fast-math),
so the numbers equal those of casadi's own ``jit`` option, and those of casadi's evaluation without
compiling, bit for bit: with floating-point contraction off the compiler never fuses a product and
a sum into one rounding (an FMA), so the compiled code rounds every operation as casadi's virtual
machine does, whatever the compiler inlines.

The cache is not trusted. Each library is written under a temporary name and renamed into place
(processes that compile the same Function at once never see half-written files), and its SHA-256 is
recorded at build time in a sidecar file (``<library>.sha256``, the format of ``sha256sum``). Before a
library is loaded, it and its sidecar must be regular files of this user that nobody else may write,
and the library's hash must be the recorded one; otherwise (a truncated file, a library planted under
the expected name, a missing sidecar) it is rebuilt, never loaded. A library that still does not load
after a rebuild is an error, not a loop. A cache folder that cannot be created or written (under a
file, on a read-only file system) is replaced by a private temporary folder for this process, with a
one-line warning on stderr.

No compilation waits for ever: the compiler runs in a process group of its own, and one that has not finished a
library within :func:`compile_seconds` (``OBSNL_COMPILE_SECONDS``, default 300 s; 10 s for its ``--version``)
is killed with all it started, and is a :class:`~obsnl.errors.CompileError` (a run that did not ask for
compilation then goes on uncompiled, with one warning); later compilations in the same process are refused at
once rather than waiting again.
"""

from __future__ import annotations

import atexit
import errno
import functools
import getpass
import hashlib
import hmac
import os
import platform
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import casadi as ca

from obsnl.errors import CompileError, OutputError

__all__ = [
    "jit_compile",
    "compiler_available",
    "cache_directory",
    "FLAGS",
    "jit_options",
    "jit_directory",
    "COMPILE_SECONDS",
    "compile_seconds",
]

#: Compiler flags (as :func:`jit_options`).
FLAGS = ("-O3", "-march=native", "-ffp-contract=off")
_LOADED: dict[str, ca.Function] = {}
_FALLBACK: list[Path] = []  # this process's private folder, when the configured one cannot be used
_FIX = "remove it or set OBSNL_CACHE_DIR to a private folder"


def cache_directory() -> Path:
    """The private cache folder of compiled filters: ``$OBSNL_CACHE_DIR`` or ``~/.cache/obsnl/jit``.

    Created with mode 0700; an existing folder is used only when it is a real folder (not a
    symbolic link), owned by the user and closed to others (nobody else may plant a library that
    this process would load). A folder that cannot be created (its path runs through a file, the
    file system is read-only) gives a one-line warning and a private temporary folder of this process.

    Returns
    -------
    Path
        The folder.

    Raises
    ------
    OutputError
        The folder is a symbolic link, not a folder, owned by another user or open to others.

    Examples
    --------
    >>> cache_directory().is_dir()
    True
    """
    env = os.environ.get("OBSNL_CACHE_DIR")
    base = Path(env) if env else Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "obsnl" / "jit"
    try:
        if not base.exists() and not base.is_symlink():
            base.parent.mkdir(parents=True, exist_ok=True)
            try:
                base.mkdir(mode=0o700)
            except FileExistsError:
                pass
        st = os.lstat(base)
    except OSError as exc:
        return _fallback(f"the compiled-filter cache {base} cannot be created ({exc.strerror or exc})")
    if stat.S_ISLNK(st.st_mode):
        raise OutputError(f"the compiled-filter cache {base} is a symbolic link; {_FIX}")
    if not stat.S_ISDIR(st.st_mode):
        raise OutputError(f"the compiled-filter cache {base} is not a folder; {_FIX}")
    if hasattr(os, "getuid") and st.st_uid != os.getuid():
        raise OutputError(f"the compiled-filter cache {base} belongs to another user; {_FIX}")
    if st.st_mode & 0o077:
        raise OutputError(
            f"the compiled-filter cache {base} is open to other users (mode "
            f"{stat.S_IMODE(st.st_mode):o}); run chmod 700 on it or {_FIX}"
        )
    return base


def _fallback(why: str) -> Path:
    """A private temporary folder of this process (removed at exit), announced once on stderr."""
    if not _FALLBACK:
        try:
            folder = Path(tempfile.mkdtemp(prefix="obsnl-jit-"))  # mode 0700, a new name
        except OSError as exc:
            raise CompileError(
                f"{why}, and no temporary folder can be made ({exc.strerror or exc}); set "
                f"OBSNL_CACHE_DIR to a writable folder or run without compiling "
                f"(jit=False)"
            ) from None
        atexit.register(shutil.rmtree, folder, True)
        _FALLBACK.append(folder)
        sys.stderr.write(
            f"obsnl: warning: {why}; compiled filters go to a temporary folder for this run "
            f"(set OBSNL_CACHE_DIR to a writable folder to keep them)\n"
        )
    return _FALLBACK[0]


_COMPILERS = ("gcc", "cc", "clang")


def compiler_available() -> bool:
    """Whether a C compiler (gcc, cc or clang) is on PATH, so that code can be compiled (looked up at each call).

    Returns
    -------
    bool

    Examples
    --------
    >>> isinstance(compiler_available(), bool)
    True
    """
    return _on_path() is not None


def _on_path() -> str | None:
    """The path of the first of gcc, cc, clang on PATH, or None."""
    return next((p for p in map(shutil.which, _COMPILERS) if p), None)


def _compiler() -> str:
    path = _on_path()
    if path is None:
        raise CompileError("jit=True needs a C compiler (gcc, cc or clang) on PATH; install one or pass jit=False")
    _not_hung(path)
    return path


#: Seconds one compilation (one library) may take by default; ``OBSNL_COMPILE_SECONDS`` sets another limit.
COMPILE_SECONDS = 300.0
#: Seconds the compiler may take to say its ``--version`` (at most the compilation's limit).
_VERSION_SECONDS = 10.0
_HUNG: dict[str, str] = {}  # compilers stopped at their time limit in this process: what they did not finish


def compile_seconds() -> float:
    """Seconds one compilation may take before the compiler is stopped: ``$OBSNL_COMPILE_SECONDS`` or
    :data:`COMPILE_SECONDS`.

    Returns
    -------
    float

    Raises
    ------
    CompileError
        ``OBSNL_COMPILE_SECONDS`` is not a number of seconds above 0.

    Examples
    --------
    >>> compile_seconds() > 0
    True
    """
    text = os.environ.get("OBSNL_COMPILE_SECONDS", "").strip()
    if not text:
        return COMPILE_SECONDS
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0 < value < float("inf"):
        raise CompileError(
            f"OBSNL_COMPILE_SECONDS={text[:40]!r} is not a number of seconds above 0; set it to one "
            f"(e.g. 600) or unset it for {COMPILE_SECONDS:g} s"
        )
    return value


def _not_hung(path: str) -> None:
    """Refuse at once a compiler that was already stopped at its time limit in this process."""
    if path in _HUNG:
        raise CompileError(_stopped(path))


def _stopped(path: str) -> str:
    """The one line for a compiler stopped at its time limit (the same the first time and every later time)."""
    return (
        f"the C compiler {path} {_HUNG[path]} (stopped, and not run again by this process); set "
        f"OBSNL_COMPILE_SECONDS to allow it longer, or run without compiling (jit=False)"
    )


def _run(args: list[str], seconds: float) -> subprocess.CompletedProcess[str]:
    """``args`` run with their output captured, in a process group of their own: past ``seconds`` the whole group
    (the compiler and whatever it started: cc1, as, ld) is killed and :class:`subprocess.TimeoutExpired` raised;
    on an interrupt too, the group is killed before the exception goes on."""
    group = hasattr(os, "killpg")
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=group)
    try:
        out, err = proc.communicate(timeout=seconds)
    except BaseException:  # the time limit, or an interrupt: nothing of it may outlive this call
        try:
            if group:
                os.killpg(proc.pid, signal.SIGKILL)
            else:  # pragma: no cover - no process groups (Windows)
                proc.kill()
        except OSError:  # already gone
            pass
        try:
            proc.communicate(timeout=5.0)  # the pipes closed and the process reaped
        except subprocess.TimeoutExpired:  # pragma: no cover - a child that left the group holds the pipes
            pass
        raise
    return subprocess.CompletedProcess(args, proc.returncode, out, err)


def _compiler_identity() -> str:
    """The compiler :func:`_compiler` picks: its resolved path and the first line of its ``--version`` (computed
    once per compiler and process; ``"none"`` without a compiler, when only cached libraries can load).

    Raises
    ------
    CompileError
        The compiler did not say its version within ``_VERSION_SECONDS`` (a compiler that hangs).
    """
    path = _on_path()
    return "none" if path is None else _identity_of(path)


@functools.cache
def _identity_of(path: str) -> str:
    _not_hung(path)
    seconds = min(_VERSION_SECONDS, compile_seconds())
    try:
        proc = _run([path, "--version"], seconds)
        first = (proc.stdout or proc.stderr).splitlines()[0] if (proc.stdout or proc.stderr) else ""
    except subprocess.TimeoutExpired:
        _HUNG[path] = f"did not say its --version within {seconds:g} s"
        raise CompileError(_stopped(path)) from None
    except (OSError, subprocess.SubprocessError):
        first = ""
    return f"{os.path.realpath(path)} {first.strip()}"


@functools.cache
def _machine() -> str:
    """The CPU the libraries are built for (``-march=native``): architecture, model name and a hash
    of the CPU's feature flags (from ``/proc/cpuinfo`` where there is one)."""
    model, flags = "", ""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                key, _, value = line.partition(":")
                key = key.strip().lower()
                if key == "model name" and not model:
                    model = value.strip()
                elif key in ("flags", "features") and not flags:
                    flags = hashlib.sha256(" ".join(sorted(value.split())).encode()).hexdigest()[:16]
                if model and flags:
                    break
    except OSError:
        pass
    return f"{platform.machine()} {model or platform.processor()} {flags}"


def _sha256(path: Path) -> str:
    """SHA-256 of the regular file ``path`` (read without following a symbolic link)."""
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
    h = hashlib.sha256()
    with os.fdopen(fd, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _trusted(lib: Path, sidecar: Path) -> bool:
    """True when ``lib`` and its ``sidecar`` are regular files of this user that nobody else may write
    and the library's SHA-256 is the one the sidecar recorded when obsnl built it."""
    try:
        for p in (lib, sidecar):
            st = os.lstat(p)
            if (
                not stat.S_ISREG(st.st_mode)
                or st.st_mode & 0o022
                or (hasattr(os, "getuid") and st.st_uid != os.getuid())
            ):
                return False
        recorded = sidecar.read_text(encoding="ascii").split()
        return bool(recorded) and hmac.compare_digest(_sha256(lib), recorded[0])
    except (OSError, UnicodeDecodeError):
        return False


def _build(name: str, code: str, folder: Path, lib_name: str) -> Path:
    """Compile ``code`` into ``folder/lib_name`` with its sidecar; both written under temporary names and
    renamed into place. Returns the library."""
    cc = _compiler()
    with tempfile.TemporaryDirectory(dir=folder, prefix="build-") as tmp:
        src = Path(tmp) / f"{name}.c"
        src.write_text(code, encoding="utf-8")
        out = Path(tmp) / lib_name
        seconds = compile_seconds()
        try:
            proc = _run([cc, *FLAGS, "-fPIC", "-shared", str(src), "-o", str(out)], seconds)
        except subprocess.TimeoutExpired:  # a compiler that hangs (or a library too large for the limit)
            _HUNG[cc] = f"did not finish compiling {name} within {seconds:g} s"
            raise CompileError(_stopped(cc)) from None
        if proc.returncode != 0:
            for number in (errno.ENOSPC, errno.EDQUOT, errno.EROFS):  # the folder, not the code: fall back
                if os.strerror(number) in proc.stderr:
                    raise OSError(number, os.strerror(number), str(out))
            raise CompileError(f"the C compiler failed on {name}: {' '.join(proc.stderr.split())[:300]}")
        os.chmod(out, 0o700)
        side = Path(tmp) / f"{lib_name}.sha256"
        side.write_text(f"{_sha256(out)}  {lib_name}\n", encoding="ascii")
        os.chmod(side, 0o600)
        lib = folder / lib_name
        os.replace(out, lib)
        os.replace(side, folder / f"{lib_name}.sha256")
    return lib


def _load(name: str, lib: Path) -> ca.Function | None:
    """The Function ``name`` of the library ``lib``, or None when casadi cannot load it."""
    try:
        return ca.external(name, str(lib))
    except RuntimeError:
        return None


def jit_compile(fn: ca.Function) -> ca.Function:
    """``fn`` compiled to C and loaded from the disk cache (compiled first if it is not cached).

    A cached library is loaded only when its SHA-256 is the one recorded at build time and it and its
    record belong to this user and are closed to others; anything else is rebuilt.

    Parameters
    ----------
    fn : casadi.Function
        A casadi Function (SX or MX, not itself compiled).

    Returns
    -------
    casadi.Function
        The same function (name, inputs, outputs) evaluated by the compiled library.

    Raises
    ------
    CompileError
        No C compiler, the compiler failed or did not finish within :func:`compile_seconds`, or a freshly built
        library does not load.
    OutputError
        The cache folder is unsafe (:func:`cache_directory`).

    Examples
    --------
    >>> import casadi as ca
    >>> x = ca.SX.sym("x")
    >>> f = jit_compile(ca.Function("sq", [x], [x * x + 1.0]))
    >>> float(f(3.0))
    10.0
    """
    name = fn.name()
    gen = ca.CodeGenerator(f"{name}.c", {"with_header": False})
    gen.add(fn)
    code = gen.dump()
    version = ca.__version__  # type: ignore[attr-defined]  # casadi's stubs omit the module's __version__
    key = hashlib.sha256("\n".join([version, *FLAGS, _compiler_identity(), _machine(), code]).encode()).hexdigest()[:32]
    if key in _LOADED:
        return _LOADED[key]
    folder = cache_directory()
    lib_name = f"{name}_{key}.so"
    lib = folder / lib_name
    loaded = _load(name, lib) if _trusted(lib, folder / f"{lib_name}.sha256") else None
    if loaded is None:  # missing, tampered with, truncated or unloadable: built anew, once
        try:
            lib = _build(name, code, folder, lib_name)
        except OSError as exc:  # a cache folder that cannot be written (read-only file system)
            if folder in _FALLBACK:
                raise CompileError(
                    f"cannot compile {name} into {folder} ({exc.strerror or exc}); set "
                    f"OBSNL_CACHE_DIR to a writable folder or run without compiling"
                ) from None
            folder = _fallback(
                f"the compiled-filter cache {folder} cannot be written "
                f"({exc.strerror or errno.errorcode.get(exc.errno or 0, exc)})"
            )
            lib = _build(name, code, folder, lib_name)
        loaded = _load(name, lib)
        if loaded is None:
            raise CompileError(
                f"the library compiled for {name} ({lib}) does not load; remove the cache folder "
                f"{folder} or run without compiling (jit=False)"
            )
    _LOADED[key] = loaded
    return loaded


def jit_options() -> dict[str, Any]:
    """casadi options that compile a Function to C with the system compiler.

    ``-O3 -march=native``: the code is compiled on the machine that runs it; on the UKF step of the
    seed model this is about 1.8x faster than ``-O1`` for the same compile time (no fast-math: the
    NaN/inf guards must keep their meaning). ``-ffp-contract=off``: no product and sum fused into
    one rounding, so the compiled Function gives casadi's uncompiled numbers bit for bit (with
    contraction the last bits depended on what the compiler inlined; the cost is within the
    noise of a filter pass). The compiler's scratch files (C source, object, shared library) go to
    :func:`jit_directory`, never to the working directory.
    """
    return {
        "jit": True,
        "compiler": "shell",
        "jit_options": {"flags": list(FLAGS), "verbose": False, "directory": jit_directory()},
    }


_PRIVATE_JIT: list[str] = []  # a fresh private folder of this process, when the shared one cannot be trusted


def _private_folder(path: str) -> bool:
    """A real folder (not a symlink), owned by this user, that nobody else can read or write."""
    try:
        st = os.lstat(path)
    except OSError:
        return False
    if stat.S_ISLNK(st.st_mode) or not stat.S_ISDIR(st.st_mode):
        return False
    if hasattr(os, "getuid") and st.st_uid != os.getuid():
        return False
    return not (os.name == "posix" and st.st_mode & 0o077)


def jit_directory() -> str:
    """The directory of the JIT compiler's scratch files: one private folder per user under the system temp
    folder.

    casadi names every file uniquely and deletes it with its Function, so processes can share the
    folder; a process that is killed leaves its files there, not in the user's working directory.
    The folder is trusted only if it is a real folder (not a symlink), owned by the user, mode 0700;
    otherwise (someone planted a link or a folder there) a fresh private folder (``tempfile.mkdtemp``) is
    used for this process, so obsnl never writes or loads compiled code from a folder others control.

    Returns
    -------
    str
        The folder, ending with the path separator.

    Examples
    --------
    >>> import os, stat
    >>> d = jit_directory()
    >>> stat.S_IMODE(os.lstat(d).st_mode) & 0o077
    0
    """
    try:
        user = str(os.getuid())
    except AttributeError:  # no uid on Windows
        user = getpass.getuser()
    path = os.path.join(tempfile.gettempdir(), f"obsnl-jit-{user}")
    try:
        os.mkdir(path, 0o700)
    except FileExistsError:
        pass
    except OSError:
        path = ""
    if path and _private_folder(path):
        return path + os.sep
    if not _PRIVATE_JIT:
        _PRIVATE_JIT.append(tempfile.mkdtemp(prefix="obsnl-jit-"))  # mode 0700, new: nobody else's
    return _PRIVATE_JIT[0] + os.sep
