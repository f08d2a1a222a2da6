# SPDX-License-Identifier: MIT
"""Tasks on every core or on a Dask cluster, their results in order.

A command that runs many independent pieces of work (``mstc sweep``) cuts it
into *tasks*: small picklable values saying what to do (which scenes, which
strategies), never data a worker can make itself. A *work* object, picklable
too (an instance of a module-level class holding plain settings, such as a
library's path), turns a task into its *result* on a worker; it is the whole
interface (:class:`Work`)::

    class Work(Protocol[T, R]):
        def __call__(self, task: T) -> R: ...          # on a worker
        def split(self, task: T) -> list[T]: ...        # its parts; [] when it is one run
        def crashed(self, task: T, why: str) -> R: ...  # a one-run task that kills its worker

:func:`run_tasks` takes the tasks from an iterable only as it needs them,
runs them on a local process pool (``scheduler=None``) or on the Dask
cluster of a scheduler, and calls ``emit(task, result)`` once for each
task, in the order of the tasks, whichever finished first. It holds at most
:data:`IN_FLIGHT` tasks a worker sent (running or waiting in the worker)
and :data:`WAITING` more finished ones waiting for an earlier task, so its
memory does not grow with the number of tasks. ``emit`` runs in the calling
thread; an exception it raises ends the run (and goes up).

A worker that dies (a crash in a C library, a process killed, a machine
lost) loses the tasks it held, never their results:

- on the pool, every task that was running when the pool broke runs again,
  one at a time on a fresh worker process; one that kills that worker too
  is split (:meth:`Work.split`) and its parts are run the same way, down to
  tasks of one run, whose result is then :meth:`Work.crashed`;
- on Dask, the scheduler gives the tasks of a lost worker to the others; a
  task that keeps killing workers (``KilledWorker``) is split the same way.

Each task's result is emitted once: a task run again emits its one result,
a split task its parts' results, in order. The pool's workers are forked
from the calling process where the platform can (Linux) and the caller runs
no other thread, so a worker starts in milliseconds with the modules the
caller has imported; otherwise they are spawned. A forked worker holds
copies of the caller's open files: it writes to none of them, and ends
without flushing them (``os._exit``).
"""

from __future__ import annotations

import importlib.util
import multiprocessing
import socket
import threading
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Generic, Protocol, TypeVar

from mstc.errors import ClusterError, DependencyError, UsageError

T = TypeVar("T")
R = TypeVar("R")
R_co = TypeVar("R_co", covariant=True)

IN_FLIGHT = 2
"""Tasks sent a worker at a time: one running, one waiting, so that a worker
never waits for the caller and the caller holds no more."""
WAITING = 2
"""Finished tasks a worker may leave waiting for an earlier, slower one
before no more are sent."""
DIED = "the worker process died running this"
"""Why a one-run task that kills its worker failed (:meth:`Work.crashed`)."""


class Work(Protocol[T, R_co]):
    """Turns a task into its result, on a worker (the module's docstring)."""

    def __call__(self, task: T) -> R_co:
        """Run @p task (on a worker)."""

    def split(self, task: T) -> list[T]:
        """@p task's parts, in order, whose results stand for its result;
        [] when it is a single run and cannot be split."""

    def crashed(self, task: T, why: str) -> R_co:
        """The result of @p task, a single run, which kills its worker."""


Emit = Callable[[T, R], None]

_PENDING: Any = object()


class _Slot(Generic[T, R]):
    """A task taken from the caller: its result when it came back, or its
    parts when it was split."""

    __slots__ = ("task", "result", "parts")

    def __init__(self, task: T) -> None:
        self.task = task
        self.result: R = _PENDING
        self.parts: list[_Slot[T, R]] | None = None

    def ready(self) -> bool:
        if self.parts is not None:
            return all(p.ready() for p in self.parts)
        return self.result is not _PENDING

    def emit(self, emit: Emit[T, R]) -> None:
        if self.parts is not None:
            for part in self.parts:
                part.emit(emit)
        else:
            emit(self.task, self.result)

    def split(self, work: Work[T, R], why: str) -> list[_Slot[T, R]]:
        """Split this task into parts (returned, to be run) or, a single
        run, give it its :meth:`Work.crashed` result (nothing to run)."""
        parts = work.split(self.task)
        if not parts:
            self.result = work.crashed(self.task, why)
            return []
        self.parts = [_Slot(p) for p in parts]
        return self.parts


