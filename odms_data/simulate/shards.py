"""One shard of a generated store: the examples it holds, made and written by one task.

A task draws and renders its examples, writes their masks (Zarr: straight into the shard; HDF5:
returns deflated chunks for the parent to store) and returns the small per-frame and
per-example arrays plus the example digests, as the store builder's `Rows`. It is pure in
(params, seed, indices) up to the store path, so any executor (local processes, a Dask cluster)
gives the same store.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np

from ..store.build import Rows
from ..store.digest import example_digest, frame_tails, padded_frame_digests
from ..store.masks import FrameStats, largest_region, packed_width
from .batch_render import FrameBoxes, render_boxes
from .kernel import kernel
from .object_model import ExampleSpec, sample_examples
from .params import GeneratorParams
from .shard_task import SOURCE, ShardTask, example_ids

DRAW_CHUNK = 8  # examples rendered together: fewer calls, the drawing's scratch image a few MB


def run_shard(task: ShardTask) -> Rows:
    """Generate and write one shard; pure in (params, seed, indices) up to the store path.

    Allocation-light: each example's frames are packed into this thread's reused packed-example
    buffer (zeroed again where drawn), compressed as soon as it is packed, and each frame's
    digest hashes only its drawn rows and the zero rows below them (`padded_frame_digests`).
    """
    p = task.params
    n, (H, W) = p.n_obs, p.image_size
    specs = sample_examples(p, task.seed, range(task.start, task.stop))
    z = np.concatenate([spec.z for spec in specs])  # tasks are never empty
    tails = frame_tails(z, z)  # a generated frame's depth is its z
    stats = FrameStats.empty(len(z))
    digests = []
    ids = example_ids(task.split, task.count, task.start, task.stop)
    chunks = task.sink.chunks()
    measured = np.empty((n, 5), np.int64)  # per frame: area, then the object's x0, y0, x1, y1
    with _buffer(n, H, W) as packed:
        for e, spec, boxes, b in _drawn(p, specs):
            f, mine = slice(e * n, (e + 1) * n), slice(b, b + n)
            _pack_boxes(boxes.image, boxes.top[mine], boxes.left[mine], boxes.lo[mine], boxes.hi[mine],
                        packed, measured)
            stats.area[f] = stats.largest_area[f] = measured[:, 0]
            stats.bbox[f] = measured[:, 1:]
            for i in np.flatnonzero(~boxes.one_region[mine] & (measured[:, 0] > 0)).tolist():  # eroded or cut
                stats.largest_area[f.start + i] = _largest_region(boxes, b + i, measured[i])
            chunks.add(packed)
            y0, y1 = boxes.lo[mine, 1], boxes.hi[mine, 1]
            fd = padded_frame_digests(packed, y0.tolist(), y1.tolist(), tails[f])
            digests.append(example_digest(ids[e], SOURCE, spec.z[0], fd))
            _clear_rows(packed, y0, y1)
    f0 = task.start * n
    return Rows(
        f0, {"z": z, "depth": z, "area": stats.area, "largest_area": stats.largest_area, "bbox": stats.bbox},
        returned_masks=task.sink.write(f0, chunks), example_start=task.start,
        examples={"frame_index": np.arange(f0, task.stop * n).reshape(-1, n), "d1": z[::n].copy(),
                  "example_id": ids, "source": [SOURCE] * len(ids)},
        example_digests=digests,
    )


@kernel
def _pack_boxes(image, top, left, lo, hi, packed, measured):
    """Pack the first len(packed) frames' boxes (render_boxes) into the zero rows of `packed`,
    each frame (H, ceil(W/8)) most significant bit first; measured[i] = frame i's area, then
    its object's x0, y0, x1, y1 (zeros if none)."""
    for i in range(len(packed)):
        area, lx, ly, hx, hy = 0, hi[i, 0], hi[i, 1], -1, -1
        (x0, y0), w = lo[i], hi[i, 0] - lo[i, 0]
        for r in range(hi[i, 1] - y0):
            row, out, first, last = image[top[i] + r, left[i] : left[i] + w], packed[i, y0 + r], -1, -1
            for c in range(w):
                if row[c]:
                    x = x0 + c
                    out[x >> 3] |= 0x80 >> (x & 7)
                    area += 1
                    first, last = c if first < 0 else first, c
            if first >= 0:
                lx, hx, ly, hy = min(lx, x0 + first), max(hx, x0 + last), min(ly, y0 + r), y0 + r
        measured[i, 0] = area
        if area:
            measured[i, 1], measured[i, 2], measured[i, 3], measured[i, 4] = lx, ly, hx + 1, hy + 1
        else:
            measured[i, 1:] = 0


def _largest_region(boxes: FrameBoxes, f: int, measured: np.ndarray) -> int:
    """The largest 8-connected region of frame f's object, whose area and bounding box are
    `measured`."""
    area, x0, y0, x1, y1 = measured
    bx, by = boxes.lo[f]
    return largest_region(boxes.pixels(f)[y0 - by : y1 - by, x0 - bx : x1 - bx], int(area))


@kernel
def _clear_rows(packed, y0, y1):
    """Zero rows y0[i] .. y1[i] of each frame i of `packed`."""
    for i in range(len(packed)):
        packed[i, y0[i] : y1[i]] = 0


def _drawn(
    p: GeneratorParams, specs: list[ExampleSpec]
) -> Iterator[tuple[int, ExampleSpec, FrameBoxes, int]]:
    """(position in the shard, draws, render_boxes of its chunk, its first frame there) of each
    example of `specs`, rendered DRAW_CHUNK examples at a time."""
    for a in range(0, len(specs), DRAW_CHUNK):
        chunk = specs[a : a + DRAW_CHUNK]
        boxes = render_boxes(chunk, p)
        for j, spec in enumerate(chunk):
            yield a + j, spec, boxes, j * p.n_obs


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
