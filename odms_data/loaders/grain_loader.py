"""grain datasets (JAX's data loader): a store as a random-access source, and the generated stream.

    import grain
    from odms_data.loaders.grain_loader import StoreSource, stream_dataset

    val = grain.MapDataset.source(StoreSource("sim-val.zarr")).batch(512)
    train = (grain.MapDataset.source(StoreSource("train.zarr")).seed(1).shuffle().repeat(10).batch(512)
             .to_iter_dataset().mp_prefetch(grain.MultiprocessingOptions(num_workers=2)))
    threads = grain.ReadOptions(num_threads=2, prefetch_buffer_size=2)
    stream = stream_dataset(512, 5000, epochs=10, seed=1).to_iter_dataset(threads)
    for batch in stream: ...  # batch["masks"]: (512, 10, 112, 112) float32, ready for jax.device_put

An element of `StoreSource` is one example's network inputs (transforms.py), by store row. An
element of `stream_dataset` is a whole batch, drawn together (as the other loaders draw it):
element k holds generator indices k * batch_size + [0, batch_size), i.e. batch b of epoch e is
element e * batches_per_epoch + b, the same batch as PyTorch's StreamDataset and the NumPy loader
give. grain keeps the order, so the batches do not depend on the number of threads or workers,
and its iterators' get_state/set_state resume a run exactly.

Draw the stream with grain's threads, as above: the drawing releases the GIL, so threads draw
batches in parallel and hand them over as they are, where mp_prefetch puts every batch in a fresh
shared memory block whose pages are all faulted in anew (docs/LOADERS.md, "Throughput"). Give
`to_iter_dataset` a small prefetch buffer: by default grain reads up to 500 elements ahead, and
here an element is a whole batch (128 MB for 512 examples).
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..extras import missing
from .kinds import STANDARD, InputTransform, Params
from .reused_arrays import ReusedArrays
from .sources import GeneratedExamples, StoreExamples, stream_indices

try:
    import grain
    from absl import flags
except ModuleNotFoundError as e:
    raise missing(e, "odms_data.loaders.grain_loader") from None

if not flags.FLAGS.is_parsed():
    # grain 0.2.18's mp_prefetch reads an absl flag and fails (UnparsedFlagAccessError) in any
    # program that does not start through absl.app (google/grain#1355); its defaults are what we want.
    flags.FLAGS.mark_as_parsed()


class StoreSource:
    """The examples of the store at `path` as a grain random-access data source (len and row
    indexing); picklable, the store is opened in each worker process on first use."""

    def __init__(self, path: str, transform: InputTransform | None = None) -> None:
        self.examples = StoreExamples(path, transform)

    def __len__(self) -> int:
        return len(self.examples)

    def __getitem__(self, row: int) -> dict[str, np.ndarray]:
        return self.examples.example(int(row))

    def __repr__(self) -> str:
        return f"StoreSource({self.examples.path!r})"


class _StreamBatch:
    """Element k of the stream: the batch of generator indices k * batch_size + [0, batch_size)."""

    def __init__(self, examples: GeneratedExamples, batch_size: int) -> None:
        self.examples, self.batch_size = examples, batch_size
        self.arrays = ReusedArrays()  # batches nothing holds any more are drawn into again

    def __call__(self, k: int) -> dict[str, np.ndarray]:
        return self.examples.batch(stream_indices(k, self.batch_size, 1, 0), self.arrays.empty)


def stream_dataset(
    batch_size: int,
    batches_per_epoch: int,
    *,
    epochs: int = 1,
    params: Params = STANDARD,
    seed: int = 0,
    transform: InputTransform | None = None,
    direct: bool = False,
) -> grain.MapDataset:
    """`epochs * batches_per_epoch` batches of freshly generated examples, no example twice.
    `direct`: see sources.GeneratedExamples."""
    if batch_size < 1 or batches_per_epoch < 1 or epochs < 1:
        raise InputError(f"need batch_size, batches_per_epoch and epochs >= 1, got {batch_size}, "
                         f"{batches_per_epoch}, {epochs}")
    examples = GeneratedExamples(params, seed, transform, direct)
    return grain.MapDataset.range(epochs * batches_per_epoch).map(_StreamBatch(examples, batch_size))
