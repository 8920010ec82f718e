"""Pools of worker processes that start warm and do not outlive the process that started them,
and the one ordered, bounded map that generation, import, the NumPy loader and the Dask runner
share.

A `ProcessPoolExecutor` worker waits on its task queue forever, so when the parent is killed
(SIGKILL, the OOM killer) its idle workers, and with them the shared memory they hold, would
stay until reboot. Each worker here watches its parent and exits when the parent is gone; then
multiprocessing's resource tracker removes the shared memory blocks they registered.

Workers are forked from multiprocessing's fork server, a clean process started once per process
that has imported the renderer and loaded its kernels (simulate/warm_start.py), so a worker
starts in milliseconds instead of the 1.6 CPU-seconds a spawned one spent. Never forked from the
caller itself: forking a process that runs JAX, TensorFlow or zarr threads is unsafe. The fork
server is shared by the whole process: the first pool (ours or anyone's) starts it with its
preloaded modules; a worker forked from one that has not loaded ours loads them itself, as a
spawned one does. A forked worker takes the caller's working folder, sys.path and main module as
a spawned one does, but the environment variables the fork server started with. Where there is
no fork server (Windows), workers are spawned.
"""

from __future__ import annotations

import multiprocessing
import os
import threading
from collections import deque
from collections.abc import Callable, Generator, Iterable
from concurrent.futures import ProcessPoolExecutor
from itertools import islice
from typing import Any, TypeVar

Item = TypeVar("Item")
Handle = TypeVar("Handle")
Result = TypeVar("Result")

work_lock = threading.Lock()  # held by a worker around work an exit must not cut in two
WORK_PER_WORKER_S = 1.0  # the least work, in CPU-seconds, a worker is started for (workers_for)
WARM_START = "odms_data.simulate.warm_start"  # what the fork server imports, by name: no import edge


def cores() -> int:
    """The cores this process may run on."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def workers_for(work_s: float, most: int) -> int:
    """How many worker processes (at most `most`) to start for about `work_s` CPU-seconds of work:
    one per WORK_PER_WORKER_S. 1 means none: the work runs in the calling process, which starts
    nothing. (On 2 cores, with workers forked from the fork server, 480x640 examples on 2 workers
    took as long as in-process for 1,000, 0.8 to 0.9 of the time for 2,000 to 3,000, 0.7 for 4,000.)"""
    return max(1, min(most, int(work_s / WORK_PER_WORKER_S)))


def worker_pool(
    workers: int, initializer: Callable[..., None] | None = None, initargs: tuple[Any, ...] = ()
) -> ProcessPoolExecutor:
    """A pool of `workers` processes, forked from the fork server where there is one (the module
    says why), each running `initializer(*initargs)` first."""
    return ProcessPoolExecutor(
        workers, mp_context=_context(), initializer=_start_worker, initargs=(initializer, initargs)
    )


def _context() -> multiprocessing.context.BaseContext:
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload([WARM_START])  # read when the fork server starts, if not yet
    return context


def _start_worker(initializer: Callable[..., None] | None, initargs: tuple[Any, ...]) -> None:
    parent = multiprocessing.parent_process()
    if parent is not None:
        threading.Thread(target=_exit_with, args=(parent,), daemon=True, name="exit-with-parent").start()
    if initializer is not None:
        initializer(*initargs)


def _exit_with(parent: multiprocessing.process.BaseProcess) -> None:
    parent.join()  # returns when the parent's end of the sentinel pipe closes, i.e. it has exited
    work_lock.acquire()  # e.g. a shared memory block created but not yet registered for cleanup
    os._exit(1)


def _cancel(handles: list[Any]) -> None:
    for h in handles:
        h.cancel()


def ordered_map(
    submit: Callable[[Item], Handle],
    collect: Callable[[Handle], Result],
    items: Iterable[Item],
    ahead: int | Callable[[], int],
    abandon: Callable[[list[Handle]], None] = _cancel,
) -> Generator[Result, None, None]:
    """`collect(submit(item))` for every item, in item order, with at most `ahead` items submitted
    but not yet collected; `ahead` may be a function, asked at every top-up (a cluster that grows).

    `submit` starts the work of an item and returns a handle (a future, say); `collect` waits for
    a handle's result. When iteration stops early or raises, `abandon` gets the handles still
    pending, oldest first (by default each one's `cancel()` is called).
    """
    todo = iter(items)
    pending: deque[Handle] = deque()

    def top_up() -> None:
        limit = ahead() if callable(ahead) else ahead
        pending.extend(map(submit, islice(todo, max(0, limit - len(pending)))))

    try:
        top_up()
        while pending:
            result = collect(pending[0])
            pending.popleft()
            top_up()
            yield result
            del result  # freed as soon as the caller drops it (a batch's lent block, say)
    finally:
        if pending:
            abandon(list(pending))
