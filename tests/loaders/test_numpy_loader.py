"""The framework-free loaders: store and generator batches."""

from __future__ import annotations

import os

import numpy as np
import pytest
from loader_stores import COUNT, PARAMS, make_store

from odms_data.errors import InputError
from odms_data.loaders import GeneratedExamples, StoreExamples, Transform, store_batches, stream_batches
from odms_data.simulate.object_model import sample_example
from odms_data.simulate.params import GeneratorParams
from odms_data.simulate.render import reference_masks
from odms_data.simulate.shrink import resize_masks
from odms_data.store.reader import open_store


@pytest.fixture(scope="module", params=["zarr", "hdf5"])
def store_path(request, tmp_path_factory):
    return make_store(tmp_path_factory.mktemp(request.param), request.param)


def test_store_batches_shapes_and_labels(store_path):
    t = Transform(size=(56, 56), n_obs=4, radial=True)
    batches = list(store_batches(store_path, 10, transform=t))
    assert [len(b["index"]) for b in batches] == [10, 10, 4]
    b = batches[0]
    assert b["masks"].shape == (10, 4, 56, 56) and b["masks"].dtype == np.float32
    assert b["dz"].shape == (10, 3) and b["zbar"].shape == (10, 2) and b["radial"].shape == (10, 1, 56, 56)
    assert all(b[k].dtype == np.float32 for k in ("dz", "zbar", "d1", "d1_norm", "scale"))
    with open_store(store_path) as s:
        d1 = np.concatenate([b["d1"] for b in batches])
        np.testing.assert_array_equal(d1, s.d1.astype(np.float32))
        z = s.z[s.frame_index[:, [0, 3, 6, 9]]]
        np.testing.assert_allclose(np.concatenate([b["dz"] for b in batches]), z[:, 1:] - z[:, :1], atol=1e-6)
        ex = s.example(3)
    masks = t(ex.masks[[0, 3, 6, 9]], ex.z[[0, 3, 6, 9]], ex.d1)["masks"]
    np.testing.assert_array_equal(batches[0]["masks"][3], masks)


def test_store_shuffle_is_reproducible(store_path):
    one = [b["index"] for b in store_batches(store_path, 8, shuffle=True, seed=3, drop_last=True)]
    two = [b["index"] for b in store_batches(store_path, 8, shuffle=True, seed=3, drop_last=True)]
    other = [b["index"] for b in store_batches(store_path, 8, shuffle=True, seed=3, epoch=1)]
    assert all(np.array_equal(a, b) for a, b in zip(one, two, strict=True))
    assert sorted(np.concatenate(one).tolist()) == list(range(COUNT))
    assert not np.array_equal(np.concatenate(one), np.concatenate(other))


def test_store_example_native_size(store_path):
    ex = StoreExamples(store_path, Transform(size=None)).example(0)
    assert ex["masks"].shape == (10, *PARAMS.image_size)
    spec = sample_example(PARAMS, 5, 0)
    np.testing.assert_array_equal(ex["masks"], reference_masks(spec, PARAMS))


def test_stream_same_seed_same_batches_and_epochs_disjoint():
    params = GeneratorParams(n_obs=6)
    a = list(stream_batches(16, 3, params=params, seed=9))
    b = list(stream_batches(16, 3, params=params, seed=9, workers=2))
    assert all(np.array_equal(x[k], y[k]) for x, y in zip(a, b, strict=True) for k in x)
    assert np.concatenate([x["index"] for x in a]).tolist() == list(range(48))
    e1 = np.concatenate([x["index"] for x in stream_batches(16, 3, params=params, seed=9, epoch=1)])
    assert e1.tolist() == list(range(48, 96))
    other = next(iter(stream_batches(16, 1, params=params, seed=10)))
    assert not np.array_equal(other["masks"], a[0]["masks"])


