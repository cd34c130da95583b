"""``identify`` compiles by default where a C compiler is on PATH, and runs uncompiled otherwise.

Compiling changes the time a run takes, never its numbers: the C code is built without floating-point
contraction, so it rounds as casadi's virtual machine does (``test_compiled_numbers.py`` checks whole filter
runs bit for bit). What is checked here, on a Duffing oscillator whose data come from scipy (an integrator
independent of obsnl's), 1 % noise with a fixed seed:

- the default (``jit=None``) with a compiler: ``compiled`` is True and every estimate, std and interval equals
  the uncompiled run's to 1e-9 relative;
- no compiler on PATH: ``compiled`` is False, nothing is said, the same numbers;
- a compiler that fails, or a library cache that is a symbolic link: ``compiled`` is False, one warning names
  the failure, the same numbers (and nothing is written through the link);
- ``jit=True`` (asked for) with a failing compiler: a :class:`~obsnl.errors.CompileError`, not hidden.

Each case that must reach the compiler uses its own power of the cubic term (new C code, so no library
compiled earlier in the process or on disk can stand in for the compiler).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import obsnl
from obsnl.errors import CompileError
from obsnl.estimation import jitcache

from .conftest import needs_cc

TRUE = {"c": 0.3, "k": 4.0, "kn": 2.0}


def _case(power: int):
    model = obsnl.Model(name=f"duffing{power}", states=["x", "v"], parameters=["c", "k", "kn"], inputs=["F"],
                        equations={"x": "v", "v": f"F - c*v - k*x - kn*x**{power}"}, outputs={"disp": "x"},
                        guess={"c": 0.4, "k": 3.5, "kn": 2.5})
    t = np.arange(300) * 0.02
    F = 2.0 * np.sin(2.1 * t) + 1.2 * np.sin(3.7 * t + 0.4)
    rhs = lambda tt, s: [s[1], np.interp(tt, t, F) - TRUE["c"] * s[1] - TRUE["k"] * s[0]  # noqa: E731
                         - TRUE["kn"] * s[0] ** power]
    x = solve_ivp(rhs, (0, t[-1]), [0.0, 0.0], method="LSODA", t_eval=t, rtol=1e-10, atol=1e-12, max_step=0.02).y[0]
    disp = x + 0.01 * np.sqrt(np.mean(x**2)) * np.random.default_rng(0).standard_normal(x.size)
    return model, {"time_s": t, "F": F, "disp": disp}


def _numbers(res) -> np.ndarray:
    return np.array([[p.estimate, p.std, *p.interval] for p in res.parameters], float)


def _fresh_cache(tmp_path, monkeypatch) -> None:
    """An empty library cache, on disk and in this process."""
    monkeypatch.setenv("OBSNL_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(jitcache, "_LOADED", {})


def _broken_compiler(tmp_path, monkeypatch) -> None:
    """PATH holds only a ``gcc`` that fails, as a broken tool chain does."""
    bin_ = tmp_path / "bin"
    bin_.mkdir()
    gcc = bin_ / "gcc"
    gcc.write_text("#!/bin/sh\necho 'gcc: fatal error: broken tool chain' >&2\nexit 1\n")
    gcc.chmod(0o755)
    monkeypatch.setenv("PATH", str(bin_))


@pytest.mark.slow
@needs_cc
def test_the_default_compiles_and_gives_the_uncompiled_numbers(tmp_path, monkeypatch, capsys):
    _fresh_cache(tmp_path, monkeypatch)
    model, data = _case(3)
    auto = obsnl.identify(model, data, progress=False)
    assert auto.compiled is True and auto.to_dict()["compiled"] is True
    plain = obsnl.identify(model, data, progress=False, jit=False)
    assert plain.compiled is False
    np.testing.assert_allclose(_numbers(auto), _numbers(plain), rtol=1e-9)
    assert auto.converged and "warning" not in capsys.readouterr().err
    # no compiler on PATH: uncompiled, without a word (nothing was asked), the same numbers
    monkeypatch.setenv("PATH", str(tmp_path / "nothing"))
    bare = obsnl.identify(model, data, progress=False)
    assert bare.compiled is False and "warning" not in capsys.readouterr().err
    np.testing.assert_allclose(_numbers(bare), _numbers(plain), rtol=1e-9)


def test_a_failing_compiler_falls_back_with_a_warning(tmp_path, monkeypatch, capsys):
    _fresh_cache(tmp_path, monkeypatch)
    model, data = _case(5)
    plain = obsnl.identify(model, data, progress=False, jit=False)
    _broken_compiler(tmp_path, monkeypatch)
    res = obsnl.identify(model, data, progress=False)
    err = capsys.readouterr().err
    assert res.compiled is False
    assert err.count("obsnl: warning:") == 1 and "the C compiler failed" in err and "broken tool chain" in err
    assert "running uncompiled" in err
    np.testing.assert_allclose(_numbers(res), _numbers(plain), rtol=1e-9)


def test_an_asked_compilation_that_fails_is_an_error(tmp_path, monkeypatch):
    _fresh_cache(tmp_path, monkeypatch)
    model, data = _case(7)
    _broken_compiler(tmp_path, monkeypatch)
    with pytest.raises(CompileError, match="the C compiler failed"):
        obsnl.identify(model, data, progress=False, jit=True)


@needs_cc
def test_an_unsafe_cache_folder_falls_back_without_writing_through_it(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(jitcache, "_LOADED", {})
    victim = tmp_path / "victim"
    victim.mkdir(mode=0o700)
    (tmp_path / "cache").symlink_to(victim)
    monkeypatch.setenv("OBSNL_CACHE_DIR", str(tmp_path / "cache"))
    model, data = _case(9)
    res = obsnl.identify(model, data, progress=False)
    err = capsys.readouterr().err
    assert res.compiled is False and err.count("obsnl: warning:") == 1 and "symbolic link" in err
    assert list(victim.iterdir()) == []
    np.testing.assert_allclose(_numbers(res), _numbers(obsnl.identify(model, data, progress=False, jit=False)),
                               rtol=1e-9)


@pytest.mark.parametrize("have_cc", [True, False])
def test_the_main_job_compiles_where_it_can_and_says_when_it_cannot(have_cc, tmp_path, monkeypatch, capsys):
    import obsnl.studies.seed_paper as seed_paper
    from obsnl.estimation.jitcache import compiler_available

    if have_cc and not compiler_available():
        pytest.skip("needs a C compiler")
    if not have_cc:
        monkeypatch.setenv("PATH", str(tmp_path / "nothing"))
    seen = []

    def stop(spec):  # the experiment's spec is built: record whether it compiles, and stop there
        seen.append(spec.jit)
        raise KeyboardInterrupt

    monkeypatch.setattr(seed_paper, "context", stop)
    with pytest.raises(KeyboardInterrupt):
        seed_paper.reproduce(seeds=1, tuning_seeds=1, samples=100, replicates=0)
    err = capsys.readouterr().err
    assert seen == [have_cc]
    assert ("no C compiler" in err) is (not have_cc)
