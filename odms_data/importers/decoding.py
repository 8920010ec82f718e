"""Decoding masks on worker processes: one shard-aligned range of frames per task.

A task reads (`MaskSource.read`), checks and packs its masks, computes their statistics and frame digests, and
writes them into their shard (Zarr) or returns deflated chunks (HDF5); a bad file becomes a
failure in the result instead. libpng and libjpeg print their own complaints on stderr, which is
silenced while they decode.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import AbstractContextManager, contextmanager
from dataclasses import dataclass, field
from typing import TypeVar

import numpy as np

from ..errors import InputError
from ..parallel import WorkerPool, cores, end_pool, pool_map, worker_pool
from ..store.digest import frame_digests
from ..store.masks import FrameStats, pack, packed_width
from ..store.shard_writer import MaskSink
from .plan import MaskSource

Item = TypeVar("Item")
Result = TypeVar("Result")


@dataclass
class FrameTask:
    """Frame rows [start, start + len(masks)) of the store being written, their masks through `sink`."""

    sink: MaskSink
    start: int
    masks: Sequence[MaskSource]
    z: np.ndarray
    depth: np.ndarray
    size: tuple[int, int]  # (height, width) every mask must have, checked before it is decoded
    threshold: int
    collect_all: bool


@dataclass
class FrameResult:
    start: int
    stats: FrameStats = field(default_factory=lambda: FrameStats.empty(0))  # both set when no file failed
    digests: np.ndarray = field(default_factory=lambda: np.empty((0, 32), np.uint8))
    returned_masks: list[bytes] = field(default_factory=list)  # for StoreWriter.receive_masks
    failures: list[tuple[int, str]] = field(default_factory=list)


def run_frames(task: FrameTask) -> FrameResult:
    """Read, check, pack and write one shard's masks; failures instead when a source is bad."""
    H, W = task.size
    k = len(task.masks)
    packed = np.zeros((k, H, packed_width(W)), np.uint8)
    stats = FrameStats.empty(k)
    result = FrameResult(task.start)
    done: dict[int, int] = {}  # a source repeated within the task (the same object) is read once
    for i, f in enumerate(task.masks):
        if id(f) in done:
            packed[i] = packed[done[id(f)]]
            stats.copy(done[id(f)], i)
            continue
        try:
            m = f.read(task.threshold, (H, W))
        except InputError as e:
            result.failures.append((task.start + i, str(e)))
            if not task.collect_all:
                break
            continue
        stats.set(i, m)
        packed[i] = pack(m)
        done[id(f)] = i
    if result.failures:
        return result
    result.stats, result.digests = stats, frame_digests(packed, task.z, task.depth)
    result.returned_masks = task.sink.write_packed(task.start, packed)
    return result


@contextmanager
def _quiet_stderr() -> Iterator[None]:
    """Silence file descriptor 2: libpng and libjpeg print their own complaints there."""
    sys.stderr.flush()
    saved = os.dup(2)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(devnull)


def _silence_worker() -> None:
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 2)


class Workers:
    """A pool of decoding processes (or none, for workers <= 1) shared by several stores."""

    def __init__(self, workers: int | None = None) -> None:
        self.n = workers if workers is not None else cores()
        self.pool: WorkerPool | None = None

    def __enter__(self) -> Workers:
        if self.n > 1:
            self.pool = worker_pool(self.n, _silence_worker)
        return self

    def __exit__(self, *exc) -> None:
        if self.pool is not None:
            end_pool(self.pool)

    @contextmanager
    def map(self, fn: Callable[[Item], Result], items: Iterable[Item]) -> Iterator[Iterator[Result]]:
        """`fn(item)` for every item (a picklable top-level function), results in item order. Left
        early, the pool ends (parallel.pool_map): items not started are cancelled and running ones
        awaited, so that no worker writes into a store being removed."""
        if self.pool is None:
            def serial() -> Iterator[Result]:
                for t in items:
                    with _quiet_stderr():
                        r = fn(t)
                    yield r

            yield serial()
            return
        results = pool_map(self.pool, fn, items, 2 * self.n)
        try:
            yield results
        finally:
            results.close()

    def run(self, tasks: list[FrameTask]) -> AbstractContextManager[Iterator[FrameResult]]:
        """`run_frames` of every task, in order (see `map`)."""
        return self.map(run_frames, tasks)
