"""Writing a store of boxes (FORMAT.md, format version 2): ODMD-style examples, each n frames
in observation order with a box, a movement to the last frame and a depth, and a label, the
depth at the last frame. No masks: the arrays are those the table (format.py) gives the kind."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .digest import box_frame_digests, content_digest
from .format import StoreAttrs, box_problems, d1_problems, id_problems
from .writer import Layout, StoreWriter


@dataclass(frozen=True)
class BoxRows:
    """E examples of n frames each, in observation order (the label at the last frame):
    `boxes` (E, n, 4), `move` (E, n, 3) to the last frame, `depth` (E, n) (NaN where unknown),
    `d1` (E,) and the examples' `ids` (each `<split>/...`) and `sources`."""

    boxes: np.ndarray
    move: np.ndarray
    depth: np.ndarray
    d1: np.ndarray
    ids: list[str]
    sources: list[str]


def write_box_store(path: str, rows: BoxRows, attrs: StoreAttrs, fmt: str | None = None, *,
                    overwrite: bool = False, check: Callable[[StoreAttrs], None] | None = None) -> str:
    """Write `rows` as a store of boxes at `path` with attributes `attrs` (kind, counts and digest
    are filled in here); refuses rows that break the format's rules before writing anything.
    `check(attrs)` may raise to refuse the store before anything is written. Returns the content
    digest."""
    E, n = rows.boxes.shape[:2]
    if E == 0 or n == 0:
        raise InputError(f"{path}: nothing to write (no examples or no frames)")
    box, move = rows.boxes.reshape(E * n, 4), rows.move.reshape(E * n, 3)
    depth = rows.depth.reshape(E * n)
    problems = (box_problems(box, move) + id_problems(rows.ids, attrs.split)
                + d1_problems(rows.d1, int((~np.isnan(rows.d1)).sum()), lambda i: repr(rows.ids[i])))
    if problems:
        raise InputError(f"{path}: {problems[0]}")
    frame_index = np.arange(E * n, dtype=np.int64).reshape(E, n)
    digest = content_digest(attrs.image_size[0], attrs.image_size[1], frame_index,
                            box_frame_digests(box, move, depth), rows.ids, rows.sources, rows.d1)
    attrs.kind, attrs.format_version, attrs.digest = "boxes", 2, digest
    attrs.counts = {"examples": E, "frames": E * n, "labelled": int((~np.isnan(rows.d1)).sum())}
    if check:
        check(attrs)
    layout = Layout(
        height=attrs.image_size[0], width=attrs.image_size[1], n_frames=E * n, n_examples=E, max_obs=n,
        id_width=max(1, *(len(i.encode()) for i in rows.ids)),
        source_width=max(1, *(len(s.encode()) for s in rows.sources)),
        frames_per_chunk=min(E * n, 65536), frames_per_shard=min(E * n, 65536),
        examples_per_chunk=min(E, 65536), kind="boxes",
    )
    with StoreWriter(path, fmt, overwrite=overwrite) as w:
        w.create(layout)
        w.write_rows("frame", 0, {"box": box, "move": move, "depth": depth})
        w.write_rows("example", 0, {"frame_index": frame_index, "d1": rows.d1, "example_id": rows.ids,
                                    "source": rows.sources})
        w.commit(attrs)
    return digest
