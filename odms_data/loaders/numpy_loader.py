"""Framework-free batch iterators of NumPy arrays (what JAX users hand to `jax.device_put`).

    from odms_data.loaders import numpy_loader
    for batch in numpy_loader.stream_batches(512, 5000, seed=1, workers=2):
        x = jax.device_put(batch["masks"])  # (512, 10, 112, 112) float32

Batches are made in order, by the calling process or by `workers` worker processes (parallel.py)
with at most 2 * workers batches in flight; the content never depends on the number of workers. Workers
hand batches over in shared memory blocks that are reused (shared_batches.py): a batch from a
worker is a set of views of such a block, valid for as long as you keep them. The calling
process likewise reuses the arrays of batches nothing refers to any more (reused_arrays.py).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from concurrent.futures import Future
from contextlib import closing

import numpy as np

from ..errors import InputError
from ..parallel import end_pool, ordered_map, worker_pool
from .kinds import STANDARD, Indices, InputTransform, Params
from .reused_arrays import ReusedArrays
from .shared_batches import Arena, BlockPool
from .sources import GeneratedExamples, StoreExamples, store_order, stream_indices

Source = StoreExamples | GeneratedExamples
_source: Source  # a worker's source (set by _set_source)


def _set_source(source: Source) -> None:
    """Worker initialiser: the source travels once, so a store is opened once per worker."""
    global _source
    _source = source


def _make_batch(indices: Indices, lent: str | None):
    """In a worker: make a batch in the lent shared memory block (or a new one)."""
    arena = Arena(lent)
    return arena.finish(_source.batch(indices, arena.empty))


class Batches:
    """An iterable over the batches of `source` (StoreExamples or GeneratedExamples) whose
    example indices are `plan`; iterate it again to get the same batches again."""

    def __init__(
        self, source: Source, plan: Sequence[Indices],
        workers: int = 0,
    ) -> None:
        if workers < 0:
            raise InputError(f"workers must be >= 0, got {workers}")
        self.source, self.plan, self.workers = source, plan, workers

    def __len__(self) -> int:
        return len(self.plan)

    def __iter__(self) -> Iterator[dict[str, np.ndarray]]:
        if self.workers == 0:
            arrays = ReusedArrays()
            for indices in self.plan:
                yield self.source.batch(indices, arrays.empty)
            return
        blocks = BlockPool()

        def submit(indices: Indices) -> tuple[Future, str | None]:
            lent = blocks.lend()
            return pool.submit(_make_batch, indices, lent), lent

        def collect(handle: tuple[Future, str | None]) -> dict[str, np.ndarray]:
            future, lent = handle
            name, layout = future.result()
            return blocks.take(name, layout, lent)

        def abandon(handles: list[tuple[Future, str | None]]) -> None:
            """Stopped early: batches made but not taken go back to the pool."""
            end_pool(pool)
            for future, lent in handles:
                if not future.cancelled() and future.exception() is None:
                    blocks.give_back(future.result()[0], lent)

        with worker_pool(self.workers, _set_source, (self.source,)) as pool:
            try:
                with closing(ordered_map(submit, collect, self.plan, 2 * self.workers, abandon)) as batches:
                    for batch in batches:
                        yield batch
                        del batch  # our reference: the block is reused once the caller drops it too
            finally:
                blocks.close()


def _check_batch_size(batch_size: int) -> None:
    if batch_size < 1:
        raise InputError(f"batch size must be at least 1, got {batch_size}")


def store_batches(
    path: str,
    batch_size: int,
    *,
    transform: InputTransform | None = None,
    shuffle: bool = False,
    seed: int = 0,
    epoch: int = 0,
    drop_last: bool = False,
    workers: int = 0,
) -> Batches:
    """Batches of the store at `path`, in row order or shuffled by (seed, epoch)."""
    _check_batch_size(batch_size)
    source = StoreExamples(path, transform)
    order = store_order(len(source), shuffle, seed, epoch)
    stop = len(order) - len(order) % batch_size if drop_last else len(order)
    plan = [order[i : i + batch_size] for i in range(0, stop, batch_size)]
    return Batches(source, plan, workers)


def stream_batches(
    batch_size: int,
    batches: int,
    *,
    params: Params = STANDARD,
    seed: int = 0,
    epoch: int = 0,
    transform: InputTransform | None = None,
    direct: bool = False,
    workers: int = 0,
) -> Batches:
    """`batches` batches of freshly generated examples; epoch e uses generator indices
    [e * batches * batch_size, (e + 1) * batches * batch_size). `direct`: see GeneratedExamples."""
    _check_batch_size(batch_size)
    if batches < 1 or epoch < 0:
        raise InputError(f"need batches >= 1 and epoch >= 0, got batches={batches}, epoch={epoch}")
    source = GeneratedExamples(params, seed, transform, direct)
    return Batches(source, [stream_indices(b, batch_size, batches, epoch) for b in range(batches)], workers)
