"""Lossless conversion between the Zarr and HDF5 backends: a store as a store source (build.py),
copied a shard of frames at a time."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

from ..errors import StoreError
from .backends import MaskSink
from .build import BOX_ROWS, Progress, Rows, Sizes, Source, build
from .digest import BLOCK_FRAMES, box_frame_digests, frame_digests
from .format import StoreAttrs, arrays_per
from .reader import Store, open_store
from .writer import Layout


@dataclass(frozen=True)
class Block:
    """Frames [start, stop) to copy."""

    start: int
    stop: int


class Copied(Source):
    """The open store `store` (read from `path`), copied as it is; the content digest is
    recomputed from what is copied, so a corrupt store is refused. Its tasks read from this
    process's open store: they run here."""

    def __init__(self, store: Store, path: str) -> None:
        self.store, self.path = store, path
        self.sink: MaskSink | None = None

    def sizes(self) -> Sizes:
        s = self.store
        _ = s.frame_index, s.example_ids, s.sources  # read first: the format's rules checked
        masks = s.kind == "masks"
        chunk = int(s.backend.array("masks").chunks[0]) if masks else BLOCK_FRAMES
        return Sizes(height=s.height, width=s.width, n_frames=s.n_frames, n_examples=s.n_examples,
                     max_obs=s.frame_index.shape[1], id_width=s.backend.array("example_id").shape[1],
                     source_width=s.backend.array("source").shape[1],
                     frames_per_task=BLOCK_FRAMES if masks else BOX_ROWS, frames_per_chunk=chunk, kind=s.kind)

    def tasks(self, sink: MaskSink | None, layout: Layout) -> Iterator[Block]:
        self.sink = sink
        step = layout.frames_per_shard
        for start in range(0, layout.n_frames, step):
            yield Block(start, min(start + step, layout.n_frames))

    def runner(self) -> Callable[[Block], Rows]:
        return self.copy

    def copy(self, b: Block) -> Rows:
        """One block's frame rows, masks and frame digests, read from the store."""
        s = self.store
        rows = Rows(b.start, {a.name: s.checked(a.name)[b.start : b.stop]
                              for a in arrays_per("frame", s.kind) if not a.sharded})
        f = rows.frames
        if self.sink is None:
            rows.frame_digests = box_frame_digests(f["box"], f["move"], f["depth"])
        else:
            packed = s.read_packed(b.start, b.stop)
            rows.frame_digests = frame_digests(packed, f["z"], f["depth"])
            rows.returned_masks = self.sink.write_packed(b.start, packed)
        return rows

    def examples(self) -> dict[str, Any]:
        return {a.name: self.store.checked(a.name) for a in arrays_per("example", self.store.kind)}

    def attrs(self, digest: str) -> StoreAttrs:
        if digest != self.store.attrs.digest:
            raise StoreError(
                f"{self.path}: content digest {digest} differs from the recorded {self.store.attrs.digest}; "
                "run `odms-data validate` on it"
            )
        return self.store.attrs


def convert(
    src: str, dst: str, fmt: str | None = None, *, overwrite: bool = False,
    progress: Progress | None = None,
) -> str:
    """Copy the store `src` to `dst` (backend from `fmt` or dst's suffix); returns the digest.

    The content digest is recomputed from what is copied, so a corrupt source is refused and
    nothing is left at `dst`.
    """
    with open_store(src) as s:
        return build(Copied(s, src), dst, fmt, overwrite=overwrite, progress=progress).digest
