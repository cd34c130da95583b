"""One executor for independent tasks: in this process, local processes, or a Dask cluster.

Tasks are coarse (a filter run with its tuning, a batch of Monte-Carlo replicates, one model of a
report) and carry specifications (a model file's text, a record, a branch table's JSON, seeds),
never compiled objects: a worker rebuilds what it needs once and keeps it for the next task (the
compiled filters come from the disk cache of :mod:`obsnl.estimation.jitcache`). Every task's
randomness is fixed by the task itself (its noise seed, or a child of one root seed from
:func:`spawn_seeds`), so results do not depend on the number or order of workers.
"""

from __future__ import annotations

import hashlib
import os
import pickle
import re
import socket
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, TypeVar

from obsnl.errors import OptionError

T = TypeVar("T")

#: A Dask scheduler address: an optional scheme, a host name or address ([...] for IPv6), an optional port.
_ADDRESS = re.compile(r"^(?:(?P<scheme>tcp|tls)://)?(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9._-]+)(?::(?P<port>\d{1,5}))?$")

__all__ = ["Executor", "spawn_seeds", "built_once"]


@dataclass(frozen=True)
class Executor:
    """Where independent tasks run.

    Parameters
    ----------
    scheduler
        None: this machine; an address (``"tcp://host:8786"``) or a ``distributed.Client``: that Dask
        cluster (its workers need obsnl installed).
    workers
        Local processes when ``scheduler`` is None (None: one per core; 1: in this process, no
        processes started).

    Examples
    --------
    >>> Executor(workers=1).map(abs, [-1, 2, -3])
    [1, 2, 3]
    """

    scheduler: Any = None
    workers: int | None = None

    def __post_init__(self) -> None:
        if self.workers is not None and (not isinstance(self.workers, int) or self.workers < 1):
            raise OptionError(f"workers must be a whole number >= 1 or None (one per core), got {self.workers!r}")
        if self.scheduler is not None and not isinstance(self.scheduler, str) and not hasattr(self.scheduler, "map"):
            raise OptionError(f"scheduler must be a Dask scheduler address like tcp://host:8786 or a "
                              f"distributed.Client, got {self.scheduler!r}")
        if isinstance(self.scheduler, str):
            _host_port(self.scheduler)

    def probe(self, timeout: float = 5.0) -> Executor:
        """Refuse, at once, a scheduler address that nothing answers on (before any work starts).

        A TCP connection to the address is opened and closed (at most ``timeout`` seconds); the Dask
        handshake itself comes with the first task. Local executors and client objects pass as they are.

        Returns
        -------
        Executor
            ``self``.

        Raises
        ------
        OptionError
            The host is unknown or nothing listens at the address.

        Examples
        --------
        >>> Executor(workers=1).probe().kind
        'serial'
        """
        if not isinstance(self.scheduler, str):
            return self
        host, port = _host_port(self.scheduler)
        try:
            socket.create_connection((host, port), timeout=timeout).close()
        except OSError as exc:
            raise OptionError(f"cannot reach the Dask scheduler {self.scheduler!r} ({exc.strerror or exc}); start one "
                              f"with `dask scheduler` and workers with `dask worker ADDRESS`, or leave --scheduler "
                              f"out to run on this machine") from None
        return self

    @property
    def kind(self) -> str:
        """``"serial"``, ``"processes"`` or ``"dask"``."""
        if self.scheduler is not None:
            return "dask"
        return "serial" if self.n_workers == 1 else "processes"

    @property
    def n_workers(self) -> int:
        return self.workers or os.cpu_count() or 1

    def map(self, fn: Callable[[Any], Any], tasks: Sequence[Any], *,
            done: Callable[[int, Any], None] | None = None) -> list[Any]:
        """``[fn(t) for t in tasks]``, run where this executor says; ``done(i, result)`` as each finishes.

        ``fn`` must be a module-level function (it is pickled by name for processes and Dask).
        """
        with self.session() as session:
            return session.map(fn, tasks, done=done)

    @contextmanager
    def session(self) -> Iterator[_Session]:
        """Workers kept for several :meth:`_Session.map` calls (what they built stays built)."""
        s = _Session(self)
        try:
            yield s
        finally:
            s.close()


