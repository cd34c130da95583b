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
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypeVar

from obsnl._text import quote
from obsnl.errors import ExecutorError, ObsnlError, OptionError

if TYPE_CHECKING:  # Dask is optional: imported only where a cluster is used
    from distributed import Client

T = TypeVar("T")

#: A Dask scheduler address: an optional scheme, a host name or address ([...] for IPv6), an optional port.
_ADDRESS = re.compile(
    r"^(?:(?P<scheme>tcp|tls)://)?(?P<host>\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9._-]+)(?::(?P<port>\d{1,5}))?$"
)

__all__ = ["Executor", "spawn_seeds", "built_once", "MAX_WORKERS", "DEADLINE"]

#: Most local worker processes (each holds its own copy of the model and its compiled filters); past a
#: machine integer the process pool itself fails with an OverflowError.
MAX_WORKERS = 1024

#: Seconds a Dask scheduler may take to answer, and a cluster may stay without a running worker while tasks
#: wait, before the work is refused with one line (an :class:`~obsnl.errors.ExecutorError`).
DEADLINE = 10.0

#: What to do about a Dask scheduler that cannot run the work.
_START = (
    "start one with `dask scheduler` and workers with `dask worker ADDRESS`, or leave scheduler= out "
    "to run on this machine"
)


