"""Writing a whole shard of `masks` at once: chunks compressed as they are made, one write.

zarr spends about twice the compression's own time on a full shard write (a fresh fill-value
array and a copy per inner chunk, and an asyncio task per chunk). A shard task knows its chunks
one by one, so it compresses each as soon as it is made and writes the shard's bytes at once:
one file write for a local store (zarr.py's ShardLayout; zarr is not even imported), one store
call for a URL. zarr reads them as it reads its own (tests/store check it). HDF5 chunks are deflated
the same way and handed back to the single writer. Workers reach the store through a `MaskSink`,
which StoreWriter.mask_sink gives and StoreWriter.receive_masks completes.
"""

from __future__ import annotations

import os
import threading
import zlib
from dataclasses import dataclass

import numpy as np

from ...urls import storage_options
from .choose import BACKENDS
from .common import GZIP_LEVEL, ZSTD_LEVEL
from .zarr import ShardLayout, encode_index, on_zarr_loop


class ShardChunks:
    """The compressed mask chunks of one shard, added in order (`fmt`: 'zarr' or 'hdf5')."""

    def __init__(self, fmt: str, frames_per_chunk: int) -> None:
        self.fmt, self.frames_per_chunk = fmt, frames_per_chunk
        self.chunks: list[bytes] = []
        if fmt == "zarr":  # one zstd context for all chunks: a fresh one per chunk (numcodecs, so
            import zstandard  # zarr) allocates a megabyte each time, page faults included

            self._zstd = zstandard.ZstdCompressor(level=ZSTD_LEVEL, write_checksum=True)

    def add(self, frames: np.ndarray) -> None:
        """Compress the next chunk: (k, H, ceil(W/8)) packed frames, zero-padded to full length."""
        if len(frames) < self.frames_per_chunk:
            padded = np.zeros((self.frames_per_chunk, *frames.shape[1:]), np.uint8)
            padded[: len(frames)] = frames
            frames = padded
        data = np.ascontiguousarray(frames, np.uint8)
        if self.fmt == "zarr":
            self.chunks.append(self._zstd.compress(data.data))
        else:
            self.chunks.append(zlib.compress(data.data, GZIP_LEVEL))

    def write(self, path: str, start: int) -> list[bytes]:
        """Zarr: store the shard that begins at frame `start` (a shard boundary) in one write,
        replacing whatever an interrupted earlier attempt left; returns []. HDF5: returns the
        deflated chunks, for the single writer's `receive_masks`."""
        if not BACKENDS[self.fmt].workers_write_shards:
            return self.chunks
        layout = ShardLayout.of(path)
        if layout is not None:  # a local store: no zarr (its import is a third of a worker's start-up)
            target = layout.shard_path(start // layout.shard)
            target.parent.mkdir(parents=True, exist_ok=True)
            partial = target.with_name(f"{target.name}.{os.getpid()}.{threading.get_ident()}.partial")
            partial.write_bytes(shard_bytes(self.chunks, layout.per_shard))
            partial.replace(target)  # whole or not at all, as zarr's own local writes
            return []
        import zarr
        from zarr.buffer import default_buffer_prototype

        masks = zarr.open_array(store=path, path="masks", mode="r+", storage_options=storage_options(path))
        per_shard = masks.shards[0] // masks.chunks[0]  # type: ignore[index]  # masks is sharded
        key = masks.metadata.encode_chunk_key((start // masks.shards[0], 0, 0))  # type: ignore[index]
        data = default_buffer_prototype().buffer.from_bytes(shard_bytes(self.chunks, per_shard))
        on_zarr_loop(masks.store.set(f"{masks.path}/{key}", data))
        return []


@dataclass(frozen=True)
class MaskSink:
    """Where the workers put the masks of a store being written; picklable, so tasks carry it to
    other processes. What `write` returns goes to the parent's StoreWriter.receive_masks."""

    path: str
    fmt: str
    frames_per_chunk: int

    def chunks(self) -> ShardChunks:
        """An empty shard, to `add` chunks to as they are made."""
        return ShardChunks(self.fmt, self.frames_per_chunk)

    def write(self, start: int, chunks: ShardChunks) -> list[bytes]:
        """Store the shard beginning at frame `start` (a shard boundary) where the workers write
        shards, replacing what an interrupted earlier attempt may have left; returns what is left
        for the parent (the compressed chunks where they do not, else nothing)."""
        return chunks.write(self.path, start)

    def write_packed(self, start: int, packed: np.ndarray) -> list[bytes]:
        """`write` a worker's whole shard of packed masks."""
        chunks = self.chunks()
        for c in range(0, len(packed), self.frames_per_chunk):
            chunks.add(packed[c : c + self.frames_per_chunk])
        return self.write(start, chunks)


def shard_bytes(chunks: list[bytes], per_shard: int) -> bytes:
    """A shard holding `chunks` as its first inner chunks (the rest absent), then its index."""
    return b"".join([*chunks, encode_index([len(c) for c in chunks], per_shard)])
