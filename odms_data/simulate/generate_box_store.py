"""`odms-data generate --boxes PRESET`: a store of boxes (FORMAT.md, version 2) from the seeded
box generator (box_examples.py). Example k of (preset, seed) is generator index k, so a store's
examples are those the box stream gives for the same (preset, seed, index), bit for bit."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict

import numpy as np

from ..errors import InputError
from ..store.box_store import BoxRows, write_box_store
from ..store.format import StoreAttrs
from .box_examples import BOX_GENERATOR_VERSION, BOX_PRESETS, sample_box_examples

BLOCK = 16384  # examples sampled at a time


def generate_box_store(path: str, count: int, preset: str, seed: int, *, split: str = "generated",
                       fmt: str | None = None, overwrite: bool = False,
                       progress: Callable[[int], None] | None = None) -> StoreAttrs:
    """Write `count` examples of box preset `preset` and `seed` as a store of boxes at `path`;
    each frame's depth is the generator's true one (the movements carry the camera noise)."""
    if preset not in BOX_PRESETS:
        raise InputError(f"unknown box preset '{preset}'; the presets are {', '.join(BOX_PRESETS)}")
    if count < 1 or seed < 0:
        raise InputError(f"need at least one example and a non-negative seed, got {count} and {seed}")
    p = BOX_PRESETS[preset]
    parts: dict[str, list[np.ndarray]] = {"boxes": [], "move": [], "depth": [], "frame_depth": []}
    for start in range(0, count, BLOCK):
        g = sample_box_examples(p, seed, np.arange(start, min(count, start + BLOCK)))
        for key, values in parts.items():
            values.append(g[key])
        if progress:
            progress(len(g["depth"]))
    rows = BoxRows(np.concatenate(parts["boxes"]), np.concatenate(parts["move"]),
                   np.concatenate(parts["frame_depth"]), np.concatenate(parts["depth"]),
                   [f"{split}/{k:07d}" for k in range(count)], ["generated"] * count)
    params = {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(p).items()}
    attrs = StoreAttrs(split=split, domain="generated", image_size=p.image_dim, counts={},
                       generator={"version": BOX_GENERATOR_VERSION, "preset": preset, "params": params,
                                  "seed": seed})
    write_box_store(path, rows, attrs, fmt, overwrite=overwrite)
    return attrs
