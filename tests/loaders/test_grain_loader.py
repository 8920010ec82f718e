"""grain datasets with the real grain package: in-process, with 2 prefetch processes, resumed."""

from __future__ import annotations

import grain
import numpy as np
from loader_stores import COUNT, make_store

from odms_data.loaders import Transform, stream_batches
from odms_data.loaders.grain_loader import StoreSource, stream_dataset
from odms_data.simulate.params import GeneratorParams

SMALL = Transform(size=(56, 56), n_obs=5)


def _run(ds: grain.MapDataset, workers: int) -> list[dict[str, np.ndarray]]:
    it = iter(ds.to_iter_dataset().mp_prefetch(grain.MultiprocessingOptions(num_workers=workers)))
    try:
        return list(it)
    finally:
        it.close()


def _equal(a: list[dict[str, np.ndarray]], b: list[dict[str, np.ndarray]]) -> bool:
    return len(a) == len(b) and all(np.array_equal(x[k], y[k]) for x, y in zip(a, b, strict=True) for k in x)


def test_store_source_shuffled_batches_match_the_store_and_ignore_workers(tmp_path):
    path = make_store(tmp_path, "zarr")
    source = StoreSource(str(path), SMALL)
    assert len(source) == COUNT and "small.zarr" in repr(source)
    ds = grain.MapDataset.source(source).seed(7).shuffle().batch(5)
    one, two = _run(ds, 0), _run(ds, 2)
    assert _equal(one, two)
    rows = np.concatenate([b["index"] for b in one])
    assert sorted(rows.tolist()) == list(range(COUNT)) and rows.tolist() != list(range(COUNT))
    assert one[0]["masks"].shape == (5, 5, 56, 56) and one[0]["masks"].dtype == np.float32
    first = source[int(rows[0])]
    assert all(np.array_equal(one[0][k][0], first[k]) for k in first)
    reseeded = grain.MapDataset.source(source).seed(8).shuffle().batch(5)
    assert np.concatenate([b["index"] for b in _run(reseeded, 0)]).tolist() != rows.tolist()


def test_stream_dataset_is_the_other_loaders_stream_and_ignores_workers():
    params = GeneratorParams(n_obs=6)
    ds = stream_dataset(6, 3, epochs=2, params=params, seed=3, transform=SMALL)
    one, two = _run(ds, 0), _run(ds, 2)
    assert _equal(one, two)
    assert np.concatenate([b["index"] for b in one]).tolist() == list(range(36))  # no example twice
    epoch1 = list(stream_batches(6, 3, epoch=1, params=params, seed=3, transform=SMALL))
    assert _equal(one[3:], epoch1)
    again = stream_dataset(6, 3, epochs=2, params=params, seed=3, transform=SMALL)
    assert _equal(_run(again, 0), one)


def test_stream_iterator_resumes_from_a_checkpoint():
    ds = stream_dataset(4, 5, params=GeneratorParams(n_obs=5), seed=1, transform=SMALL).to_iter_dataset()
    it = iter(ds)
    first = [next(it) for _ in range(2)]
    state = it.get_state()
    rest = list(it)
    resumed = iter(ds)
    resumed.set_state(state)
    assert _equal(list(resumed), rest) and len(first) + len(rest) == 5
