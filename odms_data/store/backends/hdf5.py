"""The HDF5 backend: one file, gzip chunks, written through a file that keeps a failed write
from libhdf5, and read chunk by chunk, each chunk inflated with a bound.

libhdf5's gzip filter grows its buffer until a chunk's stream ends: a chunk of a few kilobytes can
inflate to gigabytes before libhdf5 sees it is too long. `BoundedDataset` reads the raw chunks
(h5py's read_direct_chunk) and inflates each to exactly its size (common.inflate). The
layout is checked first (declared.py): chunked, gzip or no filter, every chunk stored.
"""

from __future__ import annotations

import io
import json
import math
from collections.abc import Iterable
from typing import Any

import numpy as np

from ... import safe_json
from ...errors import StoreError
from .common import GZIP_LEVEL, Backend, Mode, StoreArray, inflate


class _FailSafeFile(io.FileIO):
    """The file under an HDF5 store being written (h5py's fileobj driver). A write that fails is
    not reported to libhdf5: the error is kept in `failed` and that write and every later one are
    dropped, and the writer raises the error after the call that met it (`Hdf5Backend.check`).

    libhdf5 cannot recover from a failed write: a file whose flush or close failed leaves a file
    id that is freed twice when it is closed again or at exit, a segmentation fault (h5py issues
    914 and 2160). Seeing only successful writes, it closes cleanly; the store is then removed.
    """

    failed: OSError | None = None

    def write(self, b) -> int:
        if self.failed is None:
            try:
                return super().write(b) or 0
            except OSError as e:
                self.failed = e
        return len(memoryview(b))

    def truncate(self, size: int | None = None) -> int:
        if self.failed is None:
            try:
                return super().truncate(size)
            except OSError as e:
                self.failed = e
        return self.tell() if size is None else size


class Hdf5Backend(Backend):
    format = "hdf5"
    workers_write_shards = False

    def __init__(self, path: str, mode: Mode) -> None:
        import h5py

        self.path, self.mode = path, mode
        self._raw: _FailSafeFile | None = None
        if mode == "w":
            self._raw = _FailSafeFile(path, "w+b")
            try:
                self.file = h5py.File(self._raw, "w")
            except BaseException:
                self._raw.close()
                raise
            return
        try:
            self.file = h5py.File(path, mode)
        except OSError as e:
            raise StoreError(f"{path}: not a readable HDF5 file ({e})") from e

    def _array_names(self) -> Iterable[str]:
        return self.file.keys()

    def array(self, name: str) -> Any:
        import h5py

        try:
            link = self.file.get(name, getlink=True)
            arr = self.file[name] if isinstance(link, h5py.HardLink) else None
        except Exception as e:
            raise StoreError(f"{self.path}: array '{name}' is unreadable ({type(e).__name__}: {e})") from e
        if arr is None:  # resolving a soft or external link would read another object or file
            raise StoreError(f"{self.path}: '{name}' is a {type(link).__name__}, not an array of the file")
        if not isinstance(arr, h5py.Dataset):  # a damaged header can turn it into a group or type
            raise StoreError(f"{self.path}: '{name}' is a {type(arr).__name__}, not an array")
        if self.mode != "r":
            return arr
        try:
            return BoundedDataset(arr)  # reads its creation properties: a damaged header fails here
        except Exception as e:
            raise StoreError(f"{self.path}: array '{name}' is unreadable ({type(e).__name__}: {e})") from e

    def read_attrs(self) -> dict[str, Any] | None:
        try:
            raw = self.file.attrs.get("odms")
        except Exception as e:  # a damaged object header surfaces as KeyError, OSError, ...
            raise StoreError(f"{self.path}: attributes are unreadable ({type(e).__name__}: {e})") from e
        if raw is None:
            return None
        if not isinstance(raw, str | bytes):
            raise StoreError(f"{self.path}: attribute 'odms' is not a JSON string")
        attrs = safe_json.loads(raw, f"{self.path}: attribute 'odms'", StoreError)
        if not isinstance(attrs, dict):
            raise StoreError(f"{self.path}: attribute 'odms' is not a JSON object")
        return attrs

    def write_attrs(self, attrs: dict[str, Any]) -> None:
        self.file.attrs["odms"] = json.dumps(attrs)

    def create_array(self, name, shape, dtype, chunks, shards=None):
        chunks = tuple(max(1, min(c, s)) for c, s in zip(chunks, shape, strict=True))
        return self.file.create_dataset(
            name, shape=shape, dtype=dtype, chunks=chunks, compression="gzip",
            compression_opts=GZIP_LEVEL, fillvalue=0,
        )

    def write_raw_chunk(self, array: StoreArray, start: int, data: bytes) -> None:
        array.id.write_direct_chunk((start, *(0,) * (len(array.shape) - 1)), data)  # type: ignore[attr-defined]

    def check(self) -> None:
        if self._raw is not None and self._raw.failed is not None:
            raise self._raw.failed

    def close(self) -> None:
        try:
            self.file.close()
        finally:
            if self._raw is not None:
                self._raw.close()
        self.check()


