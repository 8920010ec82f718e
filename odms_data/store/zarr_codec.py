"""zarr's zstd codec with every chunk's decompression bounded by its chunk's size (chunk_codecs.py).

`use_bounded_zstd()` makes it the codec zarr uses for "zstd" in this process; ZarrBackend calls
it before opening a store, so every read through zarr is bounded.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np
import zarr
from zarr.codecs import ZstdCodec
from zarr.core.buffer.cpu import as_numpy_array_wrapper
from zarr.registry import register_codec

from .chunk_codecs import zstd_decode


@dataclass(frozen=True)
class BoundedZstdCodec(ZstdCodec):
    """zarr's zstd codec, decoding each chunk to no more than its chunk spec's size."""

    def _decode_sync(self, chunk_bytes: Any, chunk_spec: Any) -> Any:
        expected = int(np.prod(chunk_spec.shape)) * chunk_spec.dtype.to_native_dtype().itemsize

        def decode(buf: np.ndarray) -> bytes:
            return zstd_decode(buf.data.cast("B"), expected)

        return as_numpy_array_wrapper(decode, chunk_bytes, chunk_spec.prototype)


@cache
def use_bounded_zstd() -> None:
    register_codec("zstd", BoundedZstdCodec)
    zarr.config.set({"codecs.zstd": f"{__name__}.BoundedZstdCodec"})
