"""zarr's codecs as odms-data reads them: a zstd chunk's decompression bounded by its chunk's size
(chunk_codecs.py), and a shard that lacks one of its chunks refused as damage (a store is always
written whole; zarr would read the chunk as zeros).

`use_bounded_zstd()` makes them the codecs zarr uses for "zstd" and "sharding_indexed" in this
process; ZarrBackend calls it before opening a store, so every read through zarr is checked.
"""

from __future__ import annotations

from contextvars import ContextVar
from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np
import zarr
from zarr.codecs import ShardingCodec, ZstdCodec
from zarr.core.buffer.cpu import as_numpy_array_wrapper
from zarr.core.chunk_grids import RegularChunkGrid
from zarr.core.indexing import get_indexer
from zarr.registry import register_codec

from ..errors import StoreError
from .chunk_codecs import zstd_decode

_wanted: ContextVar[frozenset | set] = ContextVar("wanted", default=frozenset())  # chunks a read needs


@dataclass(frozen=True)
class BoundedZstdCodec(ZstdCodec):
    """zarr's zstd codec, decoding each chunk to no more than its chunk spec's size."""

    def _decode_sync(self, chunk_bytes: Any, chunk_spec: Any) -> Any:
        expected = int(np.prod(chunk_spec.shape)) * chunk_spec.dtype.to_native_dtype().itemsize

        def decode(buf: np.ndarray) -> bytes:
            return zstd_decode(buf.data.cast("B"), expected)

        return as_numpy_array_wrapper(decode, chunk_bytes, chunk_spec.prototype)


class WholeShardCodec(ShardingCodec):
    """zarr's sharding codec, refusing a read of a chunk that its shard's index lacks. Only the
    chunks read are required: the last shard has none past the array's end, and a write that fills
    a shard in parts reads an index that lacks the chunks still to come."""

    async def _decode_partial_single(self, byte_getter: Any, selection: Any, shard_spec: Any) -> Any:
        grid = RegularChunkGrid(chunk_shape=self.chunk_shape)
        token = _wanted.set({coords for coords, *_ in get_indexer(selection, shape=shard_spec.shape,
                                                                   chunk_grid=grid)})
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


@cache
def use_bounded_zstd() -> None:
    register_codec("zstd", BoundedZstdCodec)
    register_codec("sharding_indexed", WholeShardCodec)
    zarr.config.set({"codecs.zstd": f"{__name__}.BoundedZstdCodec",
                     "codecs.sharding_indexed": f"{__name__}.WholeShardCodec"})
