"""The Zarr v3 backend (sharded masks), and the direct path to a local store's mask shards.

`ZarrBackend` reads and writes a store through zarr; every array it opens for reading reads
through odms-data's own codecs (zarr_codecs.py), never zarr's registry. zarr is imported only
where it is used: a worker that writes its shards of a local store never imports it.

zarr's fixed cost per read call, whatever its size, is most of the cost of reading one example;
`ShardReader` reads a local store's shard index and chunk bytes directly instead, and sink.py
writes whole shards the same way. Only the layout StoreWriter makes is recognised
(`ShardLayout`: sharding_indexed along frames, inner codecs bytes + zstd, index bytes + crc32c at
the end, '/'-separated chunk keys); `ShardLayout.of` and `ShardReader.open` return None for
anything else, which is then read and written through zarr.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ... import safe_json
from ...errors import StoreError
from ...inputs import open_input
from ...urls import is_url, reaching, storage_options, url_filesystem
from .common import ZSTD_LEVEL, Backend, Mode, zstd_decode

SETTLE_TIMEOUT_S = 60


def on_zarr_loop(coroutine: Any) -> Any:
    """Run `coroutine` on zarr's I/O thread's event loop and return its result: the one use of a
    private zarr module (zarr.core.sync), for what zarr's public API does not do."""
    from zarr.core.sync import sync

    return sync(coroutine)


def settle_zarr_io() -> None:
    """Wait for zarr's writes still in flight on its I/O thread. When one write of a call fails (a
    full disk) or the caller is interrupted, the call raises at once while its other writes go on,
    and would recreate files in a store being removed."""
    import asyncio

    async def others() -> None:
        pending = [t for t in asyncio.all_tasks() if t is not asyncio.current_task()]
        if pending:
            await asyncio.wait(pending, timeout=SETTLE_TIMEOUT_S)

    on_zarr_loop(others())


class ZarrBackend(Backend):
    format = "zarr"
    workers_write_shards = True

    def __init__(self, path: str, mode: Mode) -> None:
        import zarr

        self.path = path
        # arrays opened for reading, kept: each opening reads (and checks) its zarr.json, a request
        # or more per array and call on S3
        self._read: dict[str, Any] | None = {} if mode == "r" else None
        # a local store is created in the fresh folder outputs.Partial made, whose marker must stay
        zarr_mode = "a" if mode == "w" and not is_url(path) else mode
        if mode != "w":
            self._check_metadata("")
        from .zarr_codecs import StoreFolder

        store = str(path) if is_url(path) else StoreFolder(path, read_only=zarr_mode == "r")
        try:
            self.group = zarr.open_group(
                store=store, mode=zarr_mode, zarr_format=3, storage_options=storage_options(path)
            )
        except OSError:
            if mode == "w":
                raise  # a full disk, say: the writer names the store
            raise StoreError(f"{path}: not a readable Zarr v3 store (cannot be read)") from None
        except Exception as e:  # zarr raises several types for "not a group"
            raise StoreError(f"{path}: not a readable Zarr v3 store ({type(e).__name__}: {e})") from e

    def _array_names(self) -> Iterable[str]:
        return self.group.array_keys()

    def _check_metadata(self, name: str) -> None:
        """Bound the size and depth of a zarr.json, local or at a URL, before zarr parses it
        (safe_json.py); zarr reads it again, a small file."""
        if not is_url(self.path):
            meta = Path(self.path) / name / "zarr.json"
            if meta.is_file():
                safe_json.load_file(meta, StoreError)
            return
        url = "/".join([str(self.path).rstrip("/"), *([name] if name else []), "zarr.json"])
        try:
            fs, key = url_filesystem(url)
            with reaching(self.path):
                raw = fs.cat_file(key, start=0, end=safe_json.MAX_BYTES + 1)
        except FileNotFoundError:
            if not name:  # as open_backend says of a local path
                raise StoreError(f"{self.path}: no such store (no zarr.json there)") from None
            return  # zarr says which array is missing
        except OSError as e:
            raise StoreError(f"{url}: cannot be read ({e.strerror or e})") from None
        safe_json.loads(raw, url, StoreError)

    def array(self, name: str) -> Any:
        if self._read is not None and name in self._read:
            return self._read[name]
        self._check_metadata(name)
        from .zarr_codecs import scoped

        try:
            arr = self.group[name]
            if self._read is not None:  # odms-data's codecs for this array alone
                self._read[name] = arr = scoped(arr)
        except Exception as e:  # malformed metadata surfaces as many exception types
            raise StoreError(f"{self.path}: array '{name}' is unreadable ({type(e).__name__}: {e})") from e
        return arr

    def read_attrs(self) -> dict[str, Any] | None:
        attrs = self.group.attrs.asdict().get("odms")
        if attrs is not None and not isinstance(attrs, dict):
            raise StoreError(f"{self.path}: attribute 'odms' is not a JSON object")
        return attrs

    def write_attrs(self, attrs: dict[str, Any]) -> None:
        self.group.attrs.update({"odms": attrs})

    def check(self) -> None:
        """Nothing: zarr raises a failed write from the call that made it."""

    def close(self) -> None:
        settle_zarr_io()

    def create_array(self, name, shape, dtype, chunks, shards=None):
        from zarr.codecs import ZstdCodec

        return self.group.create_array(
            name, shape=shape, dtype=dtype, chunks=chunks, shards=shards,
            compressors=ZstdCodec(level=ZSTD_LEVEL, checksum=True), fill_value=0,
            config={"write_empty_chunks": True},  # skipping the per-chunk emptiness scan is 3x faster
        )


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
            with open_input(path, f"shard {s} of the masks (a damaged store)", StoreError) as f:
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
