"""Writing a store of masks from a `MaskPlan` (plan.py: mask source, z and depth of every frame;
frame rows, label, id and source of every example). `write_mask_store` hands shard-aligned frame
ranges to the decoding workers (decoding.py), which write the masks; the parent writes the small
arrays, streams the content digest and records the oddities the data shows (oddities.py).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..store.digest import content_digest
from ..store.format import (
    StoreAttrs,
    d1_problems,
    depth_problems,
    frame_index_problems,
    id_problems,
    z_problems,
)
from ..store.writer import Layout, StoreWriter
from .decoding import FrameTask, Workers
from .oddities import example_oddities
from .plan import MaskPlan


class BadFiles(InputError):
    """Mask files that could not be imported: (frame row, one-line message) each."""

    def __init__(self, failures: list[tuple[int, str]]) -> None:
        self.failures = failures
        more = f" (and {len(failures) - 1} more bad file(s))" if len(failures) > 1 else ""
        super().__init__(failures[0][1] + more, fix="skip-bad" if more else "")


def _width(values: list[str]) -> int:
    return max([1, *(len(v.encode()) for v in values)])


def write_mask_store(
    plan: MaskPlan,
    out: str | Path,
    fmt: str | None,
    workers: Workers,
    *,
    overwrite: bool = False,
    collect_all: bool = False,
    progress: Callable[[int], None] | None = None,
    check: Callable[[StoreAttrs], None] | None = None,
) -> StoreAttrs:
    """Write `plan` into a new store at `out`; BadFiles (nothing written) when a mask file is bad.

    `collect_all` decodes every file even after a bad one, so that BadFiles lists all of them.
    `check(attrs)` runs before the commit and may amend the attributes or raise to abort; a split
    it renames gives the ids its prefix (the plan keeps `id_room` bytes free for it).
    """
    F, E = len(plan.masks), len(plan.d1)
    if F == 0 or E == 0:
        raise InputError(f"{plan.split}: nothing to import (no frames or no examples left)")
    try:
        H, W = plan.masks[0].size()
    except InputError as e:
        raise BadFiles([(0, str(e))]) from None
    fpc = min(plan.frames_per_chunk, F)
    fps = max(fpc, plan.frames_per_shard // fpc * fpc)
    layout = Layout(
        height=H, width=W, n_frames=F, n_examples=E, max_obs=plan.frame_index.shape[1],
        id_width=_width(plan.ids) + plan.id_room, source_width=_width(plan.sources), frames_per_chunk=fpc,
        frames_per_shard=fps, examples_per_chunk=min(E, 4096),
    )
    with StoreWriter(str(out), fmt, overwrite=overwrite) as w:
        w.create(layout)
        sink = w.mask_sink()
        tasks = [
            FrameTask(sink, s, plan.masks[s : s + fps],
                      plan.z[s : s + fps], plan.depth[s : s + fps], (H, W), plan.threshold, collect_all)
            for s in range(0, F, fps)
        ]
        fd, area = _write_frames(plan, w, workers, tasks, collect_all, progress)

        def digest_with(ids: list[str]) -> str:
            return content_digest(H, W, plan.frame_index, fd, ids, plan.sources, plan.d1)

        attrs = StoreAttrs(
            split=plan.split, domain=plan.domain, image_size=(H, W),
            counts={"examples": E, "frames": F, "labelled": int((~np.isnan(plan.d1)).sum())},
            source=plan.source, oddities=plan.oddities + example_oddities(plan, area),
            digest=digest_with(plan.ids),
        )
        if check:
            check(attrs)
        ids = plan.ids
        if attrs.split != plan.split:  # renamed by the check: ids start with their store's split
            ids = _rename(plan, attrs, digest_with)
        _check_as_readers_do(plan, ids, attrs)
        w.write_examples(0, plan.frame_index, plan.d1, ids, plan.sources)
        w.commit(attrs)
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


def _write_frames(
    plan: MaskPlan, w: StoreWriter, workers: Workers, tasks: list[FrameTask], collect_all: bool,
    progress: Callable[[int], None] | None,
) -> tuple[np.ndarray, np.ndarray]:
    """Decode and write every frame; the frames' digests and mask areas, or BadFiles."""
    F = len(plan.masks)
    fd = np.empty((F, 32), np.uint8)
    area = np.empty(F, np.int32)
    failures: list[tuple[int, str]] = []
    with workers.run(tasks) as results:
        for r in results:
            if r.failures:
                failures += r.failures
                if not collect_all:
                    break
            if failures:
                continue
            stop = r.start + len(r.digests)
            fd[r.start : stop] = r.digests
            area[r.start : stop] = r.stats.area
            w.write_frames(r.start, plan.z[r.start : stop], plan.depth[r.start : stop], r.stats)
            w.receive_masks(r.start, r.returned_masks)
            if progress:
                progress(stop - r.start)
    if failures:
        raise BadFiles(failures)
    return fd, area


def _rename(plan: MaskPlan, attrs: StoreAttrs, digest_with: Callable[[list[str]], str]) -> list[str]:
    """The ids of a split renamed by the check, which start with the new split; the digest and the
    examples' oddities follow them (skipped folders keep theirs)."""
    ids = [attrs.split + i[len(plan.split):] for i in plan.ids]
    attrs.digest = digest_with(ids)
    renamed = dict(zip(plan.ids, ids, strict=True))
    attrs.oddities = [replace(o, subject=renamed.get(o.subject, o.subject)) for o in attrs.oddities]
    return ids
