"""Building a store: the one place that writes one.

A `Source` says only what its store holds: its `Sizes`, picklable tasks, a top-level function that
turns a task into `Rows` (arrays by name), and its attributes. `build` owns the rest: the chunking
and layout, the writer's lifetime (writer.py), the executor that runs the tasks (`Workers`: here,
local worker processes or a Dask cluster, results in task order), the rows written by array name,
the content digest, the check before the commit (the readers' own, so a store no reader accepts
never replaces anything) and the commit, and one `progress(label, done, total)`.

The digest streams: examples made by the tasks are digested by them (`Rows.example_digests`), in
order; examples known before the tasks (`Source.examples`: an import's frame rows may point
anywhere) are digested once every frame's digest (`Rows.frame_digests`) is in.
"""

from __future__ import annotations

import os
import sys
from abc import ABC, abstractmethod
from collections.abc import Callable, Generator, Iterable, Iterator
from contextlib import closing, contextmanager
from dataclasses import dataclass, field
from typing import Any, Self, TypeVar

import numpy as np

from ..errors import InputError, StoreError
from ..parallel import WorkerPool, cores, end_pool, pool_map, worker_pool, workers_for
from .backends import MaskSink
from .digest import StoreDigest, content_digest
from .format import StoreAttrs, arrays_of
from .reader import open_store
from .writer import Layout, StoreWriter

Task = TypeVar("Task")
Result = TypeVar("Result")
Progress = Callable[[str, int, int], None]  # (label, done, total)

EXAMPLE_ROWS = 4096  # per-example rows per chunk when the examples are known before the tasks
BOX_ROWS = 65536  # rows per chunk of every array of a store of boxes


@dataclass(frozen=True)
class Sizes:
    """What a source makes: its image size, frames and examples, the widest frame row and text,
    and how its work divides into tasks. `frames_per_chunk` frames of masks are compressed
    together; a task makes `frames_per_task` frames (rounded to whole chunks) and, where the
    tasks make the examples, `examples_per_task` examples. Progress counts `unit`."""

    height: int
    width: int
    n_frames: int
    n_examples: int
    max_obs: int
    id_width: int
    source_width: int
    frames_per_task: int
    frames_per_chunk: int = 1
    examples_per_task: int | None = None  # None: the examples come from Source.examples
    kind: str = "masks"
    unit: str = "frames"  # or "examples"


@dataclass
class Rows:
    """What one task made: frame rows from `frame_start` by array name (not the masks, which the
    task wrote through its sink: `returned_masks` are the chunks it hands back, for HDF5), their
    `frame_digests` (when the examples come from the source) or, when the task makes examples,
    example rows from `example_start` and their `example_digests`; or `failures` (frame row,
    one line) instead of any of it."""

    frame_start: int
    frames: dict[str, Any] = field(default_factory=dict)
    returned_masks: list[bytes] = field(default_factory=list)
    frame_digests: np.ndarray | None = None
    example_start: int = 0
    examples: dict[str, Any] = field(default_factory=dict)
    example_digests: list[bytes] = field(default_factory=list)
    failures: list[tuple[int, str]] = field(default_factory=list)

    @property
    def n_frames(self) -> int:
        return len(next(iter(self.frames.values()))) if self.frames else 0

    @property
    def n_examples(self) -> int:
        return len(self.example_digests)


class BadFiles(InputError):
    """Inputs that could not be read into the store: (frame row, one-line message) each."""

    def __init__(self, failures: list[tuple[int, str]]) -> None:
        self.failures = failures
        more = f" (and {len(failures) - 1} more bad file(s))" if len(failures) > 1 else ""
        super().__init__(failures[0][1] + more, fix="skip-bad" if more else "")


