"""The content digest: SHA-256 over the canonical content, independent of backend and chunking.

See schemas/FORMAT.md, section "Content digest", for the byte-level definition.
"""

from __future__ import annotations

import hashlib
import math
import struct
from collections.abc import Callable, Iterable, Sequence
from functools import lru_cache
from typing import TYPE_CHECKING

import numpy as np

from ..errors import StoreError
from .format import decode_strings
from .masks import packed_width

DIGEST_PREFIX = b"odms-store-content/1"
BOX_PREFIX = b"odms-box-frame/2"  # what a frame of boxes hashes first: never a mask's bytes
BLOCK_FRAMES = 1024  # frames convert reads at a time: a shard of the store it writes
# Packed mask bytes read at a time otherwise: a block above glibc's largest mmap threshold (32 MiB)
# is mapped afresh on every read, and its page faults cost more than digesting it.
READ_BYTES = 16 << 20

if TYPE_CHECKING:
    from .reader import Store


def frame_tails(*columns: np.ndarray) -> np.ndarray:
    """(k, 8 c) uint8: the c columns of k frames as little-endian float64, every NaN written as the
    one canonical quiet NaN: what a frame of masks hashes after its mask (z, depth), or all that a
    frame of boxes hashes (its box, move and depth)."""
    v = np.column_stack(columns).astype("<f8")
    v[np.isnan(v)] = np.nan
    return v.view(np.uint8)


def frame_digests(packed: np.ndarray, z: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """(k, 32) uint8: SHA-256 of each frame's packed mask bytes, z and depth."""
    out = np.empty((len(packed), 32), np.uint8)
    tails = frame_tails(z, depth)
    for i in range(len(packed)):
        h = hashlib.sha256(np.ascontiguousarray(packed[i]).data)
        h.update(tails[i])
        out[i] = np.frombuffer(h.digest(), np.uint8)
    return out


@lru_cache(maxsize=4)
def _zero_rows(height: int, row_bytes: int) -> tuple[list, memoryview]:
    """SHA-256 states after 0..height zero rows of `row_bytes`, and the bytes of height zero rows."""
    zeros = memoryview(bytes(height * row_bytes))
    h, states = hashlib.sha256(), []
    for _ in range(height + 1):
        states.append(h.copy())
        h.update(zeros[:row_bytes])
    return states, zeros


def padded_frame_digests(packed: np.ndarray, y0: list[int], y1: list[int], tails: np.ndarray) -> bytes:
    """The `frame_digests` bytes of packed frames (k, height, row_bytes) that are zero but for
    rows y0[i] .. y1[i] of frame i, whose `frame_tails` are `tails`, hashing only those rows and
    the zero rows below them: the state after the zero rows above is computed once and copied,
    the zero rows below come from a shared buffer."""
    k, height, row_bytes = packed.shape
    states, zeros = _zero_rows(height, row_bytes)
    digests = []
    for i in range(k):
        h = states[y0[i]].copy()
        h.update(packed[i, y0[i] : y1[i]])
        h.update(zeros[: (height - y1[i]) * row_bytes])
        h.update(tails[i])
        digests.append(h.digest())
    return b"".join(digests)


def box_frame_digests(box: np.ndarray, move: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """(k, 32) uint8: SHA-256 of each frame of a store of boxes: its box (4), move (3) and depth
    as little-endian float64, NaN canonical (`frame_tails`)."""
    rows = frame_tails(box, move, depth)
    return np.stack([np.frombuffer(hashlib.sha256(BOX_PREFIX + r.tobytes()).digest(), np.uint8)
                     for r in rows]) if len(rows) else np.zeros((0, 32), np.uint8)


def example_digest(example_id: str, source: str, d1: float, frames: bytes) -> bytes:
    """SHA-256 of one example: its id, source, label and the digests of its frames in order
    (their 32-byte digests joined)."""
    d1 = float(d1)
    h = hashlib.sha256(f"{example_id}\0{source}\0".encode())
    h.update(struct.pack("<dI", math.nan if math.isnan(d1) else d1, len(frames) // 32))
    h.update(frames)
    return h.digest()


class StoreDigest:
    """Streams example digests, in example order, into the store digest."""

    def __init__(self, height: int, width: int, n_examples: int) -> None:
        self._h = hashlib.sha256(DIGEST_PREFIX + struct.pack("<IIQ", height, width, n_examples))

    def update(self, example_digests: Iterable[bytes]) -> None:
        for d in example_digests:
            self._h.update(d)

    def hexdigest(self) -> str:
        return "sha256:" + self._h.hexdigest()


def content_digest(
    height: int, width: int, frame_index: np.ndarray, frame_digests: np.ndarray,
    ids: Sequence[str], sources: Sequence[str], d1: np.ndarray,
) -> str:
    """The store digest of examples (rows of `frame_index`, ids, sources, labels) over frames
    whose `frame_digests` are known."""
    digest = StoreDigest(height, width, len(frame_index))
    digest.update(
        example_digest(ids[i], sources[i], d1[i], frame_digests[row[row >= 0]].tobytes())
        for i, row in enumerate(frame_index)
    )
    return digest.hexdigest()


def recompute_digest(
    store: Store, visit: Callable[[int, np.ndarray], None] | None = None, block_frames: int | None = None
) -> tuple[str, np.ndarray]:
    """Stream all masks once; returns the content digest and the (F, 32) frame digests of the
    content as stored (unchecked: `validate` digests broken stores too; the frame index must hold
    frame rows and the strings must be UTF-8).

    `visit(start, packed_block)` sees every block of packed masks as it is read, `block_frames`
    frames at a time (READ_BYTES when None); a store of boxes has none: its frames are digested
    from `box_frame_digests`.
    """
    depth, d1, fi = (store.raw(name) for name in ("depth", "d1", "frame_index"))
    ids, sources = decode_strings(store.raw("example_id")), decode_strings(store.raw("source"))
    if store.kind == "boxes":
        fd = box_frame_digests(store.raw("box"), store.raw("move"), depth)
        return content_digest(store.height, store.width, fi, fd, ids, sources, d1), fd
    z = store.raw("z")
    fd = np.empty((store.n_frames, 32), np.uint8)
    step = block_frames or max(1, READ_BYTES // (store.height * packed_width(store.width)))
    for start in range(0, store.n_frames, step):
        block = store.read_packed(start, min(start + step, store.n_frames))
        stop = start + len(block)
        fd[start:stop] = frame_digests(block, z[start:stop], depth[start:stop])
        if visit:
            visit(start, block)
    return content_digest(store.height, store.width, fi, fd, ids, sources, d1), fd


def check_recorded_digest(
    store: Store, path: str, visit: Callable[[int, np.ndarray], None] | None = None,
    block_frames: int | None = None,
) -> str:
    """`recompute_digest` that refuses a store (at `path`, for the message) whose content differs
    from the digest it records, or that breaks the format's read rules; returns the digest."""
    _ = store.frame_index, store.example_ids, store.sources  # read first: the format's rules checked
    digest, _ = recompute_digest(store, visit, block_frames)
    if digest != store.attrs.digest:
        raise StoreError(
            f"{path}: content digest {digest} differs from the recorded {store.attrs.digest}; "
            "run `odms-data validate` on it"
        )
    return digest
