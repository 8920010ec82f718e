"""Pools of spawned worker processes that do not outlive the process that started them.

A `ProcessPoolExecutor` worker waits on its task queue forever, so when the parent is killed
(SIGKILL, the OOM killer) its idle workers, and with them the shared memory they hold, would
stay until reboot. Each worker here watches its parent and exits when the parent is gone; then
multiprocessing's resource tracker removes the shared memory blocks they registered.
Spawned, not forked: forking a process that runs JAX, TensorFlow or zarr threads is unsafe.
"""

from __future__ import annotations

import multiprocessing
import os
import threading
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from typing import Any

uninterrupted = threading.Lock()  # held by a worker around work an exit must not cut in two


def spawn_pool(
    workers: int, initializer: Callable[..., None] | None = None, initargs: tuple[Any, ...] = ()
) -> ProcessPoolExecutor:
    """A pool of `workers` spawned processes, each running `initializer(*initargs)` first."""
    return ProcessPoolExecutor(
        workers, mp_context=multiprocessing.get_context("spawn"), initializer=_start_worker,
        initargs=(initializer, initargs),
    )


def _start_worker(initializer: Callable[..., None] | None, initargs: tuple[Any, ...]) -> None:
    parent = multiprocessing.parent_process()
    if parent is not None:
        threading.Thread(target=_exit_with, args=(parent,), daemon=True, name="exit-with-parent").start()
    if initializer is not None:
        initializer(*initargs)


def _exit_with(parent: multiprocessing.process.BaseProcess) -> None:
    parent.join()  # returns when the parent's end of the sentinel pipe closes, i.e. it has exited
    uninterrupted.acquire()  # e.g. a shared memory block created but not yet registered for cleanup
    os._exit(1)
