"""PyTorch datasets with the real DataLoader, in-process and with 2 workers."""

from __future__ import annotations

import functools
import multiprocessing
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
from loader_stores import COUNT, make_store
from torch.utils.data import DataLoader

from odms_data import parallel
from odms_data.errors import InputError
from odms_data.loaders import Transform
from odms_data.loaders.torch_loader import StoreDataset, StreamDataset
from odms_data.simulate.params import GeneratorParams
from odms_data.store.reader import open_store


def two_workers(dataset, **kwargs) -> DataLoader:
    """Workers forked from the fork server, not from pytest: forking a pytest process that has
    started JAX or TensorFlow threads can deadlock. The dataset reaches them pickled, as it reaches
    spawned workers; unlike spawned ones, they do not each import torch (seconds) when the server
    has (`_fork_server`). Store handles inherited across fork are covered in test_numpy_loader."""
    return DataLoader(dataset, num_workers=2, multiprocessing_context=_fork_server(), **kwargs)


@functools.cache
def _fork_server() -> multiprocessing.context.BaseContext:
    """The process's fork server, started as odms_data.parallel starts it, but with torch's loader
    loaded too, unless an earlier test started it (then each worker imports torch itself)."""
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload([parallel.WARM_START, "odms_data.loaders.torch_loader"])
    parallel._start_fork_server()
    return context


@pytest.fixture(scope="module", params=["zarr", "hdf5"])
def store_path(request, tmp_path_factory):
    return make_store(tmp_path_factory.mktemp(request.param), request.param)


def _indices(loader) -> list[int]:
    return torch.cat([b["index"] for b in loader]).tolist()


def test_store_dataset(store_path):
    ds = StoreDataset(store_path, Transform(size=(56, 56), n_obs=5, rounded=True))
    loader = two_workers(ds, batch_size=8)
    batches = list(loader)
    b = batches[0]
    assert b["masks"].shape == (8, 5, 56, 56) and b["masks"].dtype == torch.uint8
    assert b["d1"].dtype == torch.float32 and b["zbar"].shape == (8, 3)
    assert _indices(batches) == list(range(COUNT))  # every example once across the 2 workers
    with open_store(store_path) as s:
        d1 = torch.cat([b["d1"] for b in batches]).numpy()
        np.testing.assert_array_equal(d1, s.d1.astype(np.float32))
    single = list(DataLoader(ds, batch_size=8))
    assert all(torch.equal(x[k], y[k]) for x, y in zip(batches, single, strict=True) for k in x)


def test_store_dataset_shuffle_reproducible(store_path):
    ds = StoreDataset(store_path)

    def order(seed):
        g = torch.Generator().manual_seed(seed)
        return _indices(two_workers(ds, batch_size=6, shuffle=True, generator=g))

    first = order(1)
    assert first == order(1) != order(2)
    assert sorted(first) == list(range(COUNT))


def test_stream_dataset_workers_and_epochs():
    ds = StreamDataset(8, 4, params=GeneratorParams(n_obs=6), seed=3)
    two = list(two_workers(ds, batch_size=None))
    one = list(DataLoader(ds, batch_size=None))
    assert _indices(two) == list(range(32))  # no duplicates, none missing
    assert all(torch.equal(x[k], y[k]) for x, y in zip(two, one, strict=True) for k in x)
    assert two[0]["masks"].shape == (8, 6, 112, 112) and two[0]["masks"].dtype == torch.float32
    assert two[0]["dz"].shape == (8, 5) and two[0]["zbar"].shape == (8, 4)
    ds.set_epoch(1)
    assert _indices(two_workers(ds, batch_size=None)) == list(range(32, 64))
    again = StreamDataset(8, 4, params=GeneratorParams(n_obs=6), seed=3)
    assert torch.equal(next(iter(again))["masks"], two[0]["masks"])


def test_stream_workers_hand_batches_over_in_reused_blocks_without_copies():
    """Each batch from a DataLoader worker views a block mapped from that worker; a block dropped by
    the training loop carries a later batch, epoch after epoch with persistent workers, so 48
    batches need a handful of blocks."""
    from odms_data.loaders import shared_batches

    ds = StreamDataset(4, 24, params=GeneratorParams(n_obs=3), seed=5, transform=Transform(size=(32, 32)))
    single = list(DataLoader(ds, batch_size=None))
    loader = two_workers(ds, batch_size=None, persistent_workers=True)
    before, seen = set(shared_batches._RECEIVED), set()
    for _ in range(2):
        for batch, expected in zip(loader, single, strict=True):
            assert all(torch.equal(batch[k], expected[k]) for k in batch)
            spans = {name: (np.frombuffer(b.buf, np.uint8).ctypes.data, len(b.buf))
                     for name, b in shared_batches._RECEIVED.items() if name not in before}
            inside = [name for name, (start, size) in spans.items()
                      if start <= batch["masks"].data_ptr() < start + size]
            assert len(inside) == 1  # a view of one worker's block, not a copy
            seen.update(inside)
            del batch
    assert 2 <= len(seen) <= 8  # per worker: prefetch (2), the one being made, the one held here


def test_stream_dataset_epochs_reach_persistent_workers():
    """DataLoader hands persistent workers the dataset once; set_epoch must still reach them."""
    ds = StreamDataset(4, 3, params=GeneratorParams(n_obs=3), seed=3)
    loader = two_workers(ds, batch_size=None, persistent_workers=True)
    seen = []
    for epoch in range(3):
        ds.set_epoch(epoch)
        seen.append(_indices(loader))
    assert seen == [list(range(12 * e, 12 * (e + 1))) for e in range(3)]


def test_stream_dataset_resumes_at_a_batch():
    whole = list(DataLoader(StreamDataset(4, 5, seed=3), batch_size=None))
    rest = StreamDataset(4, 5, seed=3, start=2)
    assert len(rest) == 3
    later = list(two_workers(rest, batch_size=None))
    assert _indices(later) == list(range(8, 20))  # batches 2, 3, 4 in order, across 2 workers
    assert all(torch.equal(x[k], y[k]) for x, y in zip(whole[2:], later, strict=True) for k in x)
    with pytest.raises(InputError, match="start must be a batch of the epoch, 0..4; got 5"):
        StreamDataset(4, 5, start=5)


PERSISTENT = """
from torch.utils.data import DataLoader
from odms_data.loaders import Transform, shared_batches
from odms_data.loaders.torch_loader import StreamDataset
from odms_data.simulate.params import GeneratorParams
if __name__ == "__main__":
    ds = StreamDataset(4, 3, params=GeneratorParams(image_size=(60, 80), sizes=(20,)), seed=1,
                       transform=Transform(size=(32, 32)))
    loader = DataLoader(ds, batch_size=None, num_workers=2, persistent_workers=True)
    for epoch in range(2):
        ds.set_epoch(epoch)
        assert len(list(loader)) == 3
    print(" ".join(shared_batches._RECEIVED))  # the workers' blocks, left for the exit to remove
"""


def test_persistent_workers_leak_nothing_at_exit(tmp_path):
    """The program ends with persistent workers alive: their blocks go, without a resource_tracker
    warning about leaked shared memory."""
    script = tmp_path / "persistent.py"
    script.write_text(PERSISTENT)
    r = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "resource_tracker" not in r.stderr and "leaked" not in r.stderr, r.stderr
    names = r.stdout.split()
    assert names and not [n for n in names if Path("/dev/shm", n).exists()]
