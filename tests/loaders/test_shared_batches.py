"""Batches handed from workers to the caller in reused shared memory blocks."""

from __future__ import annotations

import gc
import sys
import threading
from pathlib import Path

import numpy as np

from odms_data.loaders import Transform, stream_batches
from odms_data.loaders.shared_batches import Arena, BlockPool
from odms_data.simulate.params import GeneratorParams

PARAMS = GeneratorParams(n_obs=6)
SHM = Path("/dev/shm")


def shm_names() -> set[str]:
    """Names of the POSIX shared memory blocks (Linux keeps them in /dev/shm, beside the named
    semaphores of any process's multiprocessing, which are not blocks)."""
    return {p.name for p in SHM.iterdir() if not p.name.startswith("sem.")}


def make(lent: str | None, n: int) -> tuple[str, dict]:
    """What a worker does: a batch of n rows allocated in the arena."""
    arena = Arena(lent)
    a, b = arena.empty((n, 3), np.dtype(np.float32)), arena.empty((n,), np.dtype(np.int64))
    a[...], b[...] = np.arange(3 * n).reshape(n, 3), np.arange(n)
    return arena.finish({"a": a, "b": b})


def test_block_is_reused_only_after_its_batch_is_gone():
    pool = BlockPool()
    first = pool.take(*make(None, 4), None)
    assert pool.lend() is None  # the only block is still in use
    np.testing.assert_array_equal(first["a"][3], [9, 10, 11])
    view = first["b"][1:]
    del first
    gc.collect()
    assert pool.lend() is None  # a view of the batch still holds it
    del view
    gc.collect()
    lent = pool.lend()
    assert lent is not None
    name, layout = make(lent, 4)
    assert name == lent  # written into the lent block, no new one
    second = pool.take(name, layout, lent)
    np.testing.assert_array_equal(second["b"], np.arange(4))
    bigger = make(pool.lend(), 50)  # nothing free: a new block
    assert bigger[0] != name
    pool.close()
    np.testing.assert_array_equal(second["a"][:, 0], [0, 3, 6, 9])  # still readable after close


def test_too_small_lent_block_is_replaced():
    pool = BlockPool()
    small = pool.take(*make(None, 2), None)
    del small
    gc.collect()
    lent = pool.lend()
    name, layout = make(lent, 1000)
    assert name != lent
    batch = pool.take(name, layout, lent)
    assert lent not in pool.blocks and batch["a"].shape == (1000, 3)
    pool.close()


def test_worker_batches_equal_in_process_ones_when_some_are_kept():
    t = Transform(size=(40, 40))
    want = list(stream_batches(8, 14, params=PARAMS, seed=2, transform=t))
    before = shm_names()
    kept, addresses = [], set()
    for i, batch in enumerate(stream_batches(8, 14, params=PARAMS, seed=2, transform=t, workers=2)):
        addresses.add(batch["masks"].ctypes.data)
        if i % 3 == 0:
            kept.append((i, batch))  # held: its block must not be lent again
        del batch
    for i, batch in kept:
        assert all(np.array_equal(batch[k], want[i][k]) for k in want[i])
    assert len(addresses) < 14  # blocks were reused
    assert shm_names() <= before  # every block's name is removed at the end


def test_stopping_early_leaves_no_blocks():
    before = shm_names()
    batches = stream_batches(4, 50, params=PARAMS, transform=Transform(size=(32, 32)), workers=2)
    for i, _ in enumerate(batches):
        if i == 2:
            break
    gc.collect()
    assert shm_names() <= before


def test_close_removes_block_names():
    pool = BlockPool()
    name, layout = make(None, 3)
    assert name.lstrip("/") in shm_names()
    pool.take(name, layout, None)
    pool.close()
    assert name.lstrip("/") not in shm_names()


def test_batches_dropped_in_another_thread_while_closing():
    """TensorFlow drops batches in its own thread, possibly while the pool closes."""
    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)  # switch threads as often as possible, to interleave the two
    try:
        for _ in range(20):
            pool = BlockPool()
            batches = [pool.take(*make(None, 2), None) for _ in range(40)]
            dropper = threading.Thread(target=lambda held=batches: [held.pop() for _ in range(40)])
            dropper.start()
            pool.close()
            dropper.join()
            gc.collect()
            assert not pool.free and not pool.blocks
    finally:
        sys.setswitchinterval(interval)
