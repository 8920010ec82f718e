"""Pools of worker processes that start warm and do not outlive the process that started them,
and the one ordered, bounded map that generation, import, the NumPy loader and the Dask runner
share.

A `ProcessPoolExecutor` worker waits on its task queue forever, so when the parent is killed
(SIGKILL, the OOM killer) its idle workers, and with them the shared memory they hold, would
stay until reboot. Each worker here watches its parent and exits when the parent is gone; then
multiprocessing's resource tracker removes the shared memory blocks they registered.

Workers are forked from multiprocessing's fork server, a clean process started once per process
that has imported the renderer and loaded its kernels (simulate/warm_start.py), so a worker
starts at once instead of loading them itself, as a spawned one would. Never forked from the
caller itself: forking a process that runs JAX, TensorFlow or zarr threads is unsafe. The fork
server is shared by the whole process: the first pool (ours or anyone's) starts it with its
preloaded modules; a worker forked from one that has not loaded ours loads them itself, as a
spawned one does. A forked worker takes the caller's working folder, sys.path and main module as
a spawned one does, but the environment variables the fork server started with.

Python starts its helper processes (the resource tracker, the fork server, spawned workers) as
`python -c ...`, which puts the current folder first on their import path: a `multiprocessing.py`
in the folder a command runs in would run in each of them. `safe_children`, called once where the
command line starts, makes every child odms-data starts (those above, pool and DataLoader workers,
Dask's) import from the caller's own path only; no spawn site guards itself.

The fork server and workers ignore SIGINT: Ctrl-C reaches the whole process group, and the caller
alone stops the work and says so in one line (the command line's interrupt handling).
Where there is no fork server (Windows), workers are spawned.
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.forkserver
import multiprocessing.resource_tracker
import os
import signal
import sys
import threading
from collections import deque
from collections.abc import Callable, Generator, Iterable
from concurrent.futures import Future, ProcessPoolExecutor
from itertools import islice
from typing import Any, TypeVar

from .interrupts import held, left_to_the_parent

Item = TypeVar("Item")
Handle = TypeVar("Handle")
Result = TypeVar("Result")

work_lock = threading.Lock()  # held by a worker around work an exit must not cut in two
WORK_PER_WORKER_S = 1.0  # the least work, in CPU-seconds, a worker is started for (workers_for)
WARM_START = "odms_data.simulate.warm_start"  # what the fork server imports, by name: no import edge
WorkerPool = ProcessPoolExecutor  # what worker_pool returns, for the callers' type hints


def cores() -> int:
    """The cores this process may run on."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def workers_for(work_s: float, most: int) -> int:
    """How many worker processes (at most `most`) to start for about `work_s` CPU-seconds of work:
    one per WORK_PER_WORKER_S. 1 means none: the work runs in the calling process, which starts
    nothing: below that, starting workers costs about what they save."""
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
    _start_fork_server()
    return context


def safe_children() -> None:
    """Make every child process this process starts import from this process's own sys.path, never
    from the folder it runs in: PYTHONSAFEPATH keeps `python -c` from putting the current folder
    first, PYTHONPATH gives this process's path (Python 3.11's fork server ignores the sys.path it is
    sent, so run from a clone of odms-data it preloaded the clone's odms_data where this process had
    imported the installed one). Called once, where the command line starts: a library leaves its
    caller's environment alone."""
    path = [os.getcwd() if p == "" else p for p in sys.path]
    os.environ.update(PYTHONSAFEPATH="1", PYTHONPATH=os.pathsep.join(path))


def one_opencv_thread() -> None:
    """OpenCV on one thread, in a process odms-data owns (the fork server and the workers it
    starts; the command line's: `commands_use_one_opencv_thread`), where the work is already
    spread over processes. OpenCV's thread count is the whole process's: a library caller's
    process keeps its own. Set before OpenCV's first parallel call: a forked child of a process
    whose OpenCV started its threads hangs setting it."""
    import cv2

    cv2.setNumThreads(1)