DEFLATE = 1  # HDF5's filter id of gzip


class BoundedDataset:
    """An h5py dataset read as `[...]` or `[start:stop]` along its first axis."""

    def __init__(self, dset: Any) -> None:
        self.dset, self.shape, self.dtype, self.chunks = dset, dset.shape, dset.dtype, dset.chunks
        plist = dset.id.get_create_plist()
        self.filters = [plist.get_filter(i)[0] for i in range(plist.get_nfilters())]

    def __getitem__(self, key: Any) -> np.ndarray:
        if key is Ellipsis:
            key = slice(None)
        if not isinstance(key, slice) or key.step not in (None, 1):
            raise TypeError(f"BoundedDataset reads [...] or [start:stop], not [{key!r}]")
        start, stop, _ = key.indices(self.shape[0])
        out = np.empty((max(stop - start, 0), *self.shape[1:]), self.dtype)
        if len(out) == 0:
            return out
        if self.chunks is None or self.filters not in ([], [DEFLATE]):
            raise ValueError("the dataset is not stored as odms-data writes it (chunked, gzip)")
        c0 = self.chunks[0]
        rest = [range(0, s, c) for s, c in zip(self.shape[1:], self.chunks[1:], strict=True)]
        for row in range(start - start % c0, stop, c0):
            for corner in np.ndindex(*(len(r) for r in rest)):
                offset = (row, *(r[i] for r, i in zip(rest, corner, strict=True)))
                self._place(out, start, stop, offset)
        return out

    def _chunk(self, offset: tuple[int, ...]) -> np.ndarray:
        skipped, raw = self.dset.id.read_direct_chunk(offset)
        nbytes = math.prod(self.chunks) * self.dtype.itemsize
        if self.filters == [DEFLATE] and not skipped & 1:
            raw = inflate(raw, nbytes)
        elif len(raw) != nbytes:
            raise ValueError(f"a chunk holds {len(raw)} bytes, expected {nbytes}")
        return np.frombuffer(raw, self.dtype).reshape(self.chunks)

    def _place(self, out: np.ndarray, start: int, stop: int, offset: tuple[int, ...]) -> None:
        """Copy the part of the chunk at `offset` that lies in rows [start, stop) into `out`."""
        chunk = self._chunk(offset)
        src, dst = [], []
        for axis, (o, c, s) in enumerate(zip(offset, self.chunks, self.shape, strict=True)):
            lo, hi = (max(o, start), min(o + c, stop)) if axis == 0 else (o, min(o + c, s))
            src.append(slice(lo - o, hi - o))
            dst.append(slice(lo - start, hi - start) if axis == 0 else slice(lo, hi))
        out[tuple(dst)] = chunk[tuple(src)]
