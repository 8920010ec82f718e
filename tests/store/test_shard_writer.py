"""Shards written directly hold the bytes zarr writes, partial last shard and chunk included."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from odms_data.store.writer import Layout, StoreWriter, write_shard_masks

FRAMES, H, W, CHUNK, SHARD = 13, 9, 21, 3, 6  # 3 shards, the last with one chunk of 1 frame


def _shards_by(path: Path, how: str, packed: np.ndarray) -> dict[str, bytes]:
    """The shard files of `masks` written by zarr, directly as files or directly through zarr's store
    (a URL), by their path in the array."""
    layout = Layout(height=H, width=W, n_frames=FRAMES, n_examples=1, max_obs=1, id_width=4,
                    source_width=4, frames_per_chunk=CHUNK, frames_per_shard=SHARD, examples_per_chunk=1)
    with StoreWriter(str(path)) as w:
        w.create(layout)
        for start in range(0, FRAMES, SHARD):
            block = packed[start : start + SHARD]
            if how == "zarr":
                w.write_masks(start, block)
            else:
                target = w.partial if how == "file" else f"file://{w.partial}"
                assert write_shard_masks(target, "zarr", start, block, CHUNK) == []
        root = Path(w.partial) / "masks" / "c"
        return {str(p.relative_to(root)): p.read_bytes() for p in root.rglob("*") if p.is_file()}


@pytest.mark.parametrize("seed", [0, 1])
def test_direct_shards_equal_zarrs(tmp_path, seed):
    rng = np.random.default_rng(seed)
    packed = rng.integers(0, 256, (FRAMES, H, (W + 7) // 8), dtype=np.uint8)
    packed[rng.random(packed.shape) < 0.7] = 0  # compressible, as masks are
    packed[:, :, -1] &= 0xF8  # the padding bits of a 21-pixel row are 0
    by_zarr = _shards_by(tmp_path / "zarr.zarr", "zarr", packed)
    assert sorted(by_zarr) == ["0/0/0", "1/0/0", "2/0/0"]
    assert _shards_by(tmp_path / "file.zarr", "file", packed) == by_zarr
    assert _shards_by(tmp_path / "url.zarr", "url", packed) == by_zarr


def test_hdf5_chunks_are_zero_padded_and_deflated():
    import zlib

    packed = np.arange(4 * 2 * 3, dtype=np.uint8).reshape(4, 2, 3)
    chunks = write_shard_masks("unused.h5", "hdf5", 0, packed, 3)
    assert len(chunks) == 2
    last = np.frombuffer(zlib.decompress(chunks[1]), np.uint8).reshape(3, 2, 3)
    np.testing.assert_array_equal(last[0], packed[3])
    assert not last[1:].any()
