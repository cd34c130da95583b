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
import signal
import socket
import struct
import threading
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any, TypeVar

from obsnl._text import quote
from obsnl.errors import OptionError

T = TypeVar("T")

#: A Dask scheduler address: an optional scheme, a host name or address ([...] for IPv6), an optional port.
_ADDRESS = re.compile(r"^(?:(?P<scheme>tcp|tls)://)?(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9._-]+)(?::(?P<port>\d{1,5}))?$")

__all__ = ["Executor", "spawn_seeds", "built_once", "MAX_WORKERS"]

#: Most local worker processes (each holds its own copy of the model and its compiled filters); past a
#: machine integer the process pool itself fails with an OverflowError.
MAX_WORKERS = 1024


@dataclass(frozen=True)
class Executor:
    """Where independent tasks run.

    Parameters
    ----------
    scheduler : Any
        None: this machine; an address (``"tcp://host:8786"``) or a ``distributed.Client``: that Dask
        cluster (its workers need obsnl installed).
    workers : int or None
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
        if isinstance(self.workers, int) and self.workers > MAX_WORKERS:  # a pool too large: why, and what instead
            raise OptionError(f"workers={quote(self.workers, 30)} is more than {MAX_WORKERS}: each is a process of its "
                              f"own (from 1 to {MAX_WORKERS}); a larger pool is a Dask cluster (scheduler=)")
        if self.workers is not None and (not isinstance(self.workers, int) or not 1 <= self.workers <= MAX_WORKERS):
            raise OptionError(f"workers must be a whole number from 1 to {MAX_WORKERS} or None (one per core), got "
                              f"{quote(self.workers, 30)}; a larger pool is a Dask cluster (scheduler=)")
        if self.scheduler is not None and not isinstance(self.scheduler, str) and not hasattr(self.scheduler, "map"):
            raise OptionError(f"scheduler must be a Dask scheduler address like tcp://host:8786 or a "
                              f"distributed.Client, got {self.scheduler!r}")
        if isinstance(self.scheduler, str):
            _host_port(self.scheduler)

    def probe(self, timeout: float = 5.0) -> Executor:
        """Refuse, at once, a scheduler address where no Dask scheduler answers (before any work starts).

        A TCP connection is opened and the scheduler's side of the Dask handshake is read and checked
        (a Dask server speaks first: a length-prefixed message of one small frame holding its
        ``pickle-protocol``), at most ``timeout`` seconds each; then the connection is closed. Whatever
        else answers (an HTTP server, whose first bytes read as a frame length of exbibytes, or a server
        that stays silent) is refused with one line. ``tls://`` addresses are only connected to (their
        handshake is encrypted). Local executors and client objects pass as they are.

        Returns
        -------
        Executor
            ``self``.

        Raises
        ------
        OptionError
            The host is unknown, nothing listens at the address, or what answers is not a Dask scheduler.

        Examples
        --------
        >>> Executor(workers=1).probe().kind
        'serial'
        """
        if not isinstance(self.scheduler, str):
            return self
        host, port = _host_port(self.scheduler)
        fix = ("start one with `dask scheduler` and workers with `dask worker ADDRESS`, or leave scheduler= out "
               "to run on this machine")
        try:
            sock = socket.create_connection((host, port), timeout=timeout)
        except OSError as exc:
            raise OptionError(f"cannot reach the Dask scheduler {self.scheduler!r} ({exc.strerror or exc}); {fix}") \
                from None
        with sock:
            if self.scheduler.strip().startswith("tls://"):
                return self
            try:
                why = _dask_handshake(sock)
            except TimeoutError:
                why = f"no Dask handshake within {timeout:g} s"
            except OSError as exc:
                why = f"the connection broke before the Dask handshake: {exc.strerror or exc}"
        if why:
            raise OptionError(f"{self.scheduler!r} is not a Dask scheduler ({why}); {fix}")
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
        """Workers kept for several :meth:`_Session.map` calls (what they built stays built).

        While local processes run, SIGTERM is handled as SIGINT (a KeyboardInterrupt in this process,
        when it is the main thread's): on either, or on any error, the workers are terminated before
        the exception goes on, so none outlives the main process.
        """
        s = _Session(self)
        handle = s.pool is not None and threading.current_thread() is threading.main_thread()
        previous = signal.signal(signal.SIGTERM, _interrupt) if handle else None
        ok = False
        try:
            yield s
            ok = True
        finally:
            try:
                s.close(abort=not ok)
            finally:
                if handle:
                    signal.signal(signal.SIGTERM, previous if previous is not None else signal.SIG_DFL)


def _host_port(address: str) -> tuple[str, int]:
    """Host and port of a Dask scheduler address (port 8786 when none is given), or a one-line refusal."""
    m = _ADDRESS.match(address.strip())
    labels = [] if m is None or m["host"].startswith("[") else m["host"].removesuffix(".").split(".")
    if m is None or not 0 < int(m["port"] or 8786) < 65536 or len(m["host"]) > 253 or \
            not all(0 < len(x) < 64 for x in labels):  # the labels a host name may have (an empty one: "a..b")
        raise OptionError(f"scheduler={quote(address)} is not a Dask scheduler address; give one like "
                          f"tcp://HOST:8786 (port 1-65535, a host name of dot-separated labels of 1 to 63 characters)")
    return m["host"].strip("[]"), int(m["port"] or 8786)


#: The largest first message a Dask scheduler sends (its handshake is under 100 bytes).
_MAX_HANDSHAKE = 1 << 16


def _read_exactly(sock: socket.socket, n: int) -> bytes:
    data = b""
    while len(data) < n:
        chunk = sock.recv(n - len(data))
        if not chunk:
            break
        data += chunk
    return data


def _dask_handshake(sock: socket.socket) -> str:
    """Read the Dask handshake a scheduler sends on a new TCP connection; ``""`` if it is one, else why not.

    The message (``distributed.comm.tcp``): its length (8 bytes), the number of frames (8 bytes),
    each frame's length (8 bytes each), the frames; the handshake is one msgpack frame, a map with
    ``pickle-protocol``. Nothing beyond :data:`_MAX_HANDSHAKE` bytes is read or allocated.
    """
    head = _read_exactly(sock, 8)
    if len(head) < 8:
        return "it closed the connection without a Dask handshake"
    (total,) = struct.unpack("<Q", head)
    if not 8 <= total <= _MAX_HANDSHAKE:
        return f"its first bytes {head!r} are no Dask message"
    body = _read_exactly(sock, total)
    (nframes,) = struct.unpack("<Q", body[:8]) if len(body) >= 8 else (0,)
    if len(body) < total or not 1 <= nframes <= 16 or 8 * (nframes + 1) > total:
        return "its first message is no Dask handshake"
    lengths = struct.unpack(f"<{nframes}Q", body[8:8 * (nframes + 1)])
    if 8 * (nframes + 1) + sum(lengths) != total:
        return "its first message is no Dask handshake"
    try:
        import msgpack

        info = msgpack.loads(body[8 * (nframes + 1):8 * (nframes + 1) + lengths[0]])
    except ImportError:  # pragma: no cover - msgpack comes with dask.distributed
        return ""
    except Exception:  # noqa: BLE001 - any undecodable frame is a refusal
        info = None
    return "" if isinstance(info, dict) and "pickle-protocol" in info else "its first message is no Dask handshake"


def _interrupt(signum: int, frame: Any) -> None:
    """SIGTERM as SIGINT: a KeyboardInterrupt, so the session shuts its workers down."""
    raise KeyboardInterrupt(f"signal {signum}")


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
                raise OptionError("scheduler= needs dask.distributed: pip install 'dask[distributed]'") from None
            self.own = isinstance(ex.scheduler, str)
            try:
                self.client = Client(ex.scheduler, timeout="30s") if self.own else ex.scheduler
            except (OSError, ValueError) as exc:  # unreachable, or not an address at all
                raise OptionError(f"cannot reach the Dask scheduler {ex.scheduler!r} ({exc}); give an address like "
                                  f"tcp://HOST:8786, start one with `dask scheduler` and workers with "
                                  f"`dask worker ADDRESS`") from None

    def close(self, *, abort: bool = False) -> None:
        """Shut the workers down; ``abort`` (an interrupt, an error): stop them now, running tasks included."""
        if self.pool is not None:
            procs = list((getattr(self.pool, "_processes", None) or {}).values())
            self.pool.shutdown(wait=not abort, cancel_futures=True)
            if abort:
                for p in procs:
                    if p.is_alive():
                        p.terminate()
                for p in procs:
                    p.join(timeout=5.0)
                    if p.is_alive():  # pragma: no cover - a worker that ignores SIGTERM
                        p.kill()
                        p.join(timeout=5.0)
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
