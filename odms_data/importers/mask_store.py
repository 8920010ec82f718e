"""A `MaskPlan` (plan.py: mask source, z and depth of every frame; frame rows, label, id and source
of every example) as a store source (store/build.py): its tasks hand shard-aligned frame ranges to
the decoding workers (decoding.py), which write the masks; the attributes record the oddities
the data shows (`example_oddities`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import replace
from typing import Any

import numpy as np

from ..errors import InputError
from ..store.backends import MaskSink
from ..store.build import BadFiles, Rows, Sizes, Source
from ..store.format import (
    Z_ODDITY,
    StoreAttrs,
    d1_problems,
    depth_problems,
    frame_index_problems,
    id_problems,
    z_problems,
)
from ..store.oddity import Oddity
from ..store.writer import Layout
from .decoding import FrameTask, run_frames
from .plan import MaskPlan

TINY_Z_STEP = 1e-4  # m; steps below this (but above 0) are recorded as an oddity


def _width(values: list[str]) -> int:
    return max([1, *(len(v.encode()) for v in values)])


class ImportedMasks(Source):
    """The store of masks `plan` describes. `collect_all` decodes every file even after a bad one,
    so that BadFiles lists all of them. `check(attrs)` runs before the commit and may amend the
    attributes or raise to abort; a split it renames gives the ids its prefix (the plan keeps
    `id_room` bytes free for it)."""

    def __init__(self, plan: MaskPlan, collect_all: bool = False,
                 check: Callable[[StoreAttrs], None] | None = None) -> None:
        self.plan, self.collect_all, self.check = plan, collect_all, check
        self.area = np.empty(len(plan.masks), np.int32)
        self.image_size = (0, 0)  # read from the first mask by `sizes`
        self._examples = self._rows(plan.ids)

    def _rows(self, ids: list[str]) -> dict[str, Any]:
        p = self.plan
        return {"frame_index": p.frame_index, "d1": p.d1, "example_id": ids, "source": p.sources}

    def sizes(self) -> Sizes:
        p = self.plan
        F, E = len(p.masks), len(p.d1)
        if F == 0 or E == 0:
            raise InputError(f"{p.split}: nothing to import (no frames or no examples left)")
        try:
            H, W = p.masks[0].size()
        except InputError as e:
            raise BadFiles([(0, str(e))]) from None
        self.image_size = (H, W)
        return Sizes(height=H, width=W, n_frames=F, n_examples=E, max_obs=p.frame_index.shape[1],
                     id_width=_width(p.ids) + p.id_room, source_width=_width(p.sources),
                     frames_per_task=p.frames_per_shard, frames_per_chunk=p.frames_per_chunk)

    def tasks(self, sink: MaskSink | None, layout: Layout) -> Iterator[FrameTask]:
        p, fps = self.plan, layout.frames_per_shard
        assert sink is not None
        for s in range(0, len(p.masks), fps):
            yield FrameTask(sink, s, p.masks[s : s + fps], p.z[s : s + fps], p.depth[s : s + fps],
                            (layout.height, layout.width), p.threshold, self.collect_all)

    def runner(self) -> Callable[[FrameTask], Rows]:
        return run_frames

    def take(self, rows: Rows) -> None:
        area = rows.frames["area"]
        self.area[rows.frame_start : rows.frame_start + len(area)] = area

    def examples(self) -> dict[str, Any]:
        return self._examples

    def attrs(self, digest: str) -> StoreAttrs:
        p = self.plan
        attrs = StoreAttrs(
            split=p.split, domain=p.domain, image_size=self.image_size,
            counts={"examples": len(p.d1), "frames": len(p.masks), "labelled": int((~np.isnan(p.d1)).sum())},
            source=p.source, oddities=p.oddities + example_oddities(p, self.area), digest=digest,
        )
        if self.check:
            self.check(attrs)
        ids = p.ids
        if attrs.split != p.split:  # renamed by the check: ids start with their store's split
            ids = [attrs.split + i[len(p.split):] for i in p.ids]
            renamed = dict(zip(p.ids, ids, strict=True))  # the examples' oddities follow them
            attrs.oddities = [replace(o, subject=renamed.get(o.subject, o.subject)) for o in attrs.oddities]
            self._examples = self._rows(ids)
        _check_as_readers_do(p, ids, attrs)
        return attrs


def _check_as_readers_do(plan: MaskPlan, ids: list[str], attrs: StoreAttrs) -> None:
    """InputError (nothing written) for the first rule of the store format (store/format.py, the
    checks the readers and `validate` make) that the planned arrays break: duplicate ids (from
    repeated window lengths), depths that overflowed to infinity, ..."""
    def name(i: int) -> str:
        return repr(ids[i])

    problems = (id_problems(ids, attrs.split) + frame_index_problems(plan.frame_index, len(plan.z), name)
                + z_problems(plan.z) + depth_problems(plan.depth)
                + d1_problems(plan.d1, attrs.counts["labelled"], name))
    if problems:
        raise InputError(f"{plan.split}: the store would break the format's rules, so nothing was "
                         f"written: {problems[0]}")


def example_oddities(plan: MaskPlan, area: np.ndarray) -> list[Oddity]:
    """Per-example oddities the data shows, in example order."""
    out: list[Oddity] = []
    for e, row in enumerate(plan.frame_index):
        frames = row[row >= 0]
        names = [plan.masks[f].name for f in frames]
        steps = np.diff(plan.z[frames])
        if np.any(steps <= 0):
            j = int(np.argmax(steps <= 0))
            out.append(Oddity(Z_ODDITY, plan.ids[e], (
                f"z goes from {plan.z[frames[j]]!r} m ({names[j]}) to {plan.z[frames[j + 1]]!r} m "
                f"({names[j + 1]}); kept as released")))
        elif np.any(steps < TINY_Z_STEP):
            j = int(np.argmax(steps < TINY_Z_STEP))
            out.append(Oddity("z-step-tiny", plan.ids[e], (
                f"{names[j]} and {names[j + 1]} are {steps[j] * 1e6:.3g} micrometres apart")))
        finite = np.isfinite(plan.depth[frames])
        if finite.any() and not finite.all():
            bad = [n for n, ok in zip(names, finite, strict=True) if not ok]
            out.append(Oddity("depth-not-finite", plan.ids[e], f"no finite depth at {', '.join(bad)}"))
        empty = [n for n, f in zip(names, frames, strict=True) if area[f] == 0]
        if empty:
            out.append(Oddity("empty-mask", plan.ids[e], f"empty mask at {', '.join(empty)}"))
    return out