class Source(ABC):
    """What a store holds, as its maker knows it; `build` writes it."""

    collect_all: bool = False  # run every task after a failure, so that BadFiles lists them all

    @abstractmethod
    def sizes(self) -> Sizes:
        """The store's sizes (refuse here what cannot be written, before anything is)."""

    @abstractmethod
    def tasks(self, sink: MaskSink | None, layout: Layout) -> Iterable[Any]:
        """The tasks, in frame order, each `layout.frames_per_shard` frames (the last may be
        fewer); their masks go through `sink` (None: a store without masks)."""

    @abstractmethod
    def runner(self) -> Callable[[Any], Rows]:
        """The function that runs a task: a top-level one, for worker processes."""

    def examples(self) -> dict[str, Any] | None:
        """The example rows by name when known before the tasks; None: the tasks make them."""
        return None

    def take(self, rows: Rows) -> None:
        """Sees each task's rows as they are written (for what the attributes need)."""
        return None

    @abstractmethod
    def attrs(self, digest: str) -> StoreAttrs:
        """The store's attributes, given its content digest; may raise to abort (nothing is
        committed). A source whose `examples` then differ (a renamed split) is digested again."""


def counting(step: Callable[[int], None]) -> Progress:
    """`progress(label, done, total)` as the steps `step(k)` between its counts."""
    last = 0

    def report(label: str, done: int, total: int) -> None:
        nonlocal last
        step(done - last)
        last = done

    return report


