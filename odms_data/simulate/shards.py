"""One shard of a generated store: the examples it holds, made and written by one task.

A task draws and renders its examples, writes their masks (Zarr: straight into the shard; HDF5:
returns deflated chunks for the parent to store) and returns the small per-frame and
per-example arrays plus the example digests. It is pure in (params, seed, indices) up to the
store path, so any executor (local processes, a Dask cluster) gives the same store.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..store.digest import example_digest, frame_digests
from ..store.masks import FrameStats, pack, packed_width
from ..store.writer import write_shard_masks
from .batch_render import render_boxes
from .object_model import sample_example
from .params import GeneratorParams

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
        for i, drawn in enumerate(render_boxes([spec], p)):  # render.render_frame's pixels
            if drawn is None:
                continue
            box, x0, y0 = drawn
            y1, x1 = y0 + box.shape[0], x0 + box.shape[1]
            f = e * n + i
            frame[y0:y1, x0:x1] = box
            stats.set(f, box, x0, y0)
            packed[f, y0:y1] = pack(frame[y0:y1])
            frame[y0:y1, x0:x1] = 0
        fd = frame_digests(packed[rows], z[rows], z[rows])
        digests.append(example_digest(ids[e], SOURCE, spec.z[0], fd))
    result = ShardResult(task.start, task.stop, z, stats, digests)
    result.deflated_chunks = write_shard_masks(task.path, task.fmt, task.start * n, packed, n)
    return result