def test_streamed_example_is_the_generators():
    params = GeneratorParams(n_obs=10)
    ex = GeneratedExamples(params, 4, Transform(n_obs=5)).example(7)
    spec = sample_example(params, 4, 7)
    chosen = [0, 2, 4, 6, 9]
    full = reference_masks(spec, params)[chosen]
    np.testing.assert_array_equal(ex["masks"], resize_masks(full, (112, 112), coverage=True))
    assert ex["masks"].dtype == np.float32 and ((ex["masks"] > 0) & (ex["masks"] < 1)).any()  # fractions
    assert ex["d1"] == np.float32(spec.z[0]) and ex["index"] == 7
    np.testing.assert_allclose(ex["dz"], spec.z[chosen][1:] - spec.z[0], atol=1e-6)
    rounded = GeneratedExamples(params, 4, Transform(n_obs=5, rounded=True)).example(7)
    np.testing.assert_array_equal(rounded["masks"], resize_masks(full, (112, 112)))
    assert rounded["masks"].dtype == np.uint8
    direct = GeneratedExamples(params, 4, Transform(n_obs=5), direct=True).example(7)
    np.testing.assert_array_equal(direct["masks"], reference_masks(spec, params, (112, 112))[chosen])


def test_stream_equals_store_read_through_loader(store_path):
    t = Transform(size=(56, 56), n_obs=5, radial=True)
    stored = next(iter(store_batches(store_path, COUNT, transform=t)))
    streamed = next(iter(stream_batches(COUNT, 1, params=PARAMS, seed=5, transform=t)))
    assert stored.keys() == streamed.keys()
    assert all(np.array_equal(stored[k], streamed[k]) for k in stored)


def test_in_process_batches_reuse_only_dropped_arrays():
    params = GeneratorParams(image_size=(60, 80), n_obs=3)
    batches = iter(stream_batches(4, 4, params=params, transform=Transform(size=(28, 28))))
    kept = next(batches)
    copy = {k: v.copy() for k, v in kept.items()}
    view = next(batches)["masks"][1:]  # batch 1 dropped, a view of its masks kept
    third = next(batches)
    assert all(np.array_equal(kept[k], copy[k]) for k in kept)  # batches 1 and 2 drew elsewhere
    assert not np.shares_memory(third["masks"], kept["masks"]) and not np.shares_memory(third["masks"], view)
    pointer = third["masks"].ctypes.data
    del third
    assert next(batches)["masks"].ctypes.data == pointer  # dropped: its memory drawn into again


def test_bad_arguments():
    with pytest.raises(InputError, match="batch size"):
        stream_batches(0, 3)
    with pytest.raises(InputError, match="n_obs=12"):
        GeneratedExamples(GeneratorParams(n_obs=10), 0, Transform(n_obs=12))
    with pytest.raises(InputError, match="seed"):
        GeneratedExamples(seed=-1)


def test_store_handle_is_per_process(store_path):
    import pickle

    examples = StoreExamples(store_path)
    first = examples.store
    examples._pid = -1  # as after a fork: the handle belongs to another process
    assert examples.store is not first
    copy = pickle.loads(pickle.dumps(examples))  # as sent to a worker
    assert copy._store is None
    np.testing.assert_array_equal(copy.example(2)["masks"], examples.example(2)["masks"])


def test_batch_reads_scattered_rows_one_by_one(store_path):
    examples = StoreExamples(store_path, Transform(size=(30, 40), n_obs=2))
    rows = [23, 0, 12, 5]  # 8 frames spread over 240: read per example, not in one slice
    batch = examples.batch(rows)
    for j, i in enumerate(rows):
        assert np.array_equal(batch["masks"][j], examples.example(i)["masks"])
    assert batch["index"].tolist() == rows


def test_worker_error_reaches_the_caller_and_leaves_no_blocks(store_path):
    before = set(os.listdir("/dev/shm"))
    batches = store_batches(store_path, 8, transform=Transform(n_obs=12), workers=2)  # the store has n = 10
    with pytest.raises(InputError, match=r"example .*n_obs=12 for an example of 10 frames"):
        next(iter(batches))
    assert set(os.listdir("/dev/shm")) <= before
