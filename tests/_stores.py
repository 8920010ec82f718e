"""Small hand-made stores for the scoring tests: each frame's mask is a square of a given area."""

from __future__ import annotations

import math

import numpy as np

from odms_data.store.format import StoreAttrs
from odms_data.store.masks import FrameStats, pack
from odms_data.store.writer import Layout, StoreWriter

SIZE = 64


def stats_of(masks: np.ndarray) -> FrameStats:
    """Statistics of a (k, H, W) stack of binary masks, one mask at a time (FrameStats.set)."""
    stats = FrameStats.empty(len(masks))
    for i, mask in enumerate(masks):
        stats.set(i, mask)
    return stats


def square(area: int) -> np.ndarray:
    side = math.isqrt(area)
    if side * side != area or side > SIZE:
        raise ValueError(f"area {area} is not a square up to {SIZE}^2")
    m = np.zeros((SIZE, SIZE), bool)
    m[:side, :side] = True
    return m


def make_store(path, split: str, examples: list[dict], domain: str = "normal") -> str:
    """Write a store; each example is {'z': [...], 'areas': [...], 'd1': float, 'id': optional},
    or gives its (n, SIZE, SIZE) masks as 'masks' in place of 'areas'."""
    masks, z, frame_index, d1, ids = [], [], [], [], []
    width = max(len(e["z"]) for e in examples)
    for i, e in enumerate(examples):
        row = np.full(width, -1, np.int64)
        row[: len(e["z"])] = np.arange(len(z), len(z) + len(e["z"]))
        frame_index.append(row)
        z += list(e["z"])
        masks += list(e["masks"]) if "masks" in e else [square(a) for a in e["areas"]]
        d1.append(e["d1"])
        ids.append(f"{split}/{e.get('id', f'{i:03d}')}")
    masks, z = np.stack(masks), np.array(z, np.float64)
    layout = Layout(
        height=SIZE, width=SIZE, n_frames=len(z), n_examples=len(ids), max_obs=width,
        id_width=max(len(i.encode()) for i in ids), source_width=4, frames_per_chunk=1,
        frames_per_shard=len(z), examples_per_chunk=len(ids),
    )
    with StoreWriter(str(path)) as w:
        w.create(layout)
        w.write_masks(0, pack(masks))
        w.write_rows("frame", 0, {"z": z, "depth": z, **vars(stats_of(masks))})
        w.write_rows("example", 0, {"frame_index": np.stack(frame_index), "d1": np.array(d1, np.float64),
                                    "example_id": ids, "source": ["test"] * len(ids)})
        w.commit(StoreAttrs(
            split=split, domain=domain, image_size=(SIZE, SIZE),
            counts={"examples": len(ids), "frames": len(z), "labelled": int(np.isfinite(d1).sum())},
            source="tests", digest="sha256:" + "0" * 64,
        ))
    return str(path)
