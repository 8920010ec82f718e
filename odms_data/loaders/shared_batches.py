"""Batches carried from worker processes to the caller in shared memory, without copies.

A worker writes a batch's arrays straight into a shared memory block lent by the caller (the
sources allocate through `Arena.empty`); the caller gets arrays that are views of its own mapping
of that block. A block goes back to the free list once every array of the batch it carried is
gone, so in a training loop the same few blocks carry every batch and no page is faulted in twice.
Reusing blocks saves both what pickling a batch through a pipe costs and the page faults of a
fresh block per batch in each process.
"""

from __future__ import annotations

import _posixshmem  # type: ignore[import-not-found]  # the stdlib's, behind SharedMemory
import contextlib
import ctypes
import mmap
import multiprocessing.util
import os
import signal
import threading
import weakref
from multiprocessing.shared_memory import SharedMemory
from typing import cast

import numpy as np

from ..parallel import work_lock

BlockLayout = dict[str, tuple[tuple[int, ...], str, int]]  # key -> shape, dtype, byte offset in the block
_ALIGN = 64
HEADER = _ALIGN  # bytes at the start of a block before its arrays: the flags below
BUSY, RETIRED = 0, 2  # header bytes of a block a DataLoader worker owns (WorkerBlocks)
_ATTACHED: dict[str, SharedMemory] = {}  # blocks this worker has mapped, by name


class _Block(SharedMemory):
    """A block that may outlive its SharedMemory object: arrays viewing it keep the mapping."""

    def __del__(self) -> None:
        with contextlib.suppress(BufferError, OSError):
            self.close()


def _attach(name: str) -> SharedMemory:
    if name not in _ATTACHED:
        _ATTACHED[name] = _Block(name=name)
    return _ATTACHED[name]


def _buffer(block: SharedMemory) -> memoryview:
    """The block's mapping; the stubs allow None, which only a closed block has."""
    return cast(memoryview, block.buf)


