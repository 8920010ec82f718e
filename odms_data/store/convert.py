"""Lossless conversion between the Zarr and HDF5 backends."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .digest import BLOCK_FRAMES, check_recorded_digest
from .format import arrays_per
from .reader import open_store
from .writer import Layout, StoreWriter


def convert(
    src: str, dst: str, fmt: str | None = None, *, overwrite: bool = False,
    progress: Callable[[str, int, int], None] | None = None,
) -> str:
    """Copy the store `src` to `dst` (backend from `fmt` or dst's suffix); returns the digest.

    The content digest is recomputed from what is copied, so a corrupt source is refused and
    nothing is left at `dst`.
    """
    with open_store(src) as s:
        chunk = int(s.backend.array("masks").chunks[0]) if s.kind == "masks" else BLOCK_FRAMES
        per_shard = max(chunk, (BLOCK_FRAMES // chunk) * chunk)
        layout = Layout(
            height=s.height, width=s.width, n_frames=s.n_frames, n_examples=s.n_examples,
            max_obs=s.frame_index.shape[1], id_width=s.backend.array("example_id").shape[1],
            source_width=s.backend.array("source").shape[1], frames_per_chunk=chunk,
            frames_per_shard=per_shard, examples_per_chunk=min(s.n_examples, 4096), kind=s.kind,
        )
        with StoreWriter(dst, fmt, overwrite=overwrite) as w:
            w.create(layout)
            for per in ("frame", "example"):
                w.write_rows(per, 0, {a.name: s.checked(a.name) for a in arrays_per(per, s.kind)
                                  if not a.sharded})

            def copy(start: int, block: np.ndarray) -> None:
                w.write_masks(start, block)
                if progress:
                    progress(str(dst), start + len(block), s.n_frames)

            digest = check_recorded_digest(s, src, copy, BLOCK_FRAMES)
            w.commit(s.attrs)
        return digest
