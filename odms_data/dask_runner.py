"""Running a store's tasks on a Dask cluster: the store builder's executor (store/build.py) when
given a scheduler address.

The tasks and the function that runs them are those of a local run, so the store and its digest
do not depend on the cluster. A task writes its whole Zarr shard of `masks` in one store write; a
task that raises is retried by Dask (`RETRIES`), one whose worker dies is rerun elsewhere (the
scheduler's `allowed-failures`), and a rerun rewrites the whole shard. Results are handed to the
caller in task order (parallel.ordered_map), with at most two tasks per worker thread (recounted
as the cluster scales) ahead of the oldest unfinished one.

Only this module imports Dask, and only a build with a scheduler imports this module.
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Callable, Generator, Iterable
from typing import Any, TypeVar

from ._version import __version__
from .errors import InputError, StoreError
from .extras import optional
from .parallel import ordered_map
from .urls import is_transient

Task = TypeVar("Task")
Result = TypeVar("Result")

RETRIES = 3  # reruns of a task that raised
CONNECT_TIMEOUT_S = 30
WORKER_WAIT_S = 60  # how long to wait for a first worker to join the scheduler


def _environment() -> dict[str, Any]:
    """What must match between this process and every worker (run on each worker)."""
    import numpy
    import zarr

    return {
        "pid": os.getpid(),
        "versions": {"odms-data": __version__, "numpy": numpy.__version__,
                     "zarr": zarr.__version__},
    }


def connect(address: str):
    """A `distributed.Client` for the scheduler at `address`, with at least one worker."""
    Client = optional("distributed", "generating on a Dask cluster").Client
    try:
        client = Client(address, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as e:
        raise InputError(f"scheduler {address}: cannot connect ({e})") from None
    try:
        client.wait_for_workers(1, timeout=WORKER_WAIT_S)
    except (OSError, TimeoutError) as e:
        client.close()
        raise InputError(f"scheduler {address}: no worker joined within {WORKER_WAIT_S} s") from e
    return client


def check_workers(client, address: str, path: str) -> None:
    """Refuse workers with other versions, and `memory://` stores that workers cannot see."""
    here = _environment()
    for worker, there in client.run(_environment).items():
        if there["versions"] != here["versions"]:
            raise InputError(
                f"scheduler {address}: worker {worker} runs {there['versions']}, this process "
                f"{here['versions']}; install the same versions on the workers"
            )
        if is_transient(path) and there["pid"] != here["pid"]:
            raise InputError(
                f"{path}: a memory:// store lives in this process, but worker {worker} of {address} is "
                "another process; write to file:// or s3://, or use an in-process (threads) cluster"
            )


def run_tasks(
    fn: Callable[[Task], Result], tasks: Iterable[Task], address: str, path: str
) -> Generator[Result, None, None]:
    """`fn(task)` of every task, run on the cluster at `address`, in task order; `path` is the
    store they write (checked to be one the workers see)."""
    first = next(iter(tasks := iter(tasks)), None)
    if first is None:
        return
    tasks = itertools.chain([first], tasks)
    with connect(address) as client:
        check_workers(client, address, path)

        def ahead() -> int:  # two tasks per worker thread, recounted as the cluster scales
            return max(4, 2 * sum(client.nthreads().values()))

        def submit(task: Task) -> tuple[Task, Any]:
            return task, client.submit(fn, task, retries=RETRIES, pure=False)

        def collect(handle: tuple[Task, Any]) -> Result:
            t, future = handle
            try:
                return future.result()
            except Exception as e:
                raise StoreError(
                    f"{path}: {_named(t)} failed on {address} after retries ({type(e).__name__}: {e})"
                ) from e

        def abandon(handles: list[tuple[Task, Any]]) -> None:
            for _, future in handles:
                future.cancel()

        yield from ordered_map(submit, collect, tasks, ahead, abandon)


def _named(task: Any) -> str:
    """A task by the rows it makes (a `start` and `stop`, where it has them)."""
    start, stop = getattr(task, "start", None), getattr(task, "stop", None)
    return "a task" if start is None or stop is None else f"the task of rows {start}-{stop - 1}"
