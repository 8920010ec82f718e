"""Where the mask chunks of a local sharded Zarr store lie, for reading and writing them directly.

Only the layout StoreWriter makes is recognised (sharding_indexed along frames, inner codecs
bytes + zstd, index bytes + crc32c at the end, '/'-separated chunk keys); `ShardLayout.of`
returns None for anything else, which is then read and written through zarr.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .. import safe_json
from ..errors import StoreError
from .backends import is_url


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
