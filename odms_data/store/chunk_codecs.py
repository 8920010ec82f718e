"""Decompressing a store's chunks, each bounded by the size its array says it decodes to.

A chunk is a stranger's bytes: a 100 KB zstd or deflate stream can expand to gigabytes. Every
decompression of store data goes through `zstd_decode` or `inflate` here: a chunk that declares,
or would produce, more or fewer bytes than expected raises ValueError before the excess is
allocated. zarr's own reads go through zarr_codec.py's codec; the direct readers
(shard_reader.py, hdf5_reader.py) call the functions.
"""

from __future__ import annotations

import threading
import zlib

_local = threading.local()  # zstandard's decompressor is not thread safe; zarr decodes in threads


def zstd_decode(data: bytes | memoryview, expected: int) -> bytes:
    """The one zstd frame `data`, which must decode to exactly `expected` bytes."""
    import zstandard

    declared = zstandard.frame_content_size(data)
    if declared not in (-1, expected):  # -1: not recorded; then max_output_size bounds it
        raise ValueError(f"a chunk declares {declared} bytes, expected {expected}")
    d = getattr(_local, "zstd", None)
    if d is None:
        d = _local.zstd = zstandard.ZstdDecompressor()
    try:
        out = d.decompress(data, max_output_size=max(expected, 1), allow_extra_data=False)
    except zstandard.ZstdError as e:
        raise ValueError(f"a chunk does not decode to {expected} bytes ({e})") from None
    if len(out) != expected:
        raise ValueError(f"a chunk holds {len(out)} bytes, expected {expected}")
    return out


def inflate(data: bytes, expected: int) -> bytes:
    """The one zlib (deflate) stream `data` (HDF5's gzip filter), exactly `expected` bytes."""
    d = zlib.decompressobj()
    try:
        out = d.decompress(data, expected)
    except zlib.error as e:
        raise ValueError(f"a chunk does not inflate ({e})") from None
    if len(out) != expected or not d.eof or d.unconsumed_tail:
        raise ValueError(f"a chunk does not inflate to exactly {expected} bytes")
    return out
