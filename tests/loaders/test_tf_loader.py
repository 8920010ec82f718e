"""tf.data datasets from a store and from the generator."""

from __future__ import annotations

import numpy as np
import tensorflow as tf
from loader_stores import COUNT, make_store

from odms_data.loaders import Transform, stream_batches
from odms_data.loaders.tf_loader import from_generator, from_store
from odms_data.store.reader import open_store


def test_from_store(tmp_path):
    path = make_store(tmp_path, "zarr")
    ds = from_store(path, 10, transform=Transform(size=(56, 56), n_obs=4))
    batches = list(ds.as_numpy_iterator())
    assert batches[0]["masks"].shape == (10, 4, 56, 56) and batches[0]["masks"].dtype == np.float32
    assert ds.element_spec["d1"].dtype == tf.float32
    assert np.concatenate([b["index"] for b in batches]).tolist() == list(range(COUNT))
    with open_store(path) as s:
        np.testing.assert_array_equal(np.concatenate([b["d1"] for b in batches]), s.d1.astype(np.float32))


def test_from_generator_matches_numpy_loader():
    # enough batches that workers reuse shared memory blocks TensorFlow's thread has let go of
    ds = from_generator(6, 9, seed=4, workers=2, transform=Transform(size=(32, 32)))
    got = list(ds.as_numpy_iterator())
    want = list(stream_batches(6, 9, seed=4, transform=Transform(size=(32, 32))))
    assert all(np.array_equal(g[k], w[k]) for g, w in zip(got, want, strict=True) for k in w)
    assert list(ds.as_numpy_iterator())[1]["index"].tolist() == list(range(6, 12))
