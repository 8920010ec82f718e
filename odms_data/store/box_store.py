"""A store of boxes (FORMAT.md, format version 2) whose rows are all known, as a store source
(build.py): ODMD-style examples, each n frames in observation order with a box, a movement to
the last frame and a depth, and a label, the depth at the last frame. No masks: the arrays are
those the table (format.py) gives the kind."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import InputError
from .backends import MaskSink
from .build import BOX_ROWS, Rows, Sizes, Source, Workers, build
from .digest import box_frame_digests
from .format import StoreAttrs, box_problems, d1_problems, id_problems
from .writer import Layout


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


@dataclass(frozen=True)
class BoxTask:
    """Frames [start, stop) of a store of boxes, to be digested."""

    start: int
    box: np.ndarray
    move: np.ndarray
    depth: np.ndarray


def digest_boxes(task: BoxTask) -> Rows:
    """A task's frame rows and their digests."""
    return Rows(task.start, {"box": task.box, "move": task.move, "depth": task.depth},
                frame_digests=box_frame_digests(task.box, task.move, task.depth))


class BoxRowsSource(Source):
    """A store of boxes whose rows are all known: `rows` with attributes `attrs` (kind, counts
    and digest are filled in here); rows that break the format's rules are refused before
    anything is written. `check(attrs)` runs before the commit and may raise to abort."""

    def __init__(self, path: str, rows: BoxRows, attrs: StoreAttrs,
                 check: Callable[[StoreAttrs], None] | None = None) -> None:
        E, n = rows.boxes.shape[:2]
        if E == 0 or n == 0:
            raise InputError(f"{path}: nothing to write (no examples or no frames)")
        self.box, self.move = rows.boxes.reshape(E * n, 4), rows.move.reshape(E * n, 3)
        self.depth = rows.depth.reshape(E * n)
        problems = (box_problems(self.box, self.move) + id_problems(rows.ids, attrs.split)
                    + d1_problems(rows.d1, int((~np.isnan(rows.d1)).sum()), lambda i: repr(rows.ids[i])))
        if problems:
            raise InputError(f"{path}: {problems[0]}")
        self.rows, self._attrs, self.check, self.shape = rows, attrs, check, (E, n)
        self._examples = {"frame_index": np.arange(E * n, dtype=np.int64).reshape(E, n), "d1": rows.d1,
                          "example_id": rows.ids, "source": rows.sources}

    def sizes(self) -> Sizes:
        (E, n), r = self.shape, self.rows
        return Sizes(height=self._attrs.image_size[0], width=self._attrs.image_size[1], n_frames=E * n,
                     n_examples=E, max_obs=n, id_width=max(1, *(len(i.encode()) for i in r.ids)),
                     source_width=max(1, *(len(s.encode()) for s in r.sources)), frames_per_task=BOX_ROWS,
                     kind="boxes")

    def tasks(self, sink: MaskSink | None, layout: Layout) -> Iterator[BoxTask]:
        step = layout.frames_per_shard
        for s in range(0, len(self.box), step):
            yield BoxTask(s, self.box[s : s + step], self.move[s : s + step], self.depth[s : s + step])

    def runner(self) -> Callable[[BoxTask], Rows]:
        return digest_boxes

    def examples(self) -> dict[str, Any]:
        return self._examples

    def attrs(self, digest: str) -> StoreAttrs:
        E, n = self.shape
        a = self._attrs
        a.kind, a.format_version, a.digest = "boxes", 2, digest
        a.counts = {"examples": E, "frames": E * n, "labelled": int((~np.isnan(self.rows.d1)).sum())}
        if self.check:
            self.check(a)
        return a


def write_box_store(path: str, rows: BoxRows, attrs: StoreAttrs, fmt: str | None = None, *,
                    overwrite: bool = False, check: Callable[[StoreAttrs], None] | None = None,
                    workers: Workers | None = None) -> str:
    """Write `rows` as a store of boxes at `path` with attributes `attrs` (`BoxRowsSource`);
    returns the content digest."""
    return build(BoxRowsSource(path, rows, attrs, check), path, fmt, workers=workers,
                 overwrite=overwrite).digest