def layout_for(s: Sizes) -> Layout:
    """The chunking policy: a chunk of every array per task, its frames in shards of whole chunks
    of `frames_per_chunk` masks; a store of boxes in at most BOX_ROWS rows a chunk; example rows
    known before the tasks EXAMPLE_ROWS a chunk."""
    F, E = s.n_frames, s.n_examples
    if s.kind == "boxes":
        fpc = fps = min(F, s.frames_per_task, BOX_ROWS)
        epc = min(E, s.examples_per_task or BOX_ROWS)
    else:
        fpc = min(s.frames_per_chunk, F)
        fps = max(fpc, s.frames_per_task // fpc * fpc)
        epc = s.examples_per_task or min(E, EXAMPLE_ROWS)
    return Layout(height=s.height, width=s.width, n_frames=F, n_examples=E, max_obs=s.max_obs,
                  id_width=s.id_width, source_width=s.source_width, frames_per_chunk=fpc,
                  frames_per_shard=fps, examples_per_chunk=epc, kind=s.kind)


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
    """Where a store's tasks run: in this process (workers <= 1), on a pool of local worker
    processes shared by several stores, or on the Dask cluster of `scheduler`. `quiet` silences
    stderr where tasks run (decoders that print their own complaints)."""

    def __init__(self, workers: int | None = None, *, scheduler: str | None = None,
                 quiet: bool = False) -> None:
        self.n = workers if workers is not None else cores()
        self.scheduler, self.quiet = scheduler, quiet
        self.pool: WorkerPool | None = None

    @classmethod
    def for_work(cls, work_s: float, tasks: int, workers: int | None = None,
                 scheduler: str | None = None) -> Workers:
        """The cluster of `scheduler`, or `workers` local processes (by default as many as `work_s`
        CPU-seconds are worth, parallel.workers_for), never more than the `tasks`."""
        if scheduler is not None:
            return cls(scheduler=scheduler)
        return cls(min(workers or workers_for(work_s, cores()), tasks))

    def __enter__(self) -> Self:
        if self.n > 1 and self.scheduler is None:
            self.pool = worker_pool(self.n, _silence_worker if self.quiet else None)
        return self

    def __exit__(self, *exc) -> None:
        if self.pool is not None:
            end_pool(self.pool)

    @contextmanager
    def map(self, fn: Callable[[Task], Result], tasks: Iterable[Task], path: str = ""
            ) -> Iterator[Iterator[Result]]:
        """`fn(task)` for every task (`fn` a picklable top-level function), results in task order.
        Left early, no task is left running: on a pool, tasks not started are cancelled and
        running ones awaited (parallel.pool_map), so that no worker writes into a store being
        removed. `path` is the store they write (a cluster's workers must see it)."""
        if self.scheduler is not None:
            from ..dask_runner import run_tasks

            results = run_tasks(fn, tasks, self.scheduler, path)
        elif self.pool is not None:
            results = pool_map(self.pool, fn, tasks, 2 * self.n)
        else:
            results = self._serial(fn, tasks)
        with closing(results):
            yield results

    def _serial(self, fn: Callable[[Task], Result], tasks: Iterable[Task]) -> Generator[Result, None, None]:
        for t in tasks:
            if self.quiet:
                with _quiet_stderr():
                    r = fn(t)
            else:
                r = fn(t)
            yield r


class _Digest:
    """The content digest, streamed from the tasks' example digests, or made from the source's
    examples over the frame digests the tasks return."""

    def __init__(self, s: Sizes, streamed: bool) -> None:
        self.size = (s.height, s.width)
        self.stream = StoreDigest(s.height, s.width, s.n_examples) if streamed else None
        self.frames = None if streamed else np.empty((s.n_frames, 32), np.uint8)

    def take(self, r: Rows) -> None:
        if self.stream is not None:
            self.stream.update(r.example_digests)
        elif r.frame_digests is not None:
            self.frames[r.frame_start : r.frame_start + len(r.frame_digests)] = r.frame_digests  # type: ignore[index]

    def of(self, examples: dict[str, Any] | None) -> str:
        if self.stream is not None:
            return self.stream.hexdigest()
        assert examples is not None and self.frames is not None
        return content_digest(*self.size, examples["frame_index"], self.frames, examples["example_id"],
                              examples["source"], examples["d1"])


def build(source: Source, path: str, fmt: str | None = None, *, workers: Workers | None = None,
          overwrite: bool = False, label: str | None = None, progress: Progress | None = None
          ) -> StoreAttrs:
    """Write `source`'s store at `path` (backend `fmt`, else from the name) with its tasks run by
    `workers` (None: in this process), reporting `progress(label, done, total)` (label: the path);
    returns its attributes. Nothing replaces what is at `path` unless the finished store passes
    the readers' checks; BadFiles when tasks failed."""
    s = source.sizes()
    made_by_tasks = s.examples_per_task is not None
    digest = _Digest(s, made_by_tasks)
    with StoreWriter(path, fmt, overwrite=overwrite) as w:
        layout = layout_for(s)
        w.create(layout)
        _write_tasks(source, s, layout, w, workers or Workers(1), digest, label or str(path), progress)
        examples = source.examples()
        attrs = source.attrs(digest.of(examples))
        if not made_by_tasks:
            final = source.examples()
            if final is not examples:
                attrs.digest = digest.of(final)
            w.write_rows("example", 0, final or {})
        w.finish(attrs)
        _check_as_readers_do(w.partial, path)
        w.commit()
    return attrs


def _write_tasks(source: Source, s: Sizes, layout: Layout, w: StoreWriter, workers: Workers,
                 digest: _Digest, label: str, progress: Progress | None) -> None:
    """Run the source's tasks and write their rows, in task order; BadFiles when tasks failed."""
    sink = w.mask_sink() if s.kind == "masks" else None
    total = s.n_examples if s.unit == "examples" else s.n_frames
    failures: list[tuple[int, str]] = []
    done = 0
    with workers.map(source.runner(), source.tasks(sink, layout), w.partial) as results:
        for r in results:
            failures += r.failures
            if failures:
                if source.collect_all:
                    continue
                break
            w.write_rows("frame", r.frame_start, r.frames)
            if sink is not None:
                w.receive_masks(r.frame_start, r.returned_masks)
            if r.examples:
                w.write_rows("example", r.example_start, r.examples)
            digest.take(r)
            source.take(r)
            done += r.n_examples if s.unit == "examples" else r.n_frames
            if progress:
                progress(label, done, total)
    if failures:
        raise BadFiles(failures)


def _check_as_readers_do(partial: str, path: str) -> None:
    """Refuse a finished store (at `partial`, not yet committed to `path`) that a reader would
    refuse: its attributes, arrays and every array's rules, read as `open_store` and the readers
    read them."""
    try:
        with open_store(partial, incomplete=True) as store:
            for name in arrays_of(store.kind):
                if name != "masks":
                    store.checked(name)
    except StoreError as e:
        why = str(e).removeprefix(f"{partial}: ").removesuffix("; run `odms-data validate` on it")
        raise StoreError(f"{path}: the store written would be refused by its readers, so nothing was "
                         f"replaced: {why}") from None
