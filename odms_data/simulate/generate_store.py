"""Generating a store of masks: the mask generator as a store source (store/build.py), its tasks
a shard of examples each (shards.py), run in-process, on a pool of worker processes or on a Dask
cluster. Nothing depends on the executor, the number of workers or the shard size.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

from ..errors import InputError
from ..store.backends import MaskSink
from ..store.build import Rows, Sizes, Source, Workers, build, counting
from ..store.format import StoreAttrs
from ..store.manifests import SplitManifest, load_manifest
from ..store.masks import packed_width
from ..store.writer import Layout
from .params import DEFAULT_EXAMPLES_PER_SHARD, GENERATOR_VERSION, MAX_FRAMES, GeneratorParams
from .shard_task import SOURCE, ShardTask, example_ids

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
    if manifest.origin != "generated":
        raise InputError(f"split '{name}' is imported, not generated", fix="import")
    gen = manifest.generator or {}
    return SplitRecipe(manifest, manifest.count, gen["preset"], gen["seed"], dict(gen.get("params", {})))


def work_seconds(count: int, params: GeneratorParams) -> float:
    """About how many CPU-seconds generating `count` examples takes (to choose the workers)."""
    H, W = params.image_size
    return count * (EXAMPLE_S + params.n_obs * H * W / 1e6 * MEGAPIXEL_S)


def run_task(task: ShardTask) -> Rows:
    """shards.run_shard(task), the renderer imported only where the task runs, so that the process
    handing tasks out never loads it."""
    from .shards import run_shard

    return run_shard(task)


class GeneratedMasks(Source):
    """The mask generator as a store source: tasks of `per_task` examples (shard_task.py), each
    made and digested where it runs (shards.py)."""

    def __init__(self, count: int, params: GeneratorParams, seed: int, split: str, preset: str | None,
                 per_task: int) -> None:
        self.count, self.params, self.seed, self.split, self.preset = count, params, seed, split, preset
        self.per_task = per_task

    def sizes(self) -> Sizes:
        n, (H, W) = self.params.n_obs, self.params.image_size
        id_width = len(example_ids(self.split, self.count, self.count - 1, self.count)[0].encode())
        return Sizes(height=H, width=W, n_frames=self.count * n, n_examples=self.count, max_obs=n,
                     id_width=id_width, source_width=len(SOURCE), frames_per_task=self.per_task * n,
                     frames_per_chunk=n, examples_per_task=self.per_task, unit="examples")

    def tasks(self, sink: MaskSink | None, layout: Layout) -> Iterator[ShardTask]:
        assert sink is not None
        for s in range(0, self.count, self.per_task):  # made as run: a billion examples start at once
            yield ShardTask(sink, self.params, self.seed, self.split, self.count, s,
                            min(s + self.per_task, self.count))

    def runner(self) -> Callable[[ShardTask], Rows]:
        return run_task

    def attrs(self, digest: str) -> StoreAttrs:
        H, W = self.params.image_size
        n = self.params.n_obs
        return StoreAttrs(
            split=self.split, domain="generated", image_size=(H, W),
            counts={"examples": self.count, "frames": self.count * n, "labelled": self.count},
            generator={"version": GENERATOR_VERSION, "preset": self.preset, "params": self.params.to_json(),
                       "seed": self.seed},
            digest=digest,
        )


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
    progress: Callable[[int], None] | None = None,
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
    source = GeneratedMasks(count, params, seed, split, preset, eps)
    with Workers.for_work(work_seconds(count, params), -(-count // eps), workers, scheduler) as runners:
        return build(source, path, fmt, workers=runners, overwrite=overwrite,
                     progress=counting(progress) if progress else None)