@dataclass(frozen=True)
class Executor:
    """Where independent tasks run.

    Parameters
    ----------
    scheduler : str or distributed.Client or None
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

    scheduler: str | Client | None = None
    workers: int | None = None

    def __post_init__(self) -> None:
        if isinstance(self.workers, int) and self.workers > MAX_WORKERS:  # a pool too large: why, and what instead
            raise OptionError(
                f"workers={quote(self.workers, 30)} is more than {MAX_WORKERS}: each is a process of its "
                f"own (from 1 to {MAX_WORKERS}); a larger pool is a Dask cluster (scheduler=)"
            )
        if self.workers is not None and (not isinstance(self.workers, int) or not 1 <= self.workers <= MAX_WORKERS):
            raise OptionError(
                f"workers must be a whole number from 1 to {MAX_WORKERS} or None (one per core), got "
                f"{quote(self.workers, 30)}; a larger pool is a Dask cluster (scheduler=)"
            )
        if self.scheduler is not None and not isinstance(self.scheduler, str) and not hasattr(self.scheduler, "map"):
            raise OptionError(
                f"scheduler must be a Dask scheduler address like tcp://host:8786 or a "
                f"distributed.Client, got {self.scheduler!r}"
            )
        if isinstance(self.scheduler, str):
            _host_port(self.scheduler)

    def probe(self, timeout: float = 5.0) -> Executor:
        """Refuse, within seconds, a Dask scheduler that cannot run the work (before any work starts).

        For an address, a TCP connection is opened and the scheduler's side of the Dask handshake is read
        and checked (a Dask server speaks first: a length-prefixed message of one small frame holding its
        ``pickle-protocol``), at most ``timeout`` seconds each; whatever else answers (an HTTP server, whose
        first bytes read as a frame length of exbibytes, or a server that stays silent) is refused with one
        line. Then, over a Dask connection of its own, the scheduler is asked how many workers it has (one that
        sent the handshake and went silent is refused after ``timeout`` seconds): it must have a worker, or gain
        one within ``timeout`` seconds (a cluster with none would wait for ever). A ``distributed.Client`` given as
        the scheduler is asked for its workers the same way. ``tls://`` addresses are only connected to (their
        handshake is encrypted). Local executors pass as they are.

        Parameters
        ----------
        timeout : float
            Seconds allowed to each step (connecting, the handshake, the registration, a first worker).

        Returns
        -------
        Executor
            ``self``.

        Raises
        ------
        OptionError
            The host is unknown, nothing listens at the address, what answers is not a Dask scheduler, the
            scheduler stopped answering, or it has no worker.

        Examples
        --------
        >>> Executor(workers=1).probe().kind
        'serial'
        """
        if self.scheduler is None:
            return self
        if not isinstance(self.scheduler, str):
            _need_workers(self.scheduler, _address(self.scheduler), timeout, OptionError)
            return self
        host, port = _host_port(self.scheduler)
        try:
            sock = socket.create_connection((host, port), timeout=timeout)
        except OSError as exc:
            raise OptionError(
                f"cannot reach the Dask scheduler {self.scheduler!r} ({exc.strerror or exc}); {_START}"
            ) from None
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
            raise OptionError(f"{self.scheduler!r} is not a Dask scheduler ({why}); {_START}")
        if not _ask_scheduler(self.scheduler.strip(), timeout).get("n_workers"):
            raise OptionError(_NO_WORKER.format(name=self.scheduler, seconds=timeout))
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

    def map(
        self,
        fn: Callable[[Any], Any],
        tasks: Sequence[Any],
        *,
        done: Callable[[int, Any], object] | None = None,
        label: Callable[[Any], str] | None = None,
    ) -> list[Any]:
        """``[fn(t) for t in tasks]``, run where this executor says; ``done(i, result)`` as each finishes.

        No path waits for ever: a local worker process that dies, a Dask cluster left without a running worker
        or a scheduler that stops answering for :data:`DEADLINE` seconds, and a task that kills its Dask workers
        each stop the work with one line (an :class:`~obsnl.errors.ExecutorError`) naming the task and what to do.

        Parameters
        ----------
        fn : callable
            A module-level function (it is pickled by name for processes and Dask).
        tasks : sequence
            Its arguments, one per task.
        done : callable or None
            Called in this process as ``done(i, result)`` when task ``i`` finishes.
        label : callable or None
            A task's name in messages (``label(task)``, e.g. "the profile of k"); default "task I of N (fn)".

        Returns
        -------
        list
            The results, in the order of ``tasks``.

        Raises
        ------
        ExecutorError
            A worker died or the Dask cluster cannot run the tasks (see above).
        OptionError
            The Dask scheduler cannot be reached.

        Examples
        --------
        >>> Executor(workers=1).map(len, ["ab", "c"], label=repr)
        [2, 1]
        """
        with self.session() as session:
            return session.map(fn, tasks, done=done, label=label)

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
    if (
        m is None
        or not 0 < int(m["port"] or 8786) < 65536
        or len(m["host"]) > 253
        or not all(0 < len(x) < 64 for x in labels)
    ):  # the labels a host name may have (an empty one: "a..b")
        raise OptionError(
            f"scheduler={quote(address)} is not a Dask scheduler address; give one like "
            f"tcp://HOST:8786 (port 1-65535, a host name of dot-separated labels of 1 to 63 characters)"
        )
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
    lengths = struct.unpack(f"<{nframes}Q", body[8 : 8 * (nframes + 1)])
    if 8 * (nframes + 1) + sum(lengths) != total:
        return "its first message is no Dask handshake"
    try:
        import msgpack

        info = msgpack.loads(body[8 * (nframes + 1) : 8 * (nframes + 1) + lengths[0]])
    except ImportError:  # pragma: no cover - msgpack comes with dask.distributed
        return ""
    except Exception:  # noqa: BLE001 - any undecodable frame is a refusal
        info = None
    return "" if isinstance(info, dict) and "pickle-protocol" in info else "its first message is no Dask handshake"


def _interrupt(signum: int, frame: Any) -> None:
    """SIGTERM as SIGINT: a KeyboardInterrupt, so the session shuts its workers down."""
    raise KeyboardInterrupt(f"signal {signum}")


def _start_queue(queue: Any) -> None:
    """A worker process's start: keep the queue on which it says which task it begins."""
    global _STARTED
    _STARTED = queue


_STARTED: Any = None  # in a worker process: the queue of (process id, map, task) it has begun


def _tagged(job: tuple[Callable[[Any], Any], int, int, Any]) -> Any:
    """``fn(task)`` in a worker process, said on the start queue first (so a worker that dies is named by its task)."""
    fn, serial, i, task = job
    if _STARTED is not None:
        _STARTED.put((os.getpid(), serial, i))  # a few dozen bytes: one atomic write to the pipe
    return fn(task)


def _how(exitcode: int | None) -> str:
    """How a worker process ended, in words."""
    if exitcode is None:
        return "it vanished"
    if exitcode < 0:
        try:
            name = signal.Signals(-exitcode).name
        except ValueError:
            name = f"signal {-exitcode}"
        return f"killed by {name}" + (" (the system may be out of memory)" if name == "SIGKILL" else "")
    return f"exit code {exitcode}"