def _aligned(n: int) -> int:
    return -(-n // _ALIGN) * _ALIGN


class Arena:
    """A worker's allocator for one batch: arrays in the lent block while they fit, private
    memory after that (`finish` then moves the batch to a new block)."""

    def __init__(self, lent: str | None) -> None:
        self.block = _attach(lent) if lent else None
        self.used = HEADER
        self.address = np.frombuffer(_buffer(self.block), np.uint8).ctypes.data if self.block else 0

    def empty(self, shape: tuple[int, ...], dtype: np.dtype) -> np.ndarray:
        nbytes = int(np.prod(shape)) * np.dtype(dtype).itemsize
        start = _aligned(self.used)
        self.used = start + nbytes
        if self.block is None or self.used > self.block.size:
            return np.empty(shape, dtype)
        return np.ndarray(shape, dtype, buffer=self.block.buf, offset=start)

    def _offset(self, a: np.ndarray) -> int | None:
        """Where `a` lies in the lent block, if it is a contiguous piece of it."""
        if self.block is None or not a.flags.c_contiguous:
            return None
        offset = a.ctypes.data - self.address
        return offset if 0 <= offset and offset + a.nbytes <= self.block.size else None

    def finish(self, batch: dict[str, np.ndarray]) -> tuple[str, BlockLayout]:
        """The block holding `batch` and where each array lies in it."""
        offsets = {key: o for key, a in batch.items() if (o := self._offset(a)) is not None}
        if self.block is not None and len(offsets) == len(batch):
            return self.block.name, {k: (a.shape, a.dtype.str, offsets[k]) for k, a in batch.items()}
        with work_lock:  # created and registered with the resource tracker, or not at all
            block = _Block(create=True, size=HEADER + sum(_aligned(a.nbytes) for a in batch.values()))
        _ATTACHED[block.name] = block
        layout, offset = {}, HEADER
        for key, a in batch.items():
            np.ndarray(a.shape, a.dtype, buffer=block.buf, offset=offset)[...] = a
            layout[key] = (a.shape, a.dtype.str, offset)
            offset += _aligned(a.nbytes)
        return block.name, layout


def _views(buf: memoryview, layout: BlockLayout, release, *args) -> dict[str, np.ndarray]:
    """The arrays of `layout` viewing a block's `buf`; `release(*args)` is called once they are all gone."""
    sizes = {k: int(np.prod(shape)) * np.dtype(dt).itemsize for k, (shape, dt, _) in layout.items()}
    end = max((off + sizes[k] for k, (_, _, off) in layout.items()), default=HEADER)
    owner = (ctypes.c_char * end).from_buffer(buf)  # views of it keep it alive
    weakref.finalize(owner, release, *args)
    base = np.frombuffer(owner, np.uint8)  # type: ignore[call-overload]  # numpy's stubs omit ctypes arrays
    return {key: base[off : off + sizes[key]].view(dt).reshape(shape)
            for key, (shape, dt, off) in layout.items()}


class BlockPool:
    """The caller's side: lends free blocks to workers and turns (block, layout) into arrays.
    Batches may be dropped in any thread (TensorFlow's, say), so the state is under a lock."""

    def __init__(self) -> None:
        self.blocks: dict[str, SharedMemory] = {}
        self.free: list[str] = []
        self.closed = False
        self._lock = threading.RLock()  # re-entrant: a release can run inside any of these

    def lend(self) -> str | None:
        """A free block for the next batch, or None (the worker makes one)."""
        with self._lock:
            return self.free.pop() if self.free else None

    def _mapped(self, name: str, lent: str | None) -> SharedMemory:
        """Our mapping of block `name`; a lent block the worker did not use (too small) is dropped."""
        with self._lock:
            if lent is not None and lent != name:
                block = self.blocks.pop(lent)
                block.unlink()
                with contextlib.suppress(BufferError):
                    block.close()
            if name not in self.blocks:
                self.blocks[name] = _Block(name=name)
            return self.blocks[name]

    def take(self, name: str, layout: BlockLayout, lent: str | None) -> dict[str, np.ndarray]:
        """The batch in block `name` as arrays viewing it; the block is free again once they are
        all gone."""
        return _views(_buffer(self._mapped(name, lent)), layout, self._release, name)

    def give_back(self, name: str, lent: str | None) -> None:
        """A batch made but never taken (the caller stopped early)."""
        self._mapped(name, lent)
        self._release(name)

    def _release(self, name: str) -> None:
        """Called as the last array of a batch goes: the block is free, or, after close, left
        for the garbage collector (it is still exported while this runs)."""
        with self._lock:
            if not self.closed:
                self.free.append(name)
            else:
                self.blocks.pop(name, None)

    def close(self) -> None:
        """Remove every block's name; blocks still viewed by batches stay mapped until those
        batches are gone."""
        with self._lock:
            self.closed = True
            for block in list(self.blocks.values()):
                block.unlink()
            for name in self.free:
                with contextlib.suppress(BufferError):
                    self.blocks.pop(name).close()
            self.free.clear()


# --- PyTorch DataLoader workers: blocks owned by the worker, flags in the block ----------------
#
# A DataLoader worker cannot be lent blocks (nothing goes from the main process to an iterable
# dataset's worker), so it owns its blocks. It sends a batch as a SharedBatch, which pickles to
# the block's name and layout; unpickled in the main process, it becomes arrays viewing that
# block there (mapped once, kept mapped). The block's BUSY byte is set by the worker when it
# sends and cleared in the main process when the batch's arrays are all gone; the worker writes
# a batch only into a block that is not busy, else makes a new one. The worker removes the names
# of its blocks when it exits (its resource tracker does, if it is killed) and marks them RETIRED;
# the main process unmaps a retired block once it is not busy. The main process maps blocks
# without registering them with a resource tracker: the worker's tracker owns the names (with
# forked workers it is another tracker, which would otherwise remove the names twice).


def _header(buf: memoryview) -> np.ndarray:
    return np.ndarray((HEADER,), np.uint8, buffer=buf)


class SharedBatch:
    """A batch in a worker's block, on its way to the main process: `rebuild(name, layout)` runs
    there when it is unpickled (received_arrays, or a function that wraps it)."""

    def __init__(self, name: str, layout: BlockLayout, rebuild) -> None:
        self.name, self.layout, self.rebuild = name, layout, rebuild

    def __reduce__(self):
        return self.rebuild, (self.name, self.layout)


def _exit_on_sigterm(signum: int, frame: object) -> None:
    raise SystemExit  # status 0: PyTorch's main process takes any other as the worker failing


class WorkerBlocks:
    """A DataLoader worker's blocks: `arena()` for the next batch, `send(arena, batch)` to hand it
    over. One per worker process (`worker_blocks`), so persistent workers reuse them every epoch."""

    def __init__(self) -> None:
        self.blocks: list[SharedMemory] = []
        # after the worker's result queue has flushed (its finaliser runs at priority -5)
        multiprocessing.util.Finalize(self, self.close, exitpriority=-10)
        # The main process's exit terminates persistent workers (daemons) with SIGTERM, which left
        # their blocks to their resource tracker, with a warning about leaked shared memory: as an
        # exit instead, the finaliser above runs and removes them.
        signal.signal(signal.SIGTERM, _exit_on_sigterm)

    def arena(self) -> Arena:
        free = next((b for b in self.blocks if not _header(_buffer(b))[BUSY]), None)
        return Arena(free.name if free else None)

    def send(self, arena: Arena, batch: dict[str, np.ndarray], rebuild) -> SharedBatch:
        name, layout = arena.finish(batch)
        block = _ATTACHED[name]
        if block not in self.blocks:
            self.blocks.append(block)
        _header(_buffer(block))[BUSY] = 1
        return SharedBatch(name, layout, rebuild)

    def close(self) -> None:
        """Retire every block and remove its name (the main process keeps its mapping)."""
        for block in self.blocks:
            _header(_buffer(block))[RETIRED] = 1
            with contextlib.suppress(FileNotFoundError):
                block.unlink()
            _ATTACHED.pop(block.name, None)
            with contextlib.suppress(BufferError):
                block.close()
        self.blocks.clear()


class _Mapping:
    """A worker's block mapped in the main process, untracked."""

    def __init__(self, name: str) -> None:
        fd = _posixshmem.shm_open("/" + name, os.O_RDWR, mode=0o600)
        try:
            self._mmap = mmap.mmap(fd, os.fstat(fd).st_size)
        finally:
            os.close(fd)
        self.buf = memoryview(self._mmap)

    def close(self) -> None:
        """Unmap, unless arrays still view it (then it goes with them)."""
        with contextlib.suppress(BufferError):
            self.buf.release()
            self._mmap.close()


_WORKER_BLOCKS: list[WorkerBlocks] = []  # this DataLoader worker's, made on first use


def worker_blocks() -> WorkerBlocks:
    """This DataLoader worker process's blocks."""
    if not _WORKER_BLOCKS:
        _WORKER_BLOCKS.append(WorkerBlocks())
    return _WORKER_BLOCKS[0]


_RECEIVED: dict[str, _Mapping] = {}  # main process: workers' blocks mapped here, by name
_received_lock = threading.Lock()


def received_arrays(name: str, layout: BlockLayout) -> dict[str, np.ndarray]:
    """In the main process: the batch a worker sent in block `name`, as arrays viewing it."""
    with _received_lock:
        block = _RECEIVED.get(name)
        if block is None:
            for old, b in list(_RECEIVED.items()):
                if _header(b.buf)[RETIRED] and not _header(b.buf)[BUSY]:
                    _RECEIVED.pop(old).close()
            block = _RECEIVED[name] = _Mapping(name)
    return _views(block.buf, layout, _release_received, name)


def _release_received(name: str) -> None:
    with _received_lock:
        block = _RECEIVED.get(name)
        if block is not None:
            _header(block.buf)[BUSY] = 0
            if _header(block.buf)[RETIRED]:
                _RECEIVED.pop(name).close()
