"""Writing a store atomically: into `<path>.partial` under a lock, moved into place at commit.

A store is complete only when its `odms` attribute says `complete: true`, which `commit` writes
last; for local paths the finished store is also renamed into place, so an interrupted write
leaves at most a `.partial` sibling that the next run removes. Stores at URLs (no rename) rely on
the attribute alone.
"""

from __future__ import annotations

import fcntl
import os
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, StoreError, StoreExistsError, StoreLockedError
from .backends import Backend, detect_format, is_url, open_backend
from .format import EXAMPLE_ARRAYS, FRAME_ARRAYS, StoreAttrs, encode_strings
from .masks import FrameStats, packed_width
from .shard_writer import ShardChunks


@dataclass(frozen=True)
class Layout:
    """Shapes and chunking of a new store."""

    height: int
    width: int
    n_frames: int
    n_examples: int
    max_obs: int  # columns of frame_index
    id_width: int
    source_width: int
    frames_per_chunk: int  # frames per compressed mask chunk
    frames_per_shard: int  # frames per shard (and per chunk of the per-frame arrays)
    examples_per_chunk: int  # rows per chunk of the per-example arrays

    def __post_init__(self) -> None:
        if self.n_frames < 1 or self.n_examples < 1:
            raise InputError("a store needs at least one example and one frame")
        if self.frames_per_shard % self.frames_per_chunk:
            raise InputError("frames_per_shard must be a multiple of frames_per_chunk")


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    elif path.exists() or path.is_symlink():
        path.unlink()