class _Session:
    def __init__(self, ex: Executor) -> None:
        self.kind, self.pool, self.client, self.own = ex.kind, None, None, False
        self.started: Any = None
        self.procs: dict[int, Any] = {}
        self.serial = 0
        self.name = ex.scheduler if isinstance(ex.scheduler, str) else _address(ex.scheduler)
        if self.kind == "processes":
            import multiprocessing as mp
            from concurrent.futures import ProcessPoolExecutor

            ctx = mp.get_context("spawn")
            self.started = ctx.SimpleQueue()
            self.pool = ProcessPoolExecutor(
                max_workers=ex.n_workers, mp_context=ctx, initializer=_start_queue, initargs=(self.started,)
            )
        elif self.kind == "dask":
            self.own = isinstance(ex.scheduler, str)
            self.client = _client(ex.scheduler.strip(), DEADLINE) if isinstance(ex.scheduler, str) else ex.scheduler

    def close(self, *, abort: bool = False) -> None:
        """Shut the workers down; ``abort`` (an interrupt, an error): stop them now, running tasks included."""
        if self.pool is not None:
            procs = list({**self.procs, **(getattr(self.pool, "_processes", None) or {})}.values())
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
            self.started.close()
        if self.client is not None and self.own:
            self.client.close(timeout=DEADLINE)

    def map(
        self,
        fn: Callable[[Any], Any],
        tasks: Sequence[Any],
        *,
        done: Callable[[int, Any], object] | None = None,
        label: Callable[[Any], str] | None = None,
    ) -> list[Any]:
        tasks = list(tasks)
        results: list[Any] = [None] * len(tasks)

        def finished(i: int, value: Any) -> None:
            results[i] = value
            if done:
                done(i, value)

        def named(i: int) -> str:
            return label(tasks[i]) if label else f"task {i + 1} of {len(tasks)} ({getattr(fn, '__name__', fn)})"

        if self.kind == "serial":
            for i, t in enumerate(tasks):
                finished(i, fn(t))
        elif self.kind == "processes":
            self._on_processes(fn, tasks, finished, named)
        else:
            self._on_dask(fn, tasks, finished, named)
        return results

    def _on_processes(
        self,
        fn: Callable[[Any], Any],
        tasks: list[Any],
        finished: Callable[[int, Any], None],
        named: Callable[[int], str],
    ) -> None:
        """The tasks on the local pool; a worker that dies is named by the task it ran (an ExecutorError)."""
        from concurrent.futures import FIRST_COMPLETED, wait
        from concurrent.futures.process import BrokenProcessPool

        self.serial += 1
        begun: dict[int, int] = {}  # process id -> the task of this map it began last
        over: set[int] = set()

        def drain() -> None:  # the start queue read as it fills (a full pipe would block the workers)
            while not self.started.empty():
                pid, serial, i = self.started.get()
                if serial == self.serial:
                    begun[pid] = i

        pool = self.pool
        assert pool is not None  # a session of local processes
        try:
            futures = {pool.submit(_tagged, (fn, self.serial, i, t)): i for i, t in enumerate(tasks)}
            self.procs.update(getattr(pool, "_processes", None) or {})
            pending = set(futures)
            while pending:
                ready, pending = wait(pending, timeout=0.5, return_when=FIRST_COMPLETED)
                # the pool starts its processes as tasks come: each is remembered, to read its exit code if it dies
                self.procs.update(getattr(pool, "_processes", None) or {})
                drain()
                for fut in ready:
                    finished(futures[fut], fut.result())
                    over.add(futures[fut])
        except BrokenProcessPool:
            drain()
            raise ExecutorError(self._died(begun, over, named)) from None

    def _died(self, begun: dict[int, int], over: set[int], named: Callable[[int], str]) -> str:
        """The one line for a worker process that died: which task it ran, how it ended, what to do."""
        procs = {**self.procs, **(getattr(self.pool, "_processes", None) or {})}
        running = {pid: i for pid, i in begun.items() if i not in over}
        for pid in running:  # the pool stops the others (SIGTERM): each has ended, or does within a second
            if pid in procs:
                procs[pid].join(timeout=2.0)
        # the pool's own thread reaps the processes too: a join that loses that race returns before the exit code is
        # set, and the code shows once that thread has set it (a died worker was reported without its exit code)
        settled = time.monotonic() + 2.0
        while time.monotonic() < settled and any(procs[p].exitcode is None for p in running if p in procs):
            time.sleep(0.01)
        dead = {
            pid: procs[pid].exitcode
            for pid in running
            if pid in procs and procs[pid].exitcode not in (None, -signal.SIGTERM)
        }
        if dead:
            said = "; ".join(
                f"a worker process died ({_how(code)}) while running {named(running[pid])}"
                for pid, code in sorted(dead.items())
            )
        elif running:
            tasks = [named(i) for i in sorted(running.values())]
            said = "a worker process died while running " + (
                tasks[0] if len(tasks) == 1 else "one of: " + ", ".join(tasks)
            )
        else:
            said = "a worker process died before its task began"
        return (
            f"{said}; run it again with workers=1 (in this process, where its error shows), or with fewer "
            f"workers if memory is short"
        )

    def _on_dask(
        self,
        fn: Callable[[Any], Any],
        tasks: list[Any],
        finished: Callable[[int, Any], None],
        named: Callable[[int], str],
    ) -> None:
        """The tasks on the Dask cluster, with a deadline: a cluster without a worker, or a scheduler that stops
        answering, for :data:`DEADLINE` seconds is refused (an ExecutorError), as is a task that kills its workers."""
        from concurrent.futures import CancelledError

        from distributed import as_completed

        try:
            from distributed import KilledWorker
        except ImportError:  # pragma: no cover - older dask.distributed
            from distributed.scheduler import KilledWorker

        client = self.client
        assert client is not None  # a session on Dask
        futures = client.map(fn, tasks, pure=False)
        index = {f.key: i for i, f in enumerate(futures)}
        flow, left, quiet, idle = as_completed(futures, loop=client.loop), len(futures), time.monotonic(), None
        while left:
            ready = flow.next_batch(block=False) if flow.has_ready() else []
            for fut in ready:
                i = index[fut.key]
                try:
                    value = fut.result()
                except KilledWorker:  # Dask gave up on it (and on any other task the dead workers held)
                    lost = [
                        named(index[f.key])
                        for f in futures
                        if f.status == "error" and isinstance(f.exception(timeout=DEADLINE), KilledWorker)
                    ] or [named(i)]
                    raise ExecutorError(
                        f"Dask workers died while running {', '.join(lost)} (a task that crashes its "
                        f"worker or exhausts its memory); run it again without scheduler= and with "
                        f"workers=1, in this process, where its error shows"
                    ) from None
                except CancelledError:
                    raise ExecutorError(
                        f"the Dask scheduler {self.name!r} dropped {named(i)} (restarted, or the "
                        f"connection broke); run again, or leave scheduler= out to run on this "
                        f"machine"
                    ) from None
                finished(i, value)
                left -= 1
            if ready:
                quiet, idle = time.monotonic(), None
                continue
            time.sleep(0.05)
            if time.monotonic() - quiet < 1.0:  # the cluster asked about after a second without a result
                continue
            quiet = time.monotonic()
            if _workers(client, self.name, DEADLINE, ExecutorError):
                idle = None
            elif idle is None:
                idle = time.monotonic()
            elif time.monotonic() - idle > DEADLINE:
                raise ExecutorError(
                    f"the Dask scheduler {self.name!r} has had no worker for {DEADLINE:g} s with "
                    f"{left} of {len(tasks)} tasks waiting; start workers with `dask worker "
                    f"{self.name}`, or leave scheduler= out to run on this machine"
                )


