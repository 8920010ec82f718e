"""`odms-data generate --boxes PRESET` (or `--config FILE`): a store of boxes (FORMAT.md, version
2) from the seeded box generator (box_examples.py), as a store source (store/build.py). Example k
of (settings, seed) is generator index k, so a store's examples are those the box stream gives for
the same (settings, seed, index), bit for bit, whatever the workers or the examples per task. The
store records the preset whose settings it was made with, whether named or read from a config
file (box_config.py), or null when no preset has them."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass

import numpy as np

from ..errors import InputError
from ..store.backends import MaskSink
from ..store.build import Rows, Sizes, Source, Workers, build, counting
from ..store.digest import box_frame_digests, example_digest
from ..store.format import StoreAttrs
from ..store.writer import Layout
from .box_examples import (
    BOX_GENERATOR_VERSION,
    BOX_PRESETS,
    DEFAULT_BOX_EXAMPLES_PER_SHARD,
    BoxParams,
    preset_name,
    sample_box_examples,
)

SOURCE = "generated"


@dataclass(frozen=True)
class BoxTask:
    """Examples [start, stop) of a generated store of boxes."""

    params: BoxParams
    seed: int
    split: str
    start: int
    stop: int


def example_ids(split: str, start: int, stop: int) -> list[str]:
    return [f"{split}/{k:07d}" for k in range(start, stop)]


def run_box_task(task: BoxTask) -> Rows:
    """The rows and example digests of one task's examples; each frame's depth is the
    generator's true one (the movements carry the camera noise)."""
    n, E = task.params.num_pos, task.stop - task.start
    g = sample_box_examples(task.params, task.seed, np.arange(task.start, task.stop))
    box, move = g["boxes"].reshape(E * n, 4), g["move"].reshape(E * n, 3)
    depth = g["frame_depth"].reshape(E * n)
    fd = box_frame_digests(box, move, depth)
    ids, d1 = example_ids(task.split, task.start, task.stop), g["depth"]
    return Rows(
        task.start * n, {"box": box, "move": move, "depth": depth}, example_start=task.start,
        examples={"frame_index": np.arange(task.start * n, task.stop * n).reshape(E, n), "d1": d1,
                  "example_id": ids, "source": [SOURCE] * E},
        example_digests=[example_digest(ids[i], SOURCE, d1[i], fd[i * n : (i + 1) * n].tobytes())
                         for i in range(E)],
    )


class GeneratedBoxes(Source):
    """The box generator as a store source: tasks of `per_task` examples."""

    def __init__(self, count: int, params: BoxParams, seed: int, split: str, per_task: int) -> None:
        self.count, self.params, self.seed, self.split, self.per_task = count, params, seed, split, per_task
        self.preset = preset_name(params)

    def sizes(self) -> Sizes:
        n, (H, W) = self.params.num_pos, self.params.image_dim
        return Sizes(height=H, width=W, n_frames=self.count * n, n_examples=self.count, max_obs=n,
                     id_width=len(example_ids(self.split, self.count - 1, self.count)[0].encode()),
                     source_width=len(SOURCE), frames_per_task=self.per_task * n,
                     examples_per_task=self.per_task, kind="boxes", unit="examples")

    def tasks(self, sink: MaskSink | None, layout: Layout) -> Iterator[BoxTask]:
        for s in range(0, self.count, self.per_task):
            yield BoxTask(self.params, self.seed, self.split, s, min(s + self.per_task, self.count))

    def runner(self) -> Callable[[BoxTask], Rows]:
        return run_box_task

    def attrs(self, digest: str) -> StoreAttrs:
        n = self.params.num_pos
        params = {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self.params).items()}
        return StoreAttrs(split=self.split, domain="generated", image_size=self.params.image_dim,
                          counts={"examples": self.count, "frames": self.count * n, "labelled": self.count},
                          generator={"version": BOX_GENERATOR_VERSION, "preset": self.preset,
                                     "params": params, "seed": self.seed},
                          digest=digest, kind="boxes")


def generate_box_store(path: str, count: int, params: str | BoxParams, seed: int, *, split: str = "generated",
                       fmt: str | None = None, overwrite: bool = False,
                       progress: Callable[[int], None] | None = None, workers: int | None = None,
                       examples_per_shard: int = DEFAULT_BOX_EXAMPLES_PER_SHARD, scheduler: str | None = None
                       ) -> StoreAttrs:
    """Write `count` examples of `params` (settings, or a box preset's name) and `seed` as a store
    of boxes at `path`, `examples_per_shard` per task, on `workers` local processes (by default
    none: sampling is cheaper than starting workers, whose fork server loads the mask renderer) or
    on the Dask cluster of `scheduler`; the store is the same either way."""
    if isinstance(params, str):
        if params not in BOX_PRESETS:
            raise InputError(f"unknown box preset '{params}'; the presets are {', '.join(BOX_PRESETS)}")
        params = BOX_PRESETS[params]
    if count < 1 or seed < 0:
        raise InputError(f"need at least one example and a non-negative seed, got {count} and {seed}")
    if examples_per_shard < 1 or (workers is not None and workers < 1):
        raise InputError(f"examples per shard and workers must be at least 1, got {examples_per_shard} "
                         f"and {workers}")
    source = GeneratedBoxes(count, params, seed, split, min(examples_per_shard, count))
    tasks = -(-count // source.per_task)
    with Workers.for_work(0.0, tasks, workers, scheduler) as runners:
        return build(source, path, fmt, workers=runners, overwrite=overwrite,
                     progress=counting(progress) if progress else None)