class StoreWriter:
    """Context manager that creates a store; call `create`, the `write_*` methods, then `commit`."""

    def __init__(self, path: str, fmt: str | None = None, *, overwrite: bool = False) -> None:
        self.path = str(path)
        self.format = fmt or detect_format(self.path)
        self.overwrite = overwrite
        self.local = not is_url(self.path)
        self.partial = self.path + ".partial" if self.local else self.path
        self.backend: Backend | None = None
        self.arrays: dict = {}
        self.layout: Layout | None = None
        self._lock_fd: int | None = None
        self._committed = False

    # --- lifetime ----------------------------------------------------------------------
    def __enter__(self) -> StoreWriter:
        if self.local:
            self._acquire_lock()
            target = Path(self.path)
            if (target.exists() or target.is_symlink()) and not self.overwrite:
                self._release_lock()
                raise StoreExistsError(f"{self.path}: already exists; pass --overwrite to replace it")
            _remove(Path(self.partial))
        elif not self.overwrite and _url_exists(self.path):
            raise StoreExistsError(f"{self.path}: already exists; pass --overwrite to replace it")
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            if not self._committed:
                if self.backend is not None:
                    self.backend.close()
                if self.local:
                    _remove(Path(self.partial))
        finally:
            self._release_lock()

    def _acquire_lock(self) -> None:
        lock = self.path.rstrip("/") + ".lock"
        Path(lock).parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.read(fd, 64).decode(errors="replace").strip() or "unknown"
            os.close(fd)
            raise StoreLockedError(
                f"{self.path}: another odms-data process (pid {holder}) is writing this store"
            ) from None
        os.ftruncate(fd, 0)
        os.write(fd, str(os.getpid()).encode())
        self._lock_fd, self._lock_path = fd, lock

    def _release_lock(self) -> None:
        if self._lock_fd is not None:
            Path(self._lock_path).unlink(missing_ok=True)
            os.close(self._lock_fd)
            self._lock_fd = None

    # --- content -----------------------------------------------------------------------
    def create(self, layout: Layout) -> None:
        """Create every array of the store with the given shapes and chunking."""
        self.layout = L = layout
        if self.local:
            Path(self.partial).parent.mkdir(parents=True, exist_ok=True)
        self.backend = b = open_backend(self.partial, "w", self.format)
        F, E, fs, es = L.n_frames, L.n_examples, L.frames_per_shard, L.examples_per_chunk
        pw = packed_width(L.width)
        self.arrays = {
            "masks": b.create_array(
                "masks", (F, L.height, pw), FRAME_ARRAYS["masks"], (L.frames_per_chunk, L.height, pw),
                shards=(fs, L.height, pw),
            ),
            "z": b.create_array("z", (F,), FRAME_ARRAYS["z"], (fs,)),
            "depth": b.create_array("depth", (F,), FRAME_ARRAYS["depth"], (fs,)),
            "area": b.create_array("area", (F,), FRAME_ARRAYS["area"], (fs,)),
            "largest_area": b.create_array("largest_area", (F,), FRAME_ARRAYS["largest_area"], (fs,)),
            "bbox": b.create_array("bbox", (F, 4), FRAME_ARRAYS["bbox"], (fs, 4)),
            "frame_index": b.create_array(
                "frame_index", (E, L.max_obs), EXAMPLE_ARRAYS["frame_index"], (es, L.max_obs)
            ),
            "d1": b.create_array("d1", (E,), EXAMPLE_ARRAYS["d1"], (es,)),
            "example_id": b.create_array(
                "example_id", (E, L.id_width), EXAMPLE_ARRAYS["example_id"], (es, L.id_width)
            ),
            "source": b.create_array(
                "source", (E, L.source_width), EXAMPLE_ARRAYS["source"], (es, L.source_width)
            ),
        }

    def _created(self) -> tuple[Backend, Layout]:
        if self.backend is None or self.layout is None:
            raise StoreError(f"{self.path}: the store's arrays are written before create() was called")
        return self.backend, self.layout

    def write_masks(self, start: int, packed: np.ndarray) -> None:
        self.arrays["masks"][start : start + len(packed)] = packed

    def write_mask_chunk(self, start: int, deflated: bytes) -> None:
        """HDF5 only: store one already deflate-compressed mask chunk starting at frame `start`."""
        self.arrays["masks"].id.write_direct_chunk((start, 0, 0), deflated)

    def write_frames(
        self, start: int, z: np.ndarray, depth: np.ndarray, stats: FrameStats
    ) -> None:
        stop = start + len(z)
        a = self.arrays
        a["z"][start:stop] = z
        a["depth"][start:stop] = depth
        a["area"][start:stop] = stats.area
        a["largest_area"][start:stop] = stats.largest_area
        a["bbox"][start:stop] = stats.bbox

    def write_examples(
        self, start: int, frame_index: np.ndarray, d1: np.ndarray, ids: list[str], sources: list[str]
    ) -> None:
        stop = start + len(d1)
        _, L = self._created()
        fi = np.full((len(d1), L.max_obs), -1, np.int64)
        fi[:, : frame_index.shape[1]] = frame_index
        a = self.arrays
        a["frame_index"][start:stop] = fi
        a["d1"][start:stop] = d1
        a["example_id"][start:stop] = _fit(encode_strings(ids), L.id_width, "example id")
        a["source"][start:stop] = _fit(encode_strings(sources), L.source_width, "source")

    def commit(self, attrs: StoreAttrs) -> str:
        """Mark the store complete and move it into place; returns its path."""
        attrs.complete = True
        backend, _ = self._created()
        backend.write_attrs(attrs.to_json())
        backend.close()
        if self.local:
            target, partial = Path(self.path), Path(self.partial)
            if target.exists() or target.is_symlink():
                old = Path(self.path + ".replaced")
                _remove(old)
                target.rename(old)
                partial.rename(target)
                _remove(old)
            else:
                partial.rename(target)
        self._committed = True
        return self.path


def _url_exists(url: str) -> bool:
    from fsspec.core import url_to_fs

    fs, root = url_to_fs(url)
    return fs.exists(root)


def write_shard_masks(
    path: str, fmt: str, start: int, packed: np.ndarray, frames_per_chunk: int
) -> list[bytes]:
    """Store a worker's whole shard of packed masks, starting at the shard boundary `start`.

    Zarr: written afresh in one store write (shard_writer.py), replacing what an interrupted
    earlier attempt may have left; returns []. HDF5 (one writer only): returns the deflated
    chunks, zero-padded to full length, for `write_mask_chunk`.
    """
    chunks = ShardChunks(fmt, frames_per_chunk)
    for c in range(0, len(packed), frames_per_chunk):
        chunks.add(packed[c : c + frames_per_chunk])
    return chunks.write(path, start)


def _fit(matrix: np.ndarray, width: int, what: str) -> np.ndarray:
    if matrix.shape[1] > width:
        raise InputError(f"{what} longer than {width} bytes")
    out = np.zeros((len(matrix), width), np.uint8)
    out[:, : matrix.shape[1]] = matrix
    return out
