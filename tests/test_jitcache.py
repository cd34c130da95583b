"""The disk cache of compiled casadi Functions: same numbers as casadi's own jit, nothing compiled
twice, and a cache folder that another user could tamper with is refused.

The cache is verified, never trusted (issue 26, item 7): a truncated, planted or world-writable library is rebuilt,
never loaded; the key names the CPU and the compiler; a cache folder under a file, on a read-only or on a full file
system falls back to a private temporary folder with one warning line; a planted or world-writable JIT folder is
not used. Each of those tests failed before its fix.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from obsnl.errors import OutputError
from obsnl.estimation import jitcache
from obsnl.estimation.jitcache import jit_options

from .conftest import needs_cc


def _fn(name: str = "rk") -> ca.Function:
    x, p = ca.SX.sym("x", 2), ca.SX.sym("p", 2)
    f = ca.vertcat(x[1], -p[0] * x[0] - p[1] * ca.fabs(x[1]) ** 1.5 * ca.sign(x[1]))
    return ca.Function(name, [x, p], [x + 0.01 * f + 0.5e-4 * ca.exp(-x[0] ** 2)], ["x", "p"], ["y"])


@needs_cc
def test_cached_library_equals_casadi_jit_and_is_compiled_once(tmp_path, monkeypatch):
    monkeypatch.setenv("OBSNL_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(jitcache, "_LOADED", {})
    f = _fn()
    ours = jitcache.jit_compile(f)
    x, p = ca.SX.sym("x", 2), ca.SX.sym("p", 2)
    theirs = ca.Function("rk", [x, p], [f(x, p)], jit_options())
    rng = np.random.default_rng(7)
    for _ in range(20):
        a, b = rng.normal(size=2), rng.uniform(0.1, 3.0, size=2)
        assert np.array_equal(np.asarray(ours(a, b)), np.asarray(theirs(a, b)))  # same C code, same flags
        np.testing.assert_allclose(np.asarray(ours(a, b)), np.asarray(f(a, b)), rtol=1e-13, atol=1e-15)
    libs = sorted((tmp_path / "cache").glob("*.so"))
    assert len(libs) == 1 and ours.name_in() == ["x", "p"] and ours.name_out() == ["y"]
    stamp = libs[0].stat().st_mtime_ns
    monkeypatch.setattr(jitcache, "_LOADED", {})  # as a new process: found on disk, not compiled
    monkeypatch.setattr(jitcache, "_compiler", lambda: pytest.fail("compiled a cached function again"))
    again = jitcache.jit_compile(_fn())
    assert libs[0].stat().st_mtime_ns == stamp
    assert np.array_equal(np.asarray(again([0.3, -0.2], [1.0, 2.0])), np.asarray(ours([0.3, -0.2], [1.0, 2.0])))


@needs_cc
def test_a_changed_function_gets_a_new_library(tmp_path, monkeypatch):
    monkeypatch.setenv("OBSNL_CACHE_DIR", str(tmp_path / "cache"))
    x = ca.SX.sym("x")
    jitcache.jit_compile(ca.Function("g", [x], [2 * x]))
    g3 = jitcache.jit_compile(ca.Function("g", [x], [3 * x]))
    assert float(g3(2.0)) == 6.0
    assert len(list((tmp_path / "cache").glob("g_*.so"))) == 2


@pytest.mark.skipif(not hasattr(os, "getuid"), reason="POSIX permissions")
@needs_cc
def test_unsafe_cache_folders_are_refused(tmp_path, monkeypatch):
    open_dir = tmp_path / "open"
    open_dir.mkdir(mode=0o755)
    os.chmod(open_dir, 0o755)
    monkeypatch.setenv("OBSNL_CACHE_DIR", str(open_dir))
    with pytest.raises(OutputError, match="open to other users"):
        jitcache.cache_directory()
    private = tmp_path / "private"
    private.mkdir(mode=0o700)
    link = tmp_path / "link"
    link.symlink_to(private)
    monkeypatch.setenv("OBSNL_CACHE_DIR", str(link))
    with pytest.raises(OutputError, match="symbolic link"):
        jitcache.cache_directory()
    fresh = tmp_path / "new" / "jit"
    monkeypatch.setenv("OBSNL_CACHE_DIR", str(fresh))
    assert jitcache.cache_directory() == fresh and (fresh.stat().st_mode & 0o777) == 0o700


# ----------------------------------------------------------------------------- 4 JIT folder
def test_4_a_planted_jit_folder_is_not_used(tmp_path, monkeypatch):
    from obsnl.estimation import jitcache

    monkeypatch.setattr(jitcache.tempfile, "tempdir", str(tmp_path))
    monkeypatch.setattr(jitcache, "_PRIVATE_JIT", [])
    victim = tmp_path / "victim"
    victim.mkdir()
    (tmp_path / f"obsnl-jit-{os.getuid()}").symlink_to(victim)
    d = jitcache.jit_directory()
    assert not d.startswith(str(victim)) and os.path.realpath(d) != str(victim)
    st_ = os.lstat(d)
    assert not stat.S_ISLNK(st_.st_mode) and stat.S_IMODE(st_.st_mode) == 0o700 and st_.st_uid == os.getuid()


def test_4_a_world_writable_jit_folder_is_not_used(tmp_path, monkeypatch):
    from obsnl.estimation import jitcache

    monkeypatch.setattr(jitcache.tempfile, "tempdir", str(tmp_path))
    monkeypatch.setattr(jitcache, "_PRIVATE_JIT", [])
    shared = tmp_path / f"obsnl-jit-{os.getuid()}"
    shared.mkdir()
    shared.chmod(0o777)
    assert os.path.realpath(jitcache.jit_directory()) != str(shared)


@pytest.fixture
def cache(tmp_path, monkeypatch):
    from obsnl.estimation import jitcache

    folder = tmp_path / "cache"
    monkeypatch.setenv("OBSNL_CACHE_DIR", str(folder))
    monkeypatch.setattr(jitcache, "_LOADED", {})
    monkeypatch.setattr(jitcache, "_FALLBACK", [], raising=False)
    return folder


def _square():
    import casadi as ca

    x = ca.SX.sym("x")
    return ca.Function("sq26", [x], [x * x + 1.0])


def _library(folder: Path) -> Path:
    (lib,) = folder.glob("sq26_*.so")
    return lib


@needs_cc
def test_7_a_truncated_library_is_rebuilt_not_loaded(cache):
    import subprocess
    import sys

    from obsnl.estimation import jitcache

    code = ("import casadi as ca; from obsnl.estimation.jitcache import jit_compile; x = ca.SX.sym('x'); "
            "print(float(jit_compile(ca.Function('sq26', [x], [x * x + 1.0]))(3.0)))")

    def new_process() -> subprocess.CompletedProcess:  # this process never maps the library it truncates
        return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=dict(os.environ))

    assert new_process().stdout.strip() == "10.0"
    lib = _library(cache)
    lib.write_bytes(lib.read_bytes()[:1000])  # a full disk or a killed copy
    for _ in range(2):  # it crashed (SIGBUS) or gave a traceback on every run, never rebuilt
        p = new_process()
        assert p.returncode == 0 and p.stdout.strip() == "10.0", p.stderr[-500:]
    assert lib.stat().st_size > 1000
    assert (cache / f"{lib.name}.sha256").read_text().split()[0] == jitcache._sha256(lib)


@needs_cc
@pytest.mark.parametrize("sidecar", ["kept", "removed"])
def test_7_a_planted_library_is_never_loaded(cache, tmp_path, sidecar):
    import subprocess

    from obsnl.estimation import jitcache

    jitcache.jit_compile(_square())
    lib = _library(cache)
    marker = tmp_path / "constructor-ran"
    src = tmp_path / "plant.c"
    src.write_text('#include <stdio.h>\n__attribute__((constructor)) static void planted(void) '
                   f'{{ FILE *f = fopen("{marker}", "w"); if (f) fclose(f); }}\n')
    subprocess.run([jitcache._compiler(), "-shared", "-fPIC", str(src), "-o", str(tmp_path / "plant.so")], check=True)
    os.replace(tmp_path / "plant.so", lib)  # a new file: the library this process loaded stays mapped
    if sidecar == "removed":
        (cache / f"{lib.name}.sha256").unlink()
    jitcache._LOADED.clear()  # as a new process
    assert float(jitcache.jit_compile(_square())(3.0)) == 10.0
    assert not marker.exists()  # the planted library's constructor never ran


@needs_cc
def test_7_a_library_others_may_write_is_rebuilt(cache):
    from obsnl.estimation import jitcache

    jitcache.jit_compile(_square())
    lib = _library(cache)
    lib.chmod(0o777)
    jitcache._LOADED.clear()  # rebuilt into a new file (os.replace): the loaded one stays mapped
    jitcache.jit_compile(_square())
    assert lib.stat().st_mode & 0o077 == 0


@needs_cc
def test_7_the_key_names_the_cpu_and_the_compiler(cache, monkeypatch):
    from obsnl.estimation import jitcache

    jitcache.jit_compile(_square())
    monkeypatch.setattr(jitcache, "_machine", lambda: "another CPU")  # -march=native code is not portable
    jitcache._LOADED.clear()
    jitcache.jit_compile(_square())
    monkeypatch.setattr(jitcache, "_compiler_identity", lambda: "another compiler")
    jitcache._LOADED.clear()
    jitcache.jit_compile(_square())
    assert len(list(cache.glob("sq26_*.so"))) == 3


@needs_cc
def test_7_a_cache_folder_under_a_file_falls_back_with_one_line(tmp_path, monkeypatch, capfd):
    from obsnl.estimation import jitcache

    monkeypatch.setattr(jitcache, "_LOADED", {})
    monkeypatch.setattr(jitcache, "_FALLBACK", [], raising=False)
    (tmp_path / "afile").write_text("x")
    monkeypatch.setenv("OBSNL_CACHE_DIR", str(tmp_path / "afile" / "jit"))
    assert float(jitcache.jit_compile(_square())(3.0)) == 10.0  # it was a FileExistsError traceback
    err = capfd.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "afile" in err[0] and "OBSNL_CACHE_DIR" in err[0]


@needs_cc
def test_7_a_read_only_cache_folder_falls_back_with_one_line(cache, monkeypatch, capfd):
    import errno
    import tempfile

    from obsnl.estimation import jitcache

    jitcache.cache_directory()
    real = tempfile.TemporaryDirectory

    def read_only(*args, dir=None, **kwargs):  # what a read-only file system answers
        if dir is not None and Path(dir) == cache:
            raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(dir))
        return real(*args, dir=dir, **kwargs)

    monkeypatch.setattr(jitcache.tempfile, "TemporaryDirectory", read_only)
    assert float(jitcache.jit_compile(_square())(3.0)) == 10.0
    err = capfd.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Read-only" in err[0]


LINK_FULL = "ld: final link failed: No space left on device\ncollect2: error: ld returned 1 exit status\n"


@needs_cc
@pytest.mark.parametrize("where", ["the source", "the linker's output"])
def test_7_a_full_cache_file_system_falls_back_with_one_line(cache, monkeypatch, capfd, where):
    # A full file system fails either writing the C source (an OSError) or, when the source still fits, in the
    # linker (gcc exits 1 with 'No space left on device'): that second case ended in a two-line EstimatorError
    # ("the C compiler failed on ...: ld: final link failed ...\ncollect2: ...") and no fallback.
    # Seen on a 200 kB tmpfs filled to 12 kB free: OBSNL_CACHE_DIR=<it>/jit python -c "...jit_compile(...)".
    import errno
    import subprocess

    from obsnl.estimation import jitcache

    jitcache.cache_directory()
    real_run, real_write = jitcache._run, Path.write_text

    def full_run(argv, *args, **kwargs):  # what gcc answers when its output does not fit
        if Path(argv[-1]).parent.parent == cache:
            return subprocess.CompletedProcess(argv, 1, "", LINK_FULL)
        return real_run(argv, *args, **kwargs)

    def full_write(self, *args, **kwargs):
        if self.parent.parent == cache:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self))
        return real_write(self, *args, **kwargs)

    if where == "the source":
        monkeypatch.setattr(Path, "write_text", full_write)
    else:
        monkeypatch.setattr(jitcache, "_run", full_run)  # how jitcache runs the compiler (with a time limit)
    assert float(jitcache.jit_compile(_square())(3.0)) == 10.0
    err = capfd.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "No space left on device" in err[0] and "temporary folder" in err[0], err
    assert not list(cache.glob("*.so"))


@needs_cc
def test_7_a_compiler_error_is_one_line(cache, monkeypatch):
    # a compiler that fails on the code itself is an error, in one line (its stderr spans several)
    import subprocess

    from obsnl.errors import CompileError
    from obsnl.estimation import jitcache

    monkeypatch.setattr(jitcache, "_run", lambda argv, *a, **k: subprocess.CompletedProcess(
        argv, 1, "", "x.c:1:1: error: expected ';'\n    1 | int x\n      | ^\n"))
    with pytest.raises(CompileError) as info:
        jitcache.jit_compile(_square())
    assert "\n" not in str(info.value) and "expected ';'" in str(info.value)
