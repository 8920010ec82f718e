"""The direct shard reader gives exactly what zarr gives, and refuses a corrupt shard."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from odms_data.errors import StoreError
from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import preset
from odms_data.store.reader import open_store


@pytest.fixture(scope="module")
def small_store(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("shards") / "s.zarr"
    generate(str(path), 13, preset("standard"), seed=3, examples_per_shard=4)
    return path


def test_same_bytes_as_zarr(small_store):
    with open_store(str(small_store)) as s:
        assert s._fast is not None
        zarr_masks = s.backend.array("masks")
        for lo, hi in [(0, 1), (0, s.n_frames), (7, 45), (39, 41), (s.n_frames - 3, s.n_frames + 5), (5, 5)]:
            np.testing.assert_array_equal(s.read_packed(lo, hi), zarr_masks[lo:hi])


def test_corrupt_shard_index_is_a_store_error(small_store, tmp_path):
    import shutil

    copy = tmp_path / "c.zarr"
    shutil.copytree(small_store, copy)
    shard = copy / "masks" / "c" / "1" / "0" / "0"
    data = bytearray(shard.read_bytes())
    data[-10] ^= 0xFF
    shard.write_bytes(bytes(data))
    with open_store(str(copy)) as s, pytest.raises(StoreError, match="checksum mismatch"):
        s.read_packed(40, 45)
