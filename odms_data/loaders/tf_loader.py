"""TensorFlow: `tf.data.Dataset`s of batches from a store or from the generator.

    from odms_data.loaders.tf_loader import from_generator
    ds = from_generator(512, 5000, seed=1, workers=2).prefetch(2)
    for batch in ds: ...  # dict of tensors, batch["masks"]: (512, 10, 112, 112) float32

Both wrap `numpy_loader`'s batch iterators (same arguments, same batches), whose `workers`
processes make batches in parallel outside TensorFlow's threads.
"""

from __future__ import annotations

from typing import Any

from ..extras import missing
from .numpy_loader import Batches, store_batches, stream_batches

try:
    import tensorflow as tf
except ModuleNotFoundError as e:
    raise missing(e, "odms_data.loaders.tf_loader") from None


def dataset(batches: Batches) -> tf.data.Dataset:
    """A dataset yielding `batches` (each iteration makes them again, identically)."""
    first = batches.source.example(int(batches.plan[0][0]))
    signature = {
        k: tf.TensorSpec((None, *v.shape), tf.as_dtype(v.dtype)) for k, v in first.items()
    }
    return tf.data.Dataset.from_generator(lambda: iter(batches), output_signature=signature)


def from_store(path: str, batch_size: int, **options: Any) -> tf.data.Dataset:
    """Batches of the store at `path`; options as numpy_loader.store_batches (transform,
    shuffle, seed, epoch, drop_last, workers)."""
    return dataset(store_batches(path, batch_size, **options))


def from_generator(batch_size: int, batches: int, **options: Any) -> tf.data.Dataset:
    """Freshly generated batches; options as numpy_loader.stream_batches (params, seed, epoch,
    transform, direct, workers)."""
    return dataset(stream_batches(batch_size, batches, **options))