def _address(client: Any) -> str:
    """The scheduler address of a Dask client, as messages name it."""
    return str(getattr(getattr(client, "scheduler", None), "address", None) or client)


def _client(address: str, seconds: float) -> Any:
    """A Dask client of the scheduler at ``address``, registered within ``seconds``, or a one-line refusal."""
    try:
        from distributed import Client
    except ImportError:  # pragma: no cover
        raise OptionError("scheduler= needs dask.distributed: pip install 'dask[distributed]'") from None
    try:
        return Client(address, timeout=seconds, set_as_default=False)
    except TimeoutError:  # it took the connection (and maybe sent the handshake), then said nothing
        raise OptionError(
            f"the Dask scheduler {address!r} did not answer a client within {seconds:g} s (it hangs, "
            f"or another program holds its port); restart it with `dask scheduler`, or leave "
            f"scheduler= out to run on this machine"
        ) from None
    except (OSError, ValueError) as exc:  # unreachable, or not an address at all
        raise OptionError(
            f"cannot reach the Dask scheduler {address!r} ({exc}); give an address like tcp://HOST:8786, {_START}"
        ) from None


def _workers(client: Any, name: str, seconds: float, error: type[ObsnlError]) -> int:
    """How many workers the Dask scheduler of ``client`` has (asked with a deadline of ``seconds``)."""
    if not hasattr(client, "sync") or getattr(client, "asynchronous", False):
        return 1  # not a synchronous distributed.Client: nothing to ask, its own map says
    try:
        info = client.sync(client.scheduler.identity, n_workers=0, callback_timeout=seconds)
    except (OSError, RuntimeError) as exc:  # TimeoutError included: a scheduler that stopped answering
        why = str(exc) if str(exc) and not isinstance(exc, TimeoutError) else f"no answer within {seconds:g} s"
        raise error(
            f"the Dask scheduler {name!r} stopped answering ({why}); restart it with `dask scheduler`, or "
            f"leave scheduler= out to run on this machine"
        ) from None
    return int(info.get("n_workers", 1)) if isinstance(info, dict) else 1


