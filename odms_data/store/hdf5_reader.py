"""Reading an HDF5 store's datasets chunk by chunk, each chunk inflated with a bound.

libhdf5's gzip filter grows its buffer until a chunk's stream ends: a chunk of a few kilobytes can
inflate to gigabytes before libhdf5 sees it is too long. `BoundedDataset` reads the raw chunks
(h5py's read_direct_chunk) and inflates each to exactly its size (chunk_codecs.inflate). The
layout is checked first (declared.py): chunked, gzip or no filter, every chunk stored.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .chunk_codecs import inflate

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
