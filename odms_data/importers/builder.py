"""Writing an imported store: mask files decoded on worker processes, one shard per task.

An importer describes the store as a `Plan` (mask file, z and depth of every frame; frame rows,
label, id and source of every example). `build_store` hands shard-aligned frame ranges to the
workers, which decode, check and pack the masks, compute their statistics and frame digests, and
write them into their shard (Zarr) or return deflated chunks (HDF5); the parent writes the small
arrays and streams the content digest. Oddities that the data shows (z not increasing, tiny z
steps, missing depths, empty masks) are recorded per example.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Iterator
from concurrent.futures import Future, wait
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..parallel import spawn_pool
from ..store.digest import StoreDigest, example_digest, frame_digests
from ..store.format import Z_ODDITY, StoreAttrs
from ..store.masks import FrameStats, pack, packed_width
from ..store.writer import Layout, StoreWriter, write_shard_masks
from .mask_files import DEFAULT_THRESHOLD, image_size, read_mask

TINY_Z_STEP = 1e-4  # m; steps below this (but above 0) are recorded as an oddity


class BadFiles(InputError):
    """Mask files that could not be imported: (frame row, one-line message) each."""

    def __init__(self, failures: list[tuple[int, str]]) -> None:
        self.failures = failures
        more = f" (and {len(failures) - 1} more bad file(s); --skip-bad imports the rest)" \
            if len(failures) > 1 else ""
        super().__init__(failures[0][1] + more)


@dataclass
class Plan:
    """Everything an importer decided about a store, before any mask is decoded."""

    split: str
    domain: str
    source: str
    files: list[Path]  # (F,) mask file of each frame row
    z: np.ndarray  # (F,) m
    depth: np.ndarray  # (F,) m, NaN where unknown
    frame_index: np.ndarray  # (E, N) frame rows, padded with -1
    d1: np.ndarray  # (E,) m, NaN when unlabelled
    ids: list[str]
    sources: list[str]
    frames_per_chunk: int
    frames_per_shard: int
    oddities: list[dict[str, str]] = field(default_factory=list)
    threshold: int = DEFAULT_THRESHOLD


@dataclass
class FrameTask:
    """Frame rows [start, start + len(files)) of the store being written at `path`."""

    path: str
    fmt: str
    start: int
    files: list[str]
    z: np.ndarray
    depth: np.ndarray
    size: tuple[int, int]
    reference: str  # the file whose size all masks must have
    threshold: int
    chunk: int  # frames per mask chunk (HDF5 chunks are padded to it)
    collect_all: bool


@dataclass
class FrameResult:
    start: int
    stats: FrameStats | None = None
    digests: np.ndarray | None = None
    deflated_chunks: list[bytes] = field(default_factory=list)
    failures: list[tuple[int, str]] = field(default_factory=list)


def run_frames(task: FrameTask) -> FrameResult:
    """Decode, check, pack and write one shard's masks; failures instead when a file is bad."""
    H, W = task.size
    k = len(task.files)
    packed = np.zeros((k, H, packed_width(W)), np.uint8)
    stats = FrameStats.empty(k)
    result = FrameResult(task.start)
    for i, f in enumerate(task.files):
        try:
            m = read_mask(Path(f), task.threshold)
            if m.shape != (H, W):
                raise InputError(
                    f"{f}: image size {m.shape[0]}x{m.shape[1]} differs from the "
                    f"{H}x{W} (height x width) of {task.reference}"
                )
        except InputError as e:
            result.failures.append((task.start + i, str(e)))
            if not task.collect_all:
                break
            continue
        stats.set(i, m)
        packed[i] = pack(m)
    if result.failures:
        return result
    result.stats, result.digests = stats, frame_digests(packed, task.z, task.depth)
    result.deflated_chunks = write_shard_masks(task.path, task.fmt, task.start, packed, task.chunk)
    return result


@contextmanager
def _quiet_stderr() -> Iterator[None]:
    """Silence file descriptor 2: libpng and libjpeg print their own complaints there."""
    sys.stderr.flush()
    saved = os.dup(2)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(devnull)


def _silence_worker() -> None:
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, 2)


