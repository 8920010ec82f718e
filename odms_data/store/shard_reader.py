"""Reading mask chunks straight from a local sharded Zarr store, without zarr's async machinery.

zarr's fixed cost per read call, whatever its size, is most of the cost of reading one example;
reading the shard index and the chunk bytes directly avoids it. Only
the layout StoreWriter makes is read this way (shard_layout.py); `ShardReader.open` returns None
for anything else, which `Store` then reads through zarr.
"""

from __future__ import annotations

import numpy as np

from ..errors import StoreError
from .chunk_codecs import zstd_decode
from .shard_layout import MISSING, ShardLayout, decode_index, index_bytes


class ShardReader:
    def __init__(self, layout: ShardLayout) -> None:

        self.layout, self.shape, self.chunk = layout, layout.shape, layout.chunk
        self.per_shard = layout.per_shard
        self.frame_bytes = int(np.prod(self.shape[1:]))

    @classmethod
    def open(cls, store_path: str) -> ShardReader | None:
        layout = ShardLayout.of(store_path)
        return cls(layout) if layout else None

    def _chunks(self, s: int, ks: range) -> list[np.ndarray]:
        """Packed frames of chunks ks of shard s (full chunk length). A store is written whole:
        a missing shard or chunk is damage, and no chunk decodes to more than its own size."""
        path = self.layout.shard_path(s)
        out_bytes = self.chunk * self.frame_bytes
        try:
            with open(path, "rb") as f:
                n = index_bytes(self.per_shard)
                data_end = f.seek(-n, 2)
                index = decode_index(f.read(n), path)[ks.start : ks.stop]
                if (index[:, 0] == MISSING).any():
                    k = ks.start + int(np.argmax(index[:, 0] == MISSING))
                    raise StoreError(f"{path}: chunk {k} of the shard is missing (a damaged store)")
                if ((index[:, 0] > data_end) | (index[:, 1] > data_end - index[:, 0])).any():
                    raise StoreError(f"{path}: the shard index points past the shard's chunks")
                lo = int(index[:, 0].min())
                hi = int((index[:, 0] + index[:, 1]).max())
                f.seek(lo)
                span = f.read(hi - lo)  # the chunks of a range lie together: one read
            view = memoryview(span)
            return [np.frombuffer(zstd_decode(view[int(o) - lo : int(o + n) - lo], out_bytes), np.uint8)
                    for o, n in index]
        except FileNotFoundError:
            raise StoreError(f"{path}: shard {s} of the masks is missing (a damaged store)") from None
        except (OSError, ValueError) as e:
            raise StoreError(f"{path}: unreadable ({e})") from e

    def read(self, start: int, stop: int) -> np.ndarray:
        """Packed masks of frames [start, stop)."""
        stop = min(stop, self.shape[0])
        if stop <= start:
            return np.zeros((0, *self.shape[1:]), np.uint8)
        first, last = start // self.chunk, (stop - 1) // self.chunk
        parts = []
        for s in range(first // self.per_shard, last // self.per_shard + 1):
            k0 = max(first, s * self.per_shard) - s * self.per_shard
            k1 = min(last + 1, (s + 1) * self.per_shard) - s * self.per_shard
            parts += self._chunks(s, range(k0, k1))
        block = np.concatenate(parts).reshape(-1, *self.shape[1:])
        base = first * self.chunk
        return block[start - base : stop - base]
