"""Generating a store: shard-aligned tasks (shards.py), run in-process, on a pool of worker
processes or on a Dask cluster (dask_runner.py, imported only when a scheduler is given).

The parent writes the small arrays the tasks return and streams their example digests, in
order, into the store digest. Nothing depends on the executor, the number of workers or the
shard size.
"""

from __future__ import annotations

from collections.abc import Callable, Generator, Iterable, Iterator
from contextlib import closing
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import InputError
from ..parallel import cores, pool_map, worker_pool, workers_for
from ..store.digest import StoreDigest
from ..store.format import StoreAttrs
from ..store.manifests import SplitManifest, load_manifest
from ..store.masks import packed_width
from ..store.writer import Layout, StoreWriter
from .params import DEFAULT_EXAMPLES_PER_SHARD, GENERATOR_VERSION, MAX_FRAMES, GeneratorParams
from .shard_run import run
from .shard_task import SOURCE, ShardResult, ShardTask, example_ids

Progress = Callable[[int], None]
SHARD_BYTES = 2**28  # the most packed mask bytes one shard task holds
EXAMPLE_S, MEGAPIXEL_S = 1e-4, 1.9e-4  # generation's CPU-seconds per example and per megapixel of frames


@dataclass(frozen=True)
class SplitRecipe:
    """What generates a named split of splits/, from its manifest: count, preset, seed and the
    parameters that differ from the preset's."""

    manifest: SplitManifest
    count: int
    preset: str
    seed: int
    overrides: dict[str, Any]


def split_recipe(name: str) -> SplitRecipe:
    """The recipe of generated split `name`; InputError for an unknown or imported split."""
    manifest = load_manifest(name)
    if manifest.kind != "generated":
        raise InputError(f"split '{name}' is imported, not generated", fix="import")
    gen = manifest.generator or {}
    return SplitRecipe(manifest, manifest.count, gen["preset"], gen["seed"], dict(gen.get("params", {})))


def work_seconds(count: int, params: GeneratorParams) -> float:
    """About how many CPU-seconds generating `count` examples takes (to choose the workers)."""
    H, W = params.image_size
    return count * (EXAMPLE_S + params.n_obs * H * W / 1e6 * MEGAPIXEL_S)


def _run_tasks(
    tasks: Iterable[ShardTask], workers: int, progress: Progress | None
) -> Generator[ShardResult, None, None]:
    """Results in task order, each counted by `progress` as it comes."""
    for r in _run_local(tasks, workers):
        if progress:
            progress(r.stop - r.start)
        yield r


def _run_local(tasks: Iterable[ShardTask], workers: int) -> Iterator[ShardResult]:
    """Results in task order; at most 2 * workers tasks in flight."""
    if workers <= 1:
        yield from map(run, tasks)
        return
    with worker_pool(workers) as pool:
        yield from pool_map(pool, run, tasks, 2 * workers)


def generate(
    path: str,
    count: int,
    params: GeneratorParams,
    seed: int,
    *,
    split: str = "generated",
    preset: str | None = None,
    fmt: str | None = None,
    workers: int | None = None,
    examples_per_shard: int = DEFAULT_EXAMPLES_PER_SHARD,
    overwrite: bool = False,
    progress: Progress | None = None,
    scheduler: str | None = None,
) -> StoreAttrs:
    """Generate `count` examples into a new store at `path`; returns its attributes.

    `workers` local processes (1: in this process); by default as many as the amount of work is
    worth, up to one per core (parallel.workers_for). With `scheduler` (a Dask scheduler address)
    the shards run on that cluster instead. The store is the same either way.
    """
    if count < 1:
        raise InputError(f"count must be at least 1, got {count}")
    if seed < 0:
        raise InputError(f"seed must be a non-negative integer, got {seed}")
    if workers is not None and workers < 1:
        raise InputError(f"workers must be at least 1, got {workers}")
    if examples_per_shard < 1:
        raise InputError(f"examples per shard must be at least 1, got {examples_per_shard}")
    n, (H, W) = params.n_obs, params.image_size
    if count * n > MAX_FRAMES:
        raise InputError(f"{count} examples of {n} frames make {count * n:.3g} frames; a store holds at "
                         f"most {MAX_FRAMES:.3g} (2^40)")
    # a shard's masks are held in memory by its task: at most SHARD_BYTES, whatever was asked
    eps = max(1, min(examples_per_shard, count, SHARD_BYTES // (n * H * packed_width(W))))
    ids_width = len(example_ids(split, count, count - 1, count)[0].encode())
    layout = Layout(
        height=H, width=W, n_frames=count * n, n_examples=count, max_obs=n,
        id_width=ids_width, source_width=len(SOURCE), frames_per_chunk=n,
        frames_per_shard=eps * n, examples_per_chunk=eps,
    )
    with StoreWriter(path, fmt, overwrite=overwrite) as w:
        w.create(layout)
        sink = w.mask_sink()
        tasks = (  # made as they are run: a billion examples start at once
            ShardTask(sink, params, seed, split, count, s, min(s + eps, count))
            for s in range(0, count, eps)
        )
        if scheduler is None:
            if workers is None:
                workers = workers_for(work_seconds(count, params), cores())
            results = _run_tasks(tasks, min(workers, -(-count // eps)), progress)  # no more than tasks
        else:
            from .dask_runner import run_tasks

            results = run_tasks(tasks, scheduler, progress)
        digest = StoreDigest(H, W, count)
        with closing(results):  # on an error, the workers stop writing before the store is removed
            for r in results:
                f0 = r.start * n
                w.write_frames(f0, r.z, r.z, r.stats)
                frame_index = np.arange(f0, r.stop * n).reshape(-1, n)
                w.write_examples(
                    r.start, frame_index, r.z[::n].copy(),
                    example_ids(split, count, r.start, r.stop), [SOURCE] * (r.stop - r.start),
                )
                w.receive_masks(f0, r.returned_masks)
                digest.update(r.example_digests)
        attrs = StoreAttrs(
            split=split, domain="generated", image_size=(H, W),
            counts={"examples": count, "frames": count * n, "labelled": count},
            generator={
                "version": GENERATOR_VERSION, "preset": preset, "params": params.to_json(), "seed": seed,
            },
            digest=digest.hexdigest(),
        )
        w.commit(attrs)
    return attrs