class Workers:
    """A pool of decoding processes (or none, for workers <= 1) shared by several stores."""

    def __init__(self, workers: int | None = None) -> None:
        self.n = workers if workers is not None else (os.cpu_count() or 1)
        self.pool = None

    def __enter__(self) -> Workers:
        if self.n > 1:
            self.pool = spawn_pool(self.n, _silence_worker)
        return self

    def __exit__(self, *exc) -> None:
        if self.pool is not None:
            self.pool.shutdown(cancel_futures=True)

    @contextmanager
    def run(self, tasks: list[FrameTask]) -> Iterator[Iterator[FrameResult]]:
        """Results in task order; on leaving, tasks not started are cancelled and running ones
        awaited, so that no worker writes into a store being removed."""
        if self.pool is None:
            def serial() -> Iterator[FrameResult]:
                for t in tasks:
                    with _quiet_stderr():
                        r = run_frames(t)
                    yield r

            yield serial()
            return
        pending: list[Future] = []
        todo = iter(tasks)

        def ordered() -> Iterator[FrameResult]:
            for t in todo:
                pending.append(self.pool.submit(run_frames, t))
                if len(pending) >= 2 * self.n:
                    break
            while pending:
                result = pending[0].result()
                pending.pop(0)
                nxt = next(todo, None)
                if nxt is not None:
                    pending.append(self.pool.submit(run_frames, nxt))
                yield result

        try:
            yield ordered()
        finally:
            for f in pending:
                f.cancel()
            wait(pending)


def _width(values: list[str]) -> int:
    return max([1, *(len(v.encode()) for v in values)])


def example_oddities(plan: Plan, area: np.ndarray) -> list[dict[str, str]]:
    """Per-example oddities the data shows, in example order."""
    out = []
    for e, row in enumerate(plan.frame_index):
        frames = row[row >= 0]
        names = [plan.files[f].name for f in frames]
        steps = np.diff(plan.z[frames])
        if np.any(steps <= 0):
            j = int(np.argmax(steps <= 0))
            out.append({"example": plan.ids[e], "kind": Z_ODDITY, "detail": (
                f"z goes from {plan.z[frames[j]]!r} m ({names[j]}) to {plan.z[frames[j + 1]]!r} m "
                f"({names[j + 1]}); kept as released")})
        elif np.any(steps < TINY_Z_STEP):
            j = int(np.argmax(steps < TINY_Z_STEP))
            out.append({"example": plan.ids[e], "kind": "z-step-tiny", "detail": (
                f"{names[j]} and {names[j + 1]} are {steps[j] * 1e6:.3g} micrometres apart")})
        finite = np.isfinite(plan.depth[frames])
        if finite.any() and not finite.all():
            bad = [n for n, ok in zip(names, finite, strict=True) if not ok]
            out.append({"example": plan.ids[e], "kind": "depth-not-finite",
                        "detail": f"no finite depth at {', '.join(bad)}"})
        empty = [n for n, f in zip(names, frames, strict=True) if area[f] == 0]
        if empty:
            out.append({"example": plan.ids[e], "kind": "empty-mask",
                        "detail": f"empty mask at {', '.join(empty)}"})
    return out


def build_store(
    plan: Plan,
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
    `check(attrs)` runs before the commit and may amend the attributes or raise to abort.
    """
    F, E = len(plan.files), len(plan.d1)
    if F == 0 or E == 0:
        raise InputError(f"{plan.split}: nothing to import (no frames or no examples left)")
    try:
        H, W = image_size(plan.files[0])
    except InputError as e:
        raise BadFiles([(0, str(e))]) from None
    fpc = min(plan.frames_per_chunk, F)
    fps = max(fpc, plan.frames_per_shard // fpc * fpc)
    layout = Layout(
        height=H, width=W, n_frames=F, n_examples=E, max_obs=plan.frame_index.shape[1],
        id_width=_width(plan.ids), source_width=_width(plan.sources), frames_per_chunk=fpc,
        frames_per_shard=fps, examples_per_chunk=min(E, 4096),
    )
    with StoreWriter(str(out), fmt, overwrite=overwrite) as w:
        w.create(layout)
        tasks = [
            FrameTask(w.partial, w.format, s, [str(f) for f in plan.files[s : s + fps]],
                      plan.z[s : s + fps], plan.depth[s : s + fps], (H, W), str(plan.files[0]),
                      plan.threshold, fpc, collect_all)
            for s in range(0, F, fps)
        ]
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
                for c, chunk in enumerate(r.deflated_chunks):
                    w.write_mask_chunk(r.start + c * fpc, chunk)
                if progress:
                    progress(stop - r.start)
        if failures:
            raise BadFiles(failures)
        w.write_examples(0, plan.frame_index, plan.d1, plan.ids, plan.sources)
        digest = StoreDigest(H, W, E)
        digest.update(
            example_digest(plan.ids[e], plan.sources[e], plan.d1[e], fd[row[row >= 0]])
            for e, row in enumerate(plan.frame_index)
        )
        attrs = StoreAttrs(
            split=plan.split, domain=plan.domain, image_size=(H, W),
            counts={"examples": E, "frames": F, "labelled": int((~np.isnan(plan.d1)).sum())},
            source=plan.source, oddities=plan.oddities + example_oddities(plan, area),
            digest=digest.hexdigest(),
        )
        if check:
            check(attrs)
        w.commit(attrs)
    return attrs
