"""Where the mask chunks of a local sharded Zarr store lie, and the shard index format, for
reading and writing them directly (shard_reader.py, shard_writer.py).

Only the layout StoreWriter makes is recognised (sharding_indexed along frames, inner codecs
bytes + zstd, index bytes + crc32c at the end, '/'-separated chunk keys); `ShardLayout.of`
returns None for anything else, which is then read and written through zarr.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import safe_json
from ..errors import StoreError
from ..urls import is_url

# A shard ends with its index: per inner chunk an (offset, length) pair of little-endian uint64,
# both MISSING for an absent chunk, then the crc32c of the index, little-endian.
MISSING = 2**64 - 1
ENTRY = np.dtype([("offset", "<u8"), ("length", "<u8")])
CRC_BYTES = 4


def index_bytes(per_shard: int) -> int:
    """Bytes at the end of a shard of `per_shard` inner chunks that hold its index and checksum."""
    return per_shard * ENTRY.itemsize + CRC_BYTES


def encode_index(lengths: list[int], per_shard: int) -> bytes:
    """The index (with its crc32c) of a shard whose first inner chunks, of `lengths` bytes, lie
    one after another from its start; the rest are absent."""
    import google_crc32c

    index = np.full(per_shard, MISSING, ENTRY)
    sizes = np.array(lengths, np.uint64)
    index["length"][: len(sizes)] = sizes
    index["offset"][: len(sizes)] = np.cumsum(sizes) - sizes
    raw = index.tobytes()
    return raw + google_crc32c.value(raw).to_bytes(CRC_BYTES, "little")


def decode_index(tail: bytes, where: object) -> np.ndarray:
    """(per_shard, 2) uint64 (offset, length) rows of a shard's index from its `tail` of
    `index_bytes` bytes; StoreError naming `where` when the checksum disagrees."""
    import google_crc32c

    raw, crc = tail[:-CRC_BYTES], tail[-CRC_BYTES:]
    if google_crc32c.value(raw) != int.from_bytes(crc, "little"):
        raise StoreError(f"{where}: shard index checksum mismatch")
    return np.frombuffer(raw, "<u8").reshape(-1, 2)


@dataclass(frozen=True)
class ShardLayout:
    root: Path  # the `masks` array's folder
    shape: tuple[int, ...]  # (frames, H, ceil(W/8))
    chunk: int  # frames per inner chunk
    shard: int  # frames per shard

    @property
    def per_shard(self) -> int:
        return self.shard // self.chunk

    def shard_path(self, s: int) -> Path:
        return self.root / "c" / str(s) / "0" / "0"

    @classmethod
    def of(cls, store_path: str) -> ShardLayout | None:
        if is_url(store_path):
            return None
        root = Path(store_path) / "masks"
        try:
            meta = safe_json.load_file(root / "zarr.json", StoreError)
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
        except Exception:  # anything unexpected: let zarr handle it (and report what is wrong)
            return None
        return cls(root, shape, chunk, shard) if ok else None
