"""One shard of a generated store: the examples it holds, made and written by one task.

A task draws and renders its examples, writes their masks (Zarr: straight into the shard; HDF5:
returns deflated chunks for the parent to store) and returns the small per-frame and
per-example arrays plus the example digests. It is pure in (params, seed, indices) up to the
store path, so any executor (local processes, a Dask cluster) gives the same store.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

from ..store.digest import example_digest, padded_frame_digest
from ..store.masks import FrameStats, largest_region, packed_width
from ..store.shard_writer import ShardChunks
from .batch_render import render_boxes
from .kernel import kernel
from .object_model import ExampleSpec, sample_examples
from .params import GeneratorParams

SOURCE = "generated"
DRAW_CHUNK = 8  # examples rendered together: fewer calls, the drawing's scratch image a few MB


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
    """Generate and write one shard; pure in (params, seed, indices) up to the store path.

    Allocation-light: each example's frames are packed into this thread's reused packed-example
    buffer (zeroed again where drawn), compressed as soon as it is packed, and each frame's
    digest hashes only its drawn rows and the zero rows below them (`padded_frame_digest`).
    """
    p = task.params
    n, (H, W) = p.n_obs, p.image_size
    k = task.stop - task.start
    z = np.empty(k * n)
    stats = FrameStats.empty(k * n)
    digests = []
    ids = example_ids(task.split, task.count, task.start, task.stop)
    chunks = ShardChunks(task.fmt, n)
    measured = np.empty(5, np.int64)
    with _buffer(n, H, W) as packed:
        for e, spec, boxes in _drawn(p, task.seed, task.start, task.stop):
            z[e * n : (e + 1) * n] = spec.z
            drawn, frame_digests = [], []
            for i, box in enumerate(boxes):  # render.render_frame's pixels
                y0 = y1 = 0
                if box is not None:
                    pixels, x0, y0, one_region = box
                    y1 = y0 + pixels.shape[0]
                    _pack_box(pixels, x0, y0, packed[i], measured)
                    f, (area, bx0, by0, bx1, by1) = e * n + i, measured
                    stats.area[f], stats.largest_area[f], stats.bbox[f] = area, area, measured[1:]
                    if area and not one_region:  # eroded or cut: maybe several regions
                        object_pixels = pixels[by0 - y0 : by1 - y0, bx0 - x0 : bx1 - x0]
                        stats.largest_area[f] = largest_region(object_pixels, int(area))
                    drawn.append(packed[i, y0:y1])
                frame_digests.append(padded_frame_digest(packed[i, y0:y1], y0, H, spec.z[i], spec.z[i]))
            chunks.add(packed)
            for rows in drawn:
                rows[...] = 0
            fd = np.frombuffer(b"".join(frame_digests), np.uint8).reshape(n, 32)
            digests.append(example_digest(ids[e], SOURCE, spec.z[0], fd))
    result = ShardResult(task.start, task.stop, z, stats, digests)
    result.deflated_chunks = chunks.write(task.path, task.start * n)
    return result


@kernel
def _pack_box(pixels, x0, y0, packed, measured):
    """OR the 0/1 `pixels`, a box at (x0, y0) of a frame, into the frame's packed rows (most
    significant bit first); measured = area, then the object's x0, y0, x1, y1 (zeros if none)."""
    area, lx, ly, hx, hy = 0, pixels.shape[1], pixels.shape[0], -1, -1
    for r in range(pixels.shape[0]):
        row, out, first, last = pixels[r], packed[y0 + r], -1, -1
        for c in range(pixels.shape[1]):
            if row[c]:
                x = x0 + c
                out[x >> 3] |= 0x80 >> (x & 7)
                area += 1
                first, last = c if first < 0 else first, c
        if first >= 0:
            lx, hx, ly, hy = min(lx, first), max(hx, last), min(ly, r), r
    measured[0] = area
    if area:
        measured[1], measured[2], measured[3], measured[4] = x0 + lx, y0 + ly, x0 + hx + 1, y0 + hy + 1
    else:
        measured[1:] = 0


def _drawn(
    p: GeneratorParams, seed: int, start: int, stop: int
) -> Iterator[tuple[int, ExampleSpec, list[tuple[np.ndarray, int, int, bool] | None]]]:
    """(position in the shard, draws, render_boxes of its frames) of examples start..stop-1,
    all sampled together and rendered DRAW_CHUNK examples at a time."""
    specs = sample_examples(p, seed, range(start, stop))
    for a in range(0, len(specs), DRAW_CHUNK):
        chunk = specs[a : a + DRAW_CHUNK]
        boxes = render_boxes(chunk, p)
        for j, spec in enumerate(chunk):
            yield a + j, spec, boxes[j * p.n_obs : (j + 1) * p.n_obs]


_reused = threading.local()  # per thread: a Dask worker may run several tasks at once


@contextmanager
def _buffer(n: int, H: int, W: int) -> Iterator[np.ndarray]:
    """This thread's zeroed (n, H, ceil(W/8)) packed-example buffer, made once per shape and
    reused: with many large temporaries, a process whose allocator returns freed memory eagerly
    (a Dask nanny sets MALLOC_TRIM_THRESHOLD_) spends its time on page faults. The caller leaves
    it zeroed; after an error it is dropped."""
    key = (n, H, W)
    if getattr(_reused, "key", None) != key:
        _reused.buffer = np.zeros((n, H, packed_width(W)), np.uint8)
    buffer, _reused.key = _reused.buffer, None  # taken: a failure below leaves it dropped
    yield buffer
    _reused.key = key
