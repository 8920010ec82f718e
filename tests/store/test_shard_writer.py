"""Shards written directly read back, through zarr and the direct reader, as the masks written."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import zarr

from odms_data.store.backends import MaskSink, ShardReader
from odms_data.store.writer import Layout, StoreWriter

FRAMES, H, W, CHUNK, SHARD = 13, 9, 21, 3, 6  # 3 shards, the last with one chunk of 1 frame


@pytest.mark.parametrize("how", ["file", "url"])
def test_direct_shards_read_back_as_written(tmp_path: Path, how: str):
    rng = np.random.default_rng(0)
    packed = rng.integers(0, 256, (FRAMES, H, (W + 7) // 8), dtype=np.uint8)
    packed[rng.random(packed.shape) < 0.7] = 0  # compressible, as masks are
    packed[:, :, -1] &= 0xF8  # the padding bits of a 21-pixel row are 0
    layout = Layout(height=H, width=W, n_frames=FRAMES, n_examples=1, max_obs=1, id_width=4,
                    source_width=4, frames_per_chunk=CHUNK, frames_per_shard=SHARD, examples_per_chunk=1)
    with StoreWriter(str(tmp_path / "s.zarr")) as w:
        w.create(layout)
        target = w.partial if how == "file" else f"file://{w.partial}"
        for start in range(0, FRAMES, SHARD):
            assert MaskSink(target, "zarr", CHUNK).write_packed(start, packed[start : start + SHARD]) == []
        root = Path(w.partial) / "masks" / "c"
        assert sorted(str(p.relative_to(root)) for p in root.rglob("*") if p.is_file()) == \
            ["0/0/0", "1/0/0", "2/0/0"]
        np.testing.assert_array_equal(zarr.open_array(w.partial, path="masks")[:], packed)
        reader = ShardReader.open(w.partial)
        assert reader is not None
        np.testing.assert_array_equal(reader.read(0, FRAMES), packed)
        np.testing.assert_array_equal(reader.read(5, 8), packed[5:8])


def test_hdf5_chunks_are_zero_padded_and_deflated():
    import zlib

    packed = np.arange(4 * 2 * 3, dtype=np.uint8).reshape(4, 2, 3)
    chunks = MaskSink("unused.h5", "hdf5", 3).write_packed(0, packed)
    assert len(chunks) == 2
    last = np.frombuffer(zlib.decompress(chunks[1]), np.uint8).reshape(3, 2, 3)
    np.testing.assert_array_equal(last[0], packed[3])
    assert not last[1:].any()
