"""The disk cache of compiled casadi Functions: same numbers as casadi's own jit, nothing compiled
twice, and a cache folder that another user could tamper with is refused."""

from __future__ import annotations

import os

import casadi as ca
import numpy as np
import pytest

from obsnl.errors import OutputError
from obsnl.estimation import jitcache
from obsnl.estimation.jitcache import jit_options

from .conftest import needs_cc

pytestmark = needs_cc


def _fn(name: str = "rk") -> ca.Function:
    x, p = ca.SX.sym("x", 2), ca.SX.sym("p", 2)
    f = ca.vertcat(x[1], -p[0] * x[0] - p[1] * ca.fabs(x[1]) ** 1.5 * ca.sign(x[1]))
    return ca.Function(name, [x, p], [x + 0.01 * f + 0.5e-4 * ca.exp(-x[0] ** 2)], ["x", "p"], ["y"])


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


def test_a_changed_function_gets_a_new_library(tmp_path, monkeypatch):
    monkeypatch.setenv("OBSNL_CACHE_DIR", str(tmp_path / "cache"))
    x = ca.SX.sym("x")
    jitcache.jit_compile(ca.Function("g", [x], [2 * x]))
    g3 = jitcache.jit_compile(ca.Function("g", [x], [3 * x]))
    assert float(g3(2.0)) == 6.0
    assert len(list((tmp_path / "cache").glob("g_*.so"))) == 2


@pytest.mark.skipif(not hasattr(os, "getuid"), reason="POSIX permissions")
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