#: A scheduler without a worker, refused (``str.format`` with the scheduler's name and the seconds waited).
_NO_WORKER = (
    "the Dask scheduler {name!r} has no worker (none joined within {seconds:g} s); start workers with "
    "`dask worker {name}`, or leave scheduler= out to run on this machine"
)


def _need_workers(client: Any, name: str, seconds: float, error: type[ObsnlError]) -> None:
    """Refuse a Dask scheduler that has no worker and gains none within ``seconds``."""
    end = time.monotonic() + seconds
    while not _workers(client, name, seconds, error):
        if time.monotonic() >= end:
            raise error(_NO_WORKER.format(name=name, seconds=seconds))
        time.sleep(0.2)


def _ask_scheduler(address: str, seconds: float) -> dict[str, Any]:
    """The Dask scheduler's ``identity``, asked over one connection of its own: a client's handshake, then the
    question, at most ``seconds`` each; asked again (five times a second) until it has a worker or ``seconds``
    have passed. A scheduler that does not answer is a one-line refusal; the connection is always closed."""
    import asyncio
    from concurrent.futures import ThreadPoolExecutor

    try:
        from distributed.comm import connect
    except ImportError:  # pragma: no cover
        raise OptionError("scheduler= needs dask.distributed: pip install 'dask[distributed]'") from None

    async def ask() -> dict[str, Any]:
        comm = await connect(address, timeout=seconds)
        try:
            end = asyncio.get_running_loop().time() + seconds
            while True:
                await comm.write({"op": "identity", "n_workers": 0, "reply": True})
                info = await asyncio.wait_for(comm.read(), seconds)
                if not isinstance(info, dict) or info.get("n_workers") or asyncio.get_running_loop().time() > end:
                    return info if isinstance(info, dict) else {}
                await asyncio.sleep(0.2)
        finally:
            comm.abort()

    try:
        with ThreadPoolExecutor(1) as thread:  # a loop of its own, whether or not this thread runs one
            return thread.submit(asyncio.run, ask()).result()
    except ValueError as exc:  # an address Dask does not read
        raise OptionError(
            f"cannot reach the Dask scheduler {address!r} ({exc}); give an address like tcp://HOST:8786, {_START}"
        ) from None
    except (OSError, EOFError) as exc:  # TimeoutError included: a scheduler that went silent after its handshake
        why = str(exc) if str(exc) and not isinstance(exc, TimeoutError) else f"no answer within {seconds:g} s"
        raise OptionError(
            f"the Dask scheduler {address!r} sent its handshake but did not answer a client's question "
            f"({why}; it hangs, or another program holds its port); restart it with `dask scheduler`, "
            f"or leave scheduler= out to run on this machine"
        ) from None


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
