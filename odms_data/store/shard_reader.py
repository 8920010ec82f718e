"""Reading mask chunks straight from a local sharded Zarr store, without zarr's async machinery.

zarr spends about 2 ms of CPU per read call whatever its size, most of the cost of reading one
example; reading the shard index and the chunk bytes directly takes about a sixth of that. Only
the layout StoreWriter makes is read this way (sharding_indexed along frames, inner codecs bytes +
zstd, index bytes + crc32c at the end, '/'-separated chunk keys); `ShardReader.open` returns None
for anything else, which `Store` then reads through zarr.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import StoreError
from .backends import is_url

MISSING = np.uint64(2**64 - 1)


class ShardReader:
    def __init__(self, root: Path, shape: tuple[int, ...], chunk: int, shard: int) -> None:
        import google_crc32c
        from numcodecs import Zstd

        self.root, self.shape, self.chunk, self.shard = root, shape, chunk, shard
        self.per_shard = shard // chunk
        self.frame_bytes = int(np.prod(shape[1:]))
        self._zstd, self._crc = Zstd(), google_crc32c.value

    @classmethod
    def open(cls, store_path: str) -> ShardReader | None:
        if is_url(store_path):
            return None
        root = Path(store_path) / "masks"
        try:
            meta = json.loads((root / "zarr.json").read_text())
            (codec,) = meta["codecs"]
            conf = codec["configuration"]
            inner = [c["name"] for c in conf["codecs"]]
            index = [c["name"] for c in conf["index_codecs"]]
            outer = meta["chunk_grid"]["configuration"]["chunk_shape"]
            sep = meta["chunk_key_encoding"]["configuration"]["separator"]
            shape = tuple(meta["shape"])
            chunk, shard = conf["chunk_shape"][0], outer[0]
            ok = (codec["name"] == "sharding_indexed" and inner == ["bytes", "zstd"]
                  and index == ["bytes", "crc32c"] and conf["index_location"] == "end" and sep == "/"
                  and meta["data_type"] == "uint8" and len(shape) == 3
                  and list(outer[1:]) == list(shape[1:]) and list(conf["chunk_shape"][1:]) == list(shape[1:])
                  and meta["fill_value"] == 0 and all(type(v) is int for v in (*shape, chunk, shard))
                  and 0 < chunk <= shard and shard % chunk == 0)
        except Exception:  # anything unexpected: let zarr read it (and report what is wrong)
            return None
        return cls(root, shape, chunk, shard) if ok else None

    def _chunks(self, s: int, ks: range) -> list[np.ndarray]:
        """Packed frames of chunks ks of shard s (full chunk length; missing chunks are zeros)."""
        path = self.root / "c" / str(s) / "0" / "0"
        out_bytes = self.chunk * self.frame_bytes
        zeros = np.zeros(out_bytes, np.uint8)
        try:
            with open(path, "rb") as f:
                n = 16 * self.per_shard
                f.seek(-(n + 4), 2)
                raw = f.read(n + 4)
                if self._crc(raw[:n]) != int.from_bytes(raw[n:], "little"):
                    raise StoreError(f"{path}: shard index checksum mismatch")
                index = np.frombuffer(raw[:n], "<u8").reshape(-1, 2)[ks.start : ks.stop]
                present = index[:, 0] != MISSING
                if not present.any():
                    return [zeros] * len(ks)
                lo = int(index[present, 0].min())
                hi = int((index[present, 0] + index[present, 1]).max())
                f.seek(lo)
                span = f.read(hi - lo)  # the chunks of a range lie together: one read
            out = []
            for (offset, nbytes), ok in zip(index, present, strict=True):
                data = self._zstd.decode(span[int(offset) - lo : int(offset + nbytes) - lo]) if ok else zeros
                if len(data) != out_bytes:
                    raise StoreError(f"{path}: a chunk holds {len(data)} bytes, expected {out_bytes}")
                out.append(np.frombuffer(data, np.uint8))
            return out
        except FileNotFoundError:
            return [zeros] * len(ks)
        except (OSError, RuntimeError, ValueError) as e:  # numcodecs raises RuntimeError on bad data
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
