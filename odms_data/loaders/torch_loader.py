"""PyTorch datasets: a map-style one over a store and an iterable one streaming generated batches.

    from torch.utils.data import DataLoader
    from odms_data.loaders.torch_loader import StoreDataset, StreamDataset

    val = DataLoader(StoreDataset("sim-val.zarr"), batch_size=512, num_workers=2)
    train = StreamDataset(batch_size=512, batches_per_epoch=5000, seed=1)
    loader = DataLoader(train, batch_size=None, num_workers=2)  # the dataset makes whole batches
    for epoch in range(epochs):
        train.set_epoch(epoch)
        for batch in loader: ...

StreamDataset: batch b of epoch e holds generator indices ((e * batches_per_epoch + b) * batch_size
...+ batch_size), and worker w of W makes batches b = w, w + W, ...; DataLoader hands them out in
that round-robin order, so the batch sequence depends only on (params, seed, transform, batch
size) — not on the number of workers — and no example appears twice in or across epochs. The
epoch lives in shared memory, so set_epoch also reaches persistent workers.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..extras import missing
from .kinds import STANDARD, InputTransform, Params
from .shared_batches import BlockLayout, received_arrays, worker_blocks
from .sources import GeneratedExamples, StoreExamples, stream_indices

try:
    import torch
    from torch.utils.data import Dataset, IterableDataset, get_worker_info
except ModuleNotFoundError as e:
    raise missing(e, "odms_data.loaders.torch_loader") from None


def to_tensors(arrays: dict[str, np.ndarray]) -> dict[str, torch.Tensor]:
    return {k: torch.from_numpy(np.asarray(v)) for k, v in arrays.items()}


class StoreDataset(Dataset):
    """Example i of the store at `path` as a dict of tensors (ODN's inputs, or DBox's with a
    BoxTransform); the store is opened in each worker on first use. Shuffle reproducibly with
    DataLoader(..., shuffle=True, generator=torch.Generator().manual_seed(seed))."""

    def __init__(self, path: str, transform: InputTransform | None = None) -> None:
        self.examples = StoreExamples(path, transform)

    def __len__(self) -> int:
        return len(self.examples)

    def __getitem__(self, i: int) -> dict[str, torch.Tensor]:
        return to_tensors(self.examples.example(int(i)))

    def __getitems__(self, indices: list[int]) -> list[dict[str, torch.Tensor]]:
        """A DataLoader batch at once: nearby rows are read from the store in one slice."""
        return [to_tensors(e) for e in self.examples.examples(indices)]


class StreamDataset(IterableDataset):
    """`batches_per_epoch` batches of `batch_size` freshly generated examples per epoch; use with
    DataLoader(dataset, batch_size=None, num_workers=...) and call set_epoch(e) before each epoch.
    `start`: the first batch of each epoch to make (to resume an interrupted run where it stopped).
    `direct`: see sources.GeneratedExamples."""

    def __init__(
        self,
        batch_size: int,
        batches_per_epoch: int,
        *,
        params: Params = STANDARD,
        seed: int = 0,
        transform: InputTransform | None = None,
        direct: bool = False,
        start: int = 0,
    ) -> None:
        if batch_size < 1 or batches_per_epoch < 1:
            raise InputError(
                f"need batch_size >= 1 and batches_per_epoch >= 1, got {batch_size}, {batches_per_epoch}"
            )
        if not 0 <= start < batches_per_epoch:
            raise InputError(f"start must be a batch of the epoch, 0..{batches_per_epoch - 1}; got {start}")
        self.examples = GeneratedExamples(params, seed, transform, direct)
        self.batch_size, self.batches_per_epoch, self.start = batch_size, batches_per_epoch, start
        # In shared memory, so that set_epoch reaches workers started earlier (persistent_workers=True):
        # DataLoader hands a worker the dataset once, and pickles this tensor as a handle, not a copy.
        self._epoch = torch.zeros((), dtype=torch.int64).share_memory_()

    @property
    def epoch(self) -> int:
        return int(self._epoch)

    def set_epoch(self, epoch: int) -> None:
        if epoch < 0:
            raise InputError(f"epoch must be >= 0, got {epoch}")
        self._epoch.fill_(epoch)

    def __len__(self) -> int:
        return self.batches_per_epoch - self.start

    def __iter__(self):
        info = get_worker_info()
        worker, workers = (info.id, info.num_workers) if info else (0, 1)
        epoch = self.epoch  # read when the epoch starts: iter(loader) comes after set_epoch
        blocks = worker_blocks() if info else None
        for b in range(self.start + worker, self.batches_per_epoch, workers):
            indices = stream_indices(b, self.batch_size, self.batches_per_epoch, epoch)
            if blocks is None:
                yield to_tensors(self.examples.batch(indices))
                continue
            arena = blocks.arena()  # a DataLoader worker: made in a block of its own, sent without a copy
            yield blocks.send(arena, self.examples.batch(indices, arena.empty), received_tensors)


def received_tensors(name: str, layout: BlockLayout) -> dict[str, torch.Tensor]:
    """In the main process: a worker's batch (shared_batches.SharedBatch) as tensors viewing its block."""
    return to_tensors(received_arrays(name, layout))
