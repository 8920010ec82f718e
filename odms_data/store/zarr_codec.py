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
from zarr.registry import register_codec

from ..errors import StoreError
from .chunk_codecs import zstd_decode

_decoding = ContextVar("decoding", default=False)  # a shard index is read for a read, not a write


@dataclass(frozen=True)
class BoundedZstdCodec(ZstdCodec):
    """zarr's zstd codec, decoding each chunk to no more than its chunk spec's size."""

    def _decode_sync(self, chunk_bytes: Any, chunk_spec: Any) -> Any:
        expected = int(np.prod(chunk_spec.shape)) * chunk_spec.dtype.to_native_dtype().itemsize

        def decode(buf: np.ndarray) -> bytes:
            return zstd_decode(buf.data.cast("B"), expected)

        return as_numpy_array_wrapper(decode, chunk_bytes, chunk_spec.prototype)


class WholeShardCodec(ShardingCodec):
    """zarr's sharding codec, refusing a shard whose index lacks a chunk when it is read. A write
    that fills a shard in parts reads indexes that lack chunks still to come: those pass."""

    async def _decode_single(self, *args: Any) -> Any:
        token = _decoding.set(True)
        try:
            return await super()._decode_single(*args)
        finally:
            _decoding.reset(token)

    async def _decode_partial_single(self, *args: Any) -> Any:
        token = _decoding.set(True)
        try:
            return await super()._decode_partial_single(*args)
        finally:
            _decoding.reset(token)

    async def _decode_shard_index(self, *args: Any) -> Any:
        index = await super()._decode_shard_index(*args)
        present = index.get_full_chunk_map()
        if _decoding.get() and not present.all():
            k = int(np.flatnonzero(~present.ravel())[0])
            raise StoreError(f"chunk {k} of a shard is missing (a damaged store)")
        return index


@cache
def use_bounded_zstd() -> None:
    register_codec("zstd", BoundedZstdCodec)
    register_codec("sharding_indexed", WholeShardCodec)
    zarr.config.set({"codecs.zstd": f"{__name__}.BoundedZstdCodec",
                     "codecs.sharding_indexed": f"{__name__}.WholeShardCodec"})
