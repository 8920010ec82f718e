"""What both backends share: the `Backend` interface and its arrays, the
compression levels, and the bounded decompression of a store's chunks.

Both hold the same arrays (format.ARRAYS) and the root attribute `odms`: a JSON object
in Zarr, a JSON string in HDF5 (HDF5 attributes cannot nest).

Decompressing a store's chunks, each bounded by the size its array says it decodes to:
a chunk is a stranger's bytes: a 100 KB zstd or deflate stream can expand to gigabytes. Every
decompression of store data goes through `zstd_decode` or `inflate` here: a chunk that declares,
or would produce, more or fewer bytes than expected raises ValueError before the excess is
allocated. zarr's own reads go through zarr_codecs.py's codec; the direct readers
(zarr.py's ShardReader, hdf5.py's BoundedDataset) call the functions.
"""

from __future__ import annotations

import threading
import zlib
from abc import ABC, abstractmethod
from collections.abc import Iterable
from typing import Any, ClassVar, Literal, Protocol

from ...errors import StoreError

Mode = Literal["r", "r+", "w"]  # read, update, create
HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"
ZSTD_LEVEL = 3
GZIP_LEVEL = 1


class StoreArray(Protocol):
    """An array of an open store: zarr's and h5py's both slice like numpy."""

    @property
    def shape(self) -> tuple[int, ...]: ...

    @property
    def dtype(self) -> Any: ...

    @property
    def chunks(self) -> Any: ...

    def __getitem__(self, key: Any) -> Any: ...

    def __setitem__(self, key: Any, value: Any) -> None: ...


class Backend(ABC):
    """An open store: named arrays that slice like numpy, plus the `odms` attribute."""

    format: ClassVar[str]  # "zarr" or "hdf5"
    # True: workers write whole shards of masks into the store themselves; False: they return the
    # compressed chunks and the one writer stores them (`write_raw_chunk`)
    workers_write_shards: ClassVar[bool]
    path: str

    @abstractmethod
    def __init__(self, path: str, mode: Mode) -> None: ...

    def names(self) -> set[str]:
        """The names of the store's arrays."""
        try:
            return set(self._array_names())
        except Exception as e:  # a damaged store surfaces as many exception types
            raise StoreError(f"{self.path}: cannot list arrays ({type(e).__name__}: {e})") from e

    @abstractmethod
    def _array_names(self) -> Iterable[str]: ...

    @abstractmethod
    def array(self, name: str) -> StoreArray: ...

    @abstractmethod
    def read_attrs(self) -> dict[str, Any] | None: ...

    @abstractmethod
    def write_attrs(self, attrs: dict[str, Any]) -> None: ...

    @abstractmethod
    def create_array(
        self, name: str, shape: tuple[int, ...], dtype: Any, chunks: tuple[int, ...],
        shards: tuple[int, ...] | None = None,
    ) -> StoreArray: ...

    def write_raw_chunk(self, array: StoreArray, start: int, data: bytes) -> None:
        """Store one already compressed chunk of `array` beginning at row `start` (backends whose
        workers do not write shards)."""
        raise NotImplementedError(f"{self.format} workers write their shards themselves")

    @abstractmethod
    def check(self) -> None:
        """Raise the error of a write that failed since the store was opened (see _FailSafeFile)."""

    @abstractmethod
    def close(self) -> None: ...


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
