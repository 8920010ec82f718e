"""Generating a store: shard-aligned tasks, run in-process, on a pool of worker processes or on a
Dask cluster (dask_runner.py, imported only when a scheduler is given).

A task makes the examples of one shard, writes their masks (Zarr: straight into the shard;
HDF5: returns deflated chunks for the parent to store) and returns the small per-frame and
per-example arrays plus the example digests, which the parent streams, in order, into the
store digest. Nothing depends on the executor, the number of workers or the shard size.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from concurrent.futures import Future
from dataclasses import dataclass, field
from functools import partial

import numpy as np

from ..errors import InputError
from ..parallel import ordered_map, spawn_pool
from ..store.digest import StoreDigest, example_digest, frame_digests
from ..store.format import StoreAttrs
from ..store.masks import FrameStats, pack, packed_width
from ..store.writer import Layout, StoreWriter, write_shard_masks
from .object_model import GeneratorParams, sample_example
from .render import render_frame

DEFAULT_EXAMPLES_PER_SHARD = 128
SOURCE = "generated"


def example_ids(split: str, count: int, start: int, stop: int) -> list[str]:
    """Ids `<split>/<index>` zero-padded to at least 6 digits."""
    digits = max(6, len(str(count - 1)))
    return [f"{split}/{i:0{digits}d}" for i in range(start, stop)]


@dataclass
class ShardTask:
    """Examples [start, stop) of a generated store, written into the store at `path`."""

    path: str
    fmt: str
    params: GeneratorParams
    seed: int
    split: str
    count: int
    start: int
    stop: int


@dataclass
class ShardResult:
    start: int
    stop: int
    z: np.ndarray
    stats: FrameStats
    example_digests: list[bytes]
    deflated_chunks: list[bytes] = field(default_factory=list)  # HDF5 only, one per example


def run_shard(task: ShardTask) -> ShardResult:
    """Generate and write one shard; pure in (params, seed, indices) up to the store path."""
    p = task.params
    n, (H, W) = p.n_obs, p.image_size
    k = task.stop - task.start
    packed = np.zeros((k * n, H, packed_width(W)), np.uint8)
    z = np.empty(k * n)
    stats = FrameStats.empty(k * n)
    digests = []
    ids = example_ids(task.split, task.count, task.start, task.stop)
    frame = np.zeros((H, W), np.uint8)
    for e, index in enumerate(range(task.start, task.stop)):
        spec = sample_example(p, task.seed, index)
        rows = slice(e * n, (e + 1) * n)
        z[rows] = spec.z
        for i in range(n):
            box = render_frame(spec, p, i, frame)
            if box is None:
                continue
            x0, y0, x1, y1 = box
            f = e * n + i
            stats.set(f, frame[y0:y1, x0:x1], x0, y0)
            packed[f, y0:y1] = pack(frame[y0:y1])
            frame[y0:y1, x0:x1] = 0
        fd = frame_digests(packed[rows], z[rows], z[rows])
        digests.append(example_digest(ids[e], SOURCE, spec.z[0], fd))
    result = ShardResult(task.start, task.stop, z, stats, digests)
    result.deflated_chunks = write_shard_masks(task.path, task.fmt, task.start * n, packed, n)
    return result


Progress = Callable[[int], None]


def _run_tasks(tasks: list[ShardTask], workers: int, progress: Progress | None) -> Iterator[ShardResult]:
    """Results in task order, each counted by `progress` as it comes."""
    for r in _run_local(tasks, workers):
        if progress:
            progress(r.stop - r.start)
        yield r


def _run_local(tasks: list[ShardTask], workers: int) -> Iterator[ShardResult]:
    """Results in task order; at most 2 * workers tasks in flight."""
    if workers <= 1:
        yield from map(run_shard, tasks)
        return
    with spawn_pool(workers) as pool:
        yield from ordered_map(partial(pool.submit, run_shard), Future.result, tasks, 2 * workers)


def generate(
    path: str,
    count: int,
    params: GeneratorParams,
    seed: int,
    *,
    split: str = "generated",
    preset: str | None = None,
    fmt: str | None = None,
    workers: int = 1,
    examples_per_shard: int = DEFAULT_EXAMPLES_PER_SHARD,
    overwrite: bool = False,
    progress: Progress | None = None,
    scheduler: str | None = None,
) -> StoreAttrs:
    """Generate `count` examples into a new store at `path`; returns its attributes.

    With `scheduler` (a Dask scheduler address) the shards run on that cluster instead of
    `workers` local processes; the store is the same.
    """
    if count < 1:
        raise InputError(f"count must be at least 1, got {count}")
    if seed < 0:
        raise InputError(f"seed must be a non-negative integer, got {seed}")
    if examples_per_shard < 1:
        raise InputError(f"examples per shard must be at least 1, got {examples_per_shard}")
    n, (H, W) = params.n_obs, params.image_size
    eps = min(examples_per_shard, count)
    ids_width = len(example_ids(split, count, count - 1, count)[0].encode())
    layout = Layout(
        height=H, width=W, n_frames=count * n, n_examples=count, max_obs=n,
        id_width=ids_width, source_width=len(SOURCE), frames_per_chunk=n,
        frames_per_shard=eps * n, examples_per_chunk=eps,
    )
    with StoreWriter(path, fmt, overwrite=overwrite) as w:
        w.create(layout)
        target = os.path.abspath(w.partial) if w.local else w.partial  # workers may have another cwd
        tasks = [
            ShardTask(target, w.format, params, seed, split, count, s, min(s + eps, count))
            for s in range(0, count, eps)
        ]
        if scheduler is None:
            results = _run_tasks(tasks, workers, progress)
        else:
            from .dask_runner import run_tasks

            results = run_tasks(tasks, scheduler, progress)
        digest = StoreDigest(H, W, count)
        for r in results:
            f0 = r.start * n
            w.write_frames(f0, r.z, r.z, r.stats)
            frame_index = np.arange(f0, r.stop * n).reshape(-1, n)
            w.write_examples(
                r.start, frame_index, r.z[::n].copy(),
                example_ids(split, count, r.start, r.stop), [SOURCE] * (r.stop - r.start),
            )
            for e, chunk in enumerate(r.deflated_chunks):
                w.write_mask_chunk(f0 + e * n, chunk)
            digest.update(r.example_digests)
        attrs = StoreAttrs(
            split=split, domain="generated", image_size=(H, W),
            counts={"examples": count, "frames": count * n, "labelled": count},
            generator={"preset": preset, "params": params.to_json(), "seed": seed},
            digest=digest.hexdigest(),
        )
        w.commit(attrs)
    return attrs