class _Window(Generic[T, R]):
    """The tasks taken and not yet emitted, in order."""

    def __init__(self, tasks: Iterable[T], emit: Emit[T, R]) -> None:
        self._tasks: Iterator[T] = iter(tasks)
        self._emit = emit
        self.slots: deque[_Slot[T, R]] = deque()

    def take(self) -> _Slot[T, R] | None:
        """The next task, or None when there is none."""
        for task in self._tasks:
            slot: _Slot[T, R] = _Slot(task)
            self.slots.append(slot)
            return slot
        return None

    def flush(self) -> None:
        """Emit every result whose earlier tasks are all emitted."""
        while self.slots and self.slots[0].ready():
            self.slots.popleft().emit(self._emit)

    def __len__(self) -> int:
        return len(self.slots)


def run_tasks(
    tasks: Iterable[T] | Callable[[int], Iterable[T]],
    work: Work[T, R],
    emit: Emit[T, R],
    *,
    workers: int = 1,
    scheduler: str | None = None,
) -> None:
    """Run @p tasks with @p work, calling @p emit in their order (the
    module's docstring).

    :param tasks: the tasks, or a function of the number of workers (the
        pool's, or the cluster's when it starts) that gives them, to size
        them for the workers.
    :param workers: processes of the local pool (ignored with @p scheduler).
    :param scheduler: a Dask scheduler's address, or None for the local pool.

    :raises DependencyError: @p scheduler without Dask installed.
    :raises ClusterError: the scheduler cannot be reached.
    """
    if scheduler is not None:
        _run_dask(tasks, emit, work, scheduler)
    else:
        window = _Window(tasks(workers) if callable(tasks) else tasks, emit)
        _run_pool(window, work, workers, _context())


def _context() -> multiprocessing.context.BaseContext:
    """How the pool starts its workers: forked from this process where the
    platform can and no other thread runs (a worker then starts with what
    this process imported, in milliseconds), else spawned (a worker imports
    the work's module itself)."""
    if "fork" in multiprocessing.get_all_start_methods() and threading.active_count() == 1:
        return multiprocessing.get_context("fork")
    return multiprocessing.get_context("spawn")


def _run_pool(
    window: _Window[T, R],
    work: Work[T, R],
    workers: int,
    context: multiprocessing.context.BaseContext,
) -> None:
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=context)
    running: dict[Future[R], _Slot[T, R]] = {}
    try:
        while True:
            while len(running) < workers * IN_FLIGHT and len(window) < workers * (
                IN_FLIGHT + WAITING
            ):
                slot = window.take()
                if slot is None:
                    break
                running[pool.submit(work, slot.task)] = slot
            if not running:
                break
            finished, _ = wait(running, return_when=FIRST_COMPLETED)
            lost = _collect(finished, running)
            if lost:
                # A worker died: every task still running is lost with it
                # (the pool fails them all); take what had finished.
                wait(running)
                lost += _collect(set(running), running)
                pool.shutdown(wait=True)
                _isolate(lost, work, context)
                pool = ProcessPoolExecutor(max_workers=workers, mp_context=context)
            window.flush()
    except BaseException:
        _stop(pool)
        raise
    pool.shutdown()


def _stop(pool: ProcessPoolExecutor) -> None:
    """Interrupted (Ctrl-C) or failed: stop the workers now, their tasks
    with them, rather than let them finish those they hold (a task is run
    again when the caller resumes). The workers are the pool's processes
    (CPython's ``_processes``; Python 3.14 names this ``terminate_workers``)."""
    processes = getattr(pool, "_processes", None) or {}
    for process in list(processes.values()):
        process.terminate()
    pool.shutdown(wait=False, cancel_futures=True)