def _host_port(address: str) -> tuple[str, int]:
    """Host and port of a Dask scheduler address (port 8786 when none is given), or a one-line refusal."""
    m = _ADDRESS.match(address.strip())
    if m is None or not 0 < int(m["port"] or 8786) < 65536:
        raise OptionError(f"--scheduler {address!r} is not a Dask scheduler address; give one like tcp://HOST:8786 "
                          f"(port 1-65535)")
    return m["host"].strip("[]"), int(m["port"] or 8786)


class _Session:
    def __init__(self, ex: Executor) -> None:
        self.kind, self.pool, self.client, self.own = ex.kind, None, None, False
        if self.kind == "processes":
            import multiprocessing as mp
            from concurrent.futures import ProcessPoolExecutor

            self.pool = ProcessPoolExecutor(max_workers=ex.n_workers, mp_context=mp.get_context("spawn"))
        elif self.kind == "dask":
            try:
                from distributed import Client
            except ImportError:  # pragma: no cover
                raise OptionError("--scheduler needs dask.distributed: pip install 'dask[distributed]'") from None
            self.own = isinstance(ex.scheduler, str)
            try:
                self.client = Client(ex.scheduler, timeout="30s") if self.own else ex.scheduler
            except (OSError, ValueError) as exc:  # unreachable, or not an address at all
                raise OptionError(f"cannot reach the Dask scheduler {ex.scheduler!r} ({exc}); give an address like "
                                  f"tcp://HOST:8786, start one with `dask scheduler` and workers with "
                                  f"`dask worker ADDRESS`") from None

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(cancel_futures=True)
        if self.client is not None and self.own:
            self.client.close()

    def map(self, fn: Callable[[Any], Any], tasks: Sequence[Any], *,
            done: Callable[[int, Any], None] | None = None) -> list[Any]:
        tasks = list(tasks)
        results: list[Any] = [None] * len(tasks)
        if self.kind == "serial":
            for i, t in enumerate(tasks):
                results[i] = fn(t)
                if done:
                    done(i, results[i])
            return results
        if self.kind == "processes":
            from concurrent.futures import as_completed

            futures = {self.pool.submit(fn, t): i for i, t in enumerate(tasks)}
            for fut in as_completed(futures):
                results[futures[fut]] = fut.result()
                if done:
                    done(futures[fut], results[futures[fut]])
            return results
        from distributed import as_completed as dask_completed

        futures = self.client.map(fn, tasks, pure=False)
        index = {f.key: i for i, f in enumerate(futures)}
        for fut in dask_completed(futures):
            i = index[fut.key]
            results[i] = fut.result()
            if done:
                done(i, results[i])
        return results


_BUILT: dict[str, Any] = {}


def built_once(spec: Any, build: Callable[[], T]) -> T:
    """What ``build()`` makes for the plain-data specification ``spec``, built once per process.

    A worker keeps one experiment at a time (the last one built): tasks of one run share it, a task
    of another run replaces it. The key is the pickled ``spec``, so equal specifications share.

    Parameters
    ----------
    spec : picklable
        The specification (plain data: no compiled objects).
    build : callable
        Makes the object from nothing but ``spec``.

    Returns
    -------
    object
        The object built for ``spec``.

    Examples
    --------
    >>> built_once(("demo", 1), lambda: [1]) is built_once(("demo", 1), lambda: [2])
    True
    """
    key = hashlib.sha256(pickle.dumps(spec)).hexdigest()
    if key not in _BUILT:
        value = build()
        _BUILT.clear()  # one experiment at a time per worker
        _BUILT[key] = value
    return _BUILT[key]


def spawn_seeds(root: int, n: int) -> list[int]:
    """``n`` independent seeds from one root seed (``numpy.random.SeedSequence(root).spawn(n)``).

    Seed ``i`` depends on ``root`` and ``i`` only, never on which worker runs task ``i``.

    Parameters
    ----------
    root : int
        The root seed.
    n : int
        Number of seeds.

    Returns
    -------
    list of int

    Examples
    --------
    >>> spawn_seeds(0, 3) == spawn_seeds(0, 5)[:3]
    True
    """
    import numpy as np

    return [int(c.generate_state(1, np.uint64)[0]) for c in np.random.SeedSequence(root).spawn(n)]
