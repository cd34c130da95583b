"""Compiled casadi Functions cached on disk, so that a second run (or another worker) compiles nothing.

:func:`jit_compile` generates the C code of a casadi Function, names it by the hash of that code,
the compiler flags and the casadi version, and loads the shared library from a private per-user
cache folder (:func:`cache_directory`), compiling it only when it is not there. The key is the code
itself: the same model, filter options and record step give the same file, a changed model or
option a new one, and a stale library can never be loaded. The flags are those of
:func:`obsnl.estimation.numeric.jit_options` (``-O3 -march=native -ffp-contract=off``, no fast-math),
so the numbers equal those of casadi's own ``jit`` option, and those of casadi's evaluation without
compiling, bit for bit: with floating-point contraction off the compiler never fuses a product and
a sum into one rounding (an FMA), so the compiled code rounds every operation as casadi's virtual
machine does, whatever the compiler inlines. A library is written under a temporary name and renamed
into place, so processes that compile the same Function at once do not see half-written files.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import stat
import subprocess
import tempfile
from pathlib import Path

import casadi as ca

from obsnl.errors import EstimatorError, OutputError

__all__ = ["jit_compile", "cache_directory", "FLAGS"]

#: Compiler flags (as :func:`obsnl.estimation.numeric.jit_options`).
FLAGS = ("-O3", "-march=native", "-ffp-contract=off")
_LOADED: dict[str, ca.Function] = {}


def cache_directory() -> Path:
    """The private cache folder of compiled filters: ``$OBSNL_CACHE_DIR`` or ``~/.cache/obsnl/jit``.

    Created with mode 0700; an existing folder is used only when it is a real folder (not a
    symbolic link), owned by the user and closed to others (nobody else may plant a library that
    this process would load).

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
    if not base.exists() and not base.is_symlink():
        base.parent.mkdir(parents=True, exist_ok=True)
        try:
            base.mkdir(mode=0o700)
        except FileExistsError:
            pass
    st = os.lstat(base)
    fix = "remove it or set OBSNL_CACHE_DIR to a private folder"
    if stat.S_ISLNK(st.st_mode):
        raise OutputError(f"the compiled-filter cache {base} is a symbolic link; {fix}")
    if not stat.S_ISDIR(st.st_mode):
        raise OutputError(f"the compiled-filter cache {base} is not a folder; {fix}")
    if hasattr(os, "getuid") and st.st_uid != os.getuid():
        raise OutputError(f"the compiled-filter cache {base} belongs to another user; {fix}")
    if st.st_mode & 0o077:
        raise OutputError(f"the compiled-filter cache {base} is open to other users (mode "
                          f"{stat.S_IMODE(st.st_mode):o}); run chmod 700 on it or {fix}")
    return base


def _compiler() -> str:
    for cc in ("gcc", "cc", "clang"):
        if shutil.which(cc):
            return cc
    raise EstimatorError("jit=True needs a C compiler (gcc, cc or clang) on PATH; install one or pass jit=False")


def jit_compile(fn: ca.Function) -> ca.Function:
    """``fn`` compiled to C and loaded from the disk cache (compiled first if it is not cached).

    Parameters
    ----------
    fn
        A casadi Function (SX or MX, not itself compiled).

    Returns
    -------
    casadi.Function
        The same function (name, inputs, outputs) evaluated by the compiled library.

    Raises
    ------
    EstimatorError
        No C compiler, or the compiler failed.
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
    key = hashlib.sha256("\n".join([ca.__version__, *FLAGS, code]).encode()).hexdigest()[:32]
    if key in _LOADED:
        return _LOADED[key]
    folder = cache_directory()
    lib = folder / f"{name}_{key}.so"
    if not lib.exists():
        with tempfile.TemporaryDirectory(dir=folder, prefix="build-") as tmp:
            src = Path(tmp) / f"{name}.c"
            src.write_text(code, encoding="utf-8")
            out = Path(tmp) / lib.name
            proc = subprocess.run([_compiler(), *FLAGS, "-fPIC", "-shared", str(src), "-o", str(out)],
                                  capture_output=True, text=True)
            if proc.returncode != 0:
                raise EstimatorError(f"the C compiler failed on {name}: {proc.stderr.strip()[:300]}")
            os.chmod(out, 0o700)
            os.replace(out, lib)
    _LOADED[key] = ca.external(name, str(lib))
    return _LOADED[key]