def _collect(finished: set[Future[R]], running: dict[Future[R], _Slot[T, R]]) -> list[_Slot[T, R]]:
    """Take the results of @p finished out of @p running; the slots whose
    worker died (the pool broke) are returned."""
    lost = []
    for fut in finished:
        slot = running.pop(fut)
        try:
            slot.result = fut.result()
        except BrokenProcessPool:
            lost.append(slot)
    return lost


def _isolate(
    slots: list[_Slot[T, R]], work: Work[T, R], context: multiprocessing.context.BaseContext
) -> None:
    """Run the tasks of @p slots one at a time on one worker process: a
    task that kills it is split and its parts run the same way; a single
    run that does gets its :meth:`Work.crashed` result."""
    todo = deque(slots)
    pool: ProcessPoolExecutor | None = None
    try:
        while todo:
            slot = todo.popleft()
            if pool is None:
                pool = ProcessPoolExecutor(max_workers=1, mp_context=context)
            try:
                slot.result = pool.submit(work, slot.task).result()
            except BrokenProcessPool:
                pool.shutdown(wait=True)
                pool = None
                todo.extendleft(reversed(slot.split(work, DIED)))
    except BaseException:
        if pool is not None:
            _stop(pool)
            pool = None
        raise
    finally:
        if pool is not None:
            pool.shutdown(wait=True)


def require_dask() -> None:
    """Dask's ``distributed`` is installed (the extra ``mstc[cluster]``).

    :raises DependencyError: it is not.
    """
    if importlib.util.find_spec("distributed") is None:
        raise DependencyError(
            "a Dask cluster needs Dask's distributed, which is not installed: "
            "pip install 'mstc[cluster]' (docs/sweeps.md)"
        )


SCHEDULER_TIMEOUT = 5.0
"""How long :func:`check_scheduler` waits for a scheduler's port to answer [s]."""


def check_scheduler(address: str) -> None:
    """@p address is a Dask scheduler's, and its port answers (tcp:// and
    tls://): a wrong or closed address is said at once, before anything runs,
    not after the client's 30 s of retries.

    :raises DependencyError: Dask is not installed.
    :raises UsageError: @p address is not an address.
    :raises ClusterError: nothing answers there.
    """
    require_dask()
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, location = parse_address(address)
        host, port = parse_host_port(location) if scheme in ("tcp", "tls") else ("", 0)
    except ValueError as exc:
        raise UsageError(
            f"--scheduler {address}: {exc} (expected tcp://HOST:PORT, docs/sweeps.md)"
        ) from exc
    if not host:
        return
    try:
        socket.create_connection((host, port), timeout=SCHEDULER_TIMEOUT).close()
    except OSError as exc:
        why = exc.strerror or str(exc) or type(exc).__name__
        raise ClusterError(f"cannot reach the Dask scheduler at {address}: {why}") from exc


def _run_dask(
    tasks: Iterable[T] | Callable[[int], Iterable[T]],
    emit: Emit[T, R],
    work: Work[T, R],
    scheduler: str,
) -> None:
    require_dask()
    from distributed import Client, as_completed
    from distributed.scheduler import KilledWorker

    try:
        client = Client(scheduler, timeout="30s")
    except OSError as exc:  # distributed's TimeoutError too
        raise ClusterError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from exc
    with client:
        size = max(1, len(client.scheduler_info()["workers"]))
        window = _Window(tasks(size) if callable(tasks) else tasks, emit)
        running: dict[Any, _Slot[T, R]] = {}
        queue = as_completed()

        def send(slot: _Slot[T, R]) -> None:
            fut = client.submit(work, slot.task, pure=False)
            running[fut] = slot
            queue.add(fut)

        def fill() -> None:
            workers = max(1, len(client.scheduler_info()["workers"]))
            while len(running) < workers * IN_FLIGHT and len(window) < workers * (
                IN_FLIGHT + WAITING
            ):
                slot = window.take()
                if slot is None:
                    return
                send(slot)

        fill()
        for fut in queue:
            slot = running.pop(fut)
            try:
                slot.result = fut.result()
            except KilledWorker:
                for part in slot.split(work, DIED):
                    send(part)
            fut.release()
            window.flush()
            fill()
