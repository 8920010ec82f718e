"""Decoding masks on worker processes: one shard-aligned range of frames per task.

A task reads (`MaskSource.read`), checks and packs its masks, computes their statistics and frame digests, and
writes them into their shard (Zarr) or returns deflated chunks (HDF5), as the store builder's
`Rows`; a bad file becomes a failure in the result instead. libpng and libjpeg print their own
complaints on stderr, which is silenced while they decode.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..store import build
from ..store.backends import MaskSink
from ..store.build import Rows
from ..store.digest import frame_digests
from ..store.masks import FrameStats, pack, packed_width
from .plan import MaskSource


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


def run_frames(task: FrameTask) -> Rows:
    """Read, check, pack and write one shard's masks; failures instead when a source is bad."""
    H, W = task.size
    k = len(task.masks)
    packed = np.zeros((k, H, packed_width(W)), np.uint8)
    stats = FrameStats.empty(k)
    result = Rows(task.start)
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
    result.frames = {"z": task.z, "depth": task.depth, "area": stats.area, "largest_area": stats.largest_area,
                     "bbox": stats.bbox}
    result.frame_digests = frame_digests(packed, task.z, task.depth)
    result.returned_masks = task.sink.write_packed(task.start, packed)
    return result


class Workers(build.Workers):
    """Decoding processes (or none, for workers <= 1) shared by several stores, stderr silenced
    where masks are decoded: libpng and libjpeg print their own complaints there."""

    def __init__(self, workers: int | None = None) -> None:
        super().__init__(workers, quiet=True)
