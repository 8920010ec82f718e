"""zarr's codecs as odms-data reads its own stores: a zstd chunk's decompression bounded by its
chunk's size (common.py), and a shard that lacks one of its chunks refused as damage (a store
is always written whole; zarr would read the chunk as zeros).

`scoped(array)` is an array of an odms-data store opened for reading, with its codecs replaced by
these; ZarrBackend applies it to every array it reads. Nothing is registered with zarr: every other
array in the process reads with zarr's own codecs.

`StoreFolder` is the local store ZarrBackend opens a store's folder through: it lists the
folder without the marker of a partial one (outputs.MARKER), which zarr would take for a foreign
object and warn of when the store builder checks a store before its commit, and it reads only
regular files: a FIFO in place of a chunk would block zarr's read forever, and a device never end.
"""

from __future__ import annotations

import itertools
import os
import stat
from collections.abc import AsyncIterator, Iterable
from contextvars import ContextVar
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import zarr
from zarr.abc.store import ByteRequest
from zarr.codecs import ShardingCodec, ZstdCodec
from zarr.core.buffer import Buffer, BufferPrototype
from zarr.storage import LocalStore

from ...errors import StoreError
from ...outputs import MARKER
from .common import zstd_decode

_wanted: ContextVar[frozenset | set] = ContextVar("wanted", default=frozenset())  # chunks a read needs


@dataclass(frozen=True)
class BoundedZstdCodec(ZstdCodec):
    """zarr's zstd codec, decoding each chunk to no more than its chunk spec's size."""

    def _decode_sync(self, chunk_bytes: Any, chunk_spec: Any) -> Any:
        expected = int(np.prod(chunk_spec.shape)) * chunk_spec.dtype.to_native_dtype().itemsize
        data = zstd_decode(chunk_bytes.as_numpy_array().data.cast("B"), expected)
        return chunk_spec.prototype.buffer.from_bytes(data)


class WholeShardCodec(ShardingCodec):
    """zarr's sharding codec, refusing a read of a chunk that its shard's index lacks. Only the
    chunks read are required: the last shard has none past the array's end."""

    async def _decode_partial_single(self, byte_getter: Any, selection: Any, shard_spec: Any) -> Any:
        token = _wanted.set(_chunks_read(selection, shard_spec.shape, self.chunk_shape))
        try:
            return await super()._decode_partial_single(byte_getter, selection, shard_spec)
        finally:
            _wanted.reset(token)

    async def _decode_shard_index(self, *args: Any) -> Any:
        index = await super()._decode_shard_index(*args)
        for coords in sorted(_wanted.get()):
            if index.get_chunk_slice(coords) is None:
                k = int(np.ravel_multi_index(coords, index.offsets_and_lengths.shape[:-1]))
                raise StoreError(f"chunk {k} of a shard is missing (a damaged store)")
        return index


def _chunks_read(selection: tuple, shard_shape: tuple[int, ...], chunk_shape: tuple[int, ...]) -> set:
    """The coordinates of the inner chunks that `selection` (an int, slice or index array per axis)
    of a shard touches; for a selection of points, the chunks of every combination of its axes."""
    axes = [np.unique(np.arange(n)[s] // c).tolist() for s, n, c in zip(selection, shard_shape, chunk_shape,
                                                                         strict=True)]
    return set(itertools.product(*axes))


def _bounded(codec: Any) -> Any:
    """`codec` with zstd decoding bounded and missing shard chunks refused, at every depth."""
    name = codec.to_dict()["name"]
    if name == "zstd":
        return BoundedZstdCodec(level=codec.level, checksum=codec.checksum)
    if name == "sharding_indexed":
        return WholeShardCodec(chunk_shape=codec.chunk_shape, codecs=[_bounded(c) for c in codec.codecs],
                               index_codecs=[_bounded(c) for c in codec.index_codecs],
                               index_location=codec.index_location)
    return codec


def scoped(array: zarr.Array | zarr.Group) -> zarr.Array:
    """`array` (of an odms-data store, opened for reading) reading through the codecs above."""
    if not isinstance(array, zarr.Array):
        raise TypeError("a group, not an array")
    meta: Any = array.metadata  # Zarr v3's: ZarrBackend opens v3 stores only
    codecs = tuple(_bounded(c) for c in meta.codecs)
    inner = array.async_array
    return zarr.Array(zarr.AsyncArray(replace(meta, codecs=codecs), inner.store_path, inner.config))


class StoreFolder(LocalStore):
    """zarr's local store, its top folder listed without a partial folder's marker, reading only
    regular files (a missing one is zarr's to handle)."""

    def _regular(self, key: str) -> None:
        path = self.root / key
        try:
            mode = os.stat(path).st_mode  # one call: this runs before every read of zarr's
        except OSError:
            return  # missing or unreachable: zarr's own read says so
        if not stat.S_ISREG(mode):
            raise StoreError(f"{path}: not a regular file (a FIFO, device or folder), so not read")

    async def get(self, key: str, prototype: BufferPrototype | None = None,
                  byte_range: ByteRequest | None = None) -> Buffer | None:
        self._regular(key)
        return await super().get(key, prototype, byte_range)

    async def get_partial_values(self, prototype: BufferPrototype,
                                 key_ranges: Iterable[tuple[str, ByteRequest | None]]) -> list[Buffer | None]:
        key_ranges = list(key_ranges)
        for key, _ in key_ranges:
            self._regular(key)
        return await super().get_partial_values(prototype, key_ranges)

    async def list_dir(self, prefix: str) -> AsyncIterator[str]:
        async for key in super().list_dir(prefix):
            if prefix.strip("/") or key != MARKER:
                yield key