def commands_use_one_opencv_thread() -> None:
    """The command line's OpenCV, and that of every child it starts, on one thread: OpenCV reads
    OPENCV_FOR_THREADS_NUM when it starts, and the command line sets it before anything imports
    OpenCV (`--help` never does); a value the user set stays."""
    os.environ.setdefault("OPENCV_FOR_THREADS_NUM", "1")


def _start_fork_server() -> None:
    """Start the fork server, if not yet.

    SIGINT is blocked while the server is started, so that the server starts with it blocked until
    it ignores it (after its preloading): a Ctrl-C while it loaded the kernels printed its traceback
    (100 lines) above the caller's one line. Blocked, not ignored: a Ctrl-C in those milliseconds
    waits for the caller, which then stops (ignoring it lost it, and the command ran on); the
    resource tracker is started the same way. A first process that does nothing waits for the
    loading: a pool's worker whose start a Ctrl-C cut short failed, once forked, on its pool's
    semaphores, which the stopped caller had removed."""
    multiprocessing.resource_tracker.ensure_running()  # first: its start unblocks SIGINT when done
    with held({signal.SIGINT}):  # left last: a pending Ctrl-C is raised there
        multiprocessing.forkserver.ensure_running()
    ready = multiprocessing.get_context("forkserver").Process(target=_nothing, name="fork-server-ready")
    ready.start()
    ready.join()


def end_pool(pool: ProcessPoolExecutor) -> None:
    """End `pool` early: its work not yet started is cancelled, running work is awaited (a worker
    may be writing into a store about to be removed) and its workers are joined. The cancelling is
    left to the pool's own thread (`cancel_futures`): a `Future.cancel()` from here raced that thread
    marking every pending future failed when a worker died, as a stop signal to the whole process
    group kills them, and Python 3.11 printed that thread's InvalidStateError traceback after the
    one "interrupted" line (CPython gh-107219, fixed in 3.12)."""
    pool.shutdown(wait=True, cancel_futures=True)


def _nothing() -> None:
    pass


def _start_worker(initializer: Callable[..., None] | None, initargs: tuple[Any, ...]) -> None:
    left_to_the_parent()  # also from a fork server not ours: the caller stops us
    one_opencv_thread()
    parent = multiprocessing.parent_process()
    if parent is not None:
        threading.Thread(target=_exit_with, args=(parent,), daemon=True, name="exit-with-parent").start()
    if initializer is not None:
        initializer(*initargs)


def _exit_with(parent: multiprocessing.process.BaseProcess) -> None:
    parent.join()  # returns when the parent's end of the sentinel pipe closes, i.e. it has exited
    work_lock.acquire()  # e.g. a shared memory block created but not yet registered for cleanup
    os._exit(1)


def ordered_map(
    submit: Callable[[Item], Handle],
    collect: Callable[[Handle], Result],
    items: Iterable[Item],
    ahead: int | Callable[[], int],
    abandon: Callable[[list[Handle]], None],
) -> Generator[Result, None, None]:
    """`collect(submit(item))` for every item, in item order, with at most `ahead` items submitted
    but not yet collected; `ahead` may be a function, asked at every top-up (a cluster that grows).

    `submit` starts the work of an item and returns a handle (a future, say); `collect` waits for
    a handle's result. When iteration stops early or raises, `abandon` gets the handles still
    pending, oldest first (a pool's are ended with `end_pool`).
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


def pool_map(pool: ProcessPoolExecutor, fn: Callable[[Item], Result], items: Iterable[Item],
             ahead: int) -> Generator[Result, None, None]:
    """`fn(item)` on `pool` for every item, in item order, at most `ahead` in flight (`ordered_map`);
    stopped early, the pool ends (`end_pool`)."""
    return ordered_map(lambda item: pool.submit(fn, item), Future.result, items, ahead,
                       lambda _: end_pool(pool))
