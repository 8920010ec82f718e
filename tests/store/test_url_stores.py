"""Stores at fsspec URLs (file://, memory://), written in-process: same content, no silent replace."""

from __future__ import annotations

import fsspec  # noqa: F401
import pytest

from odms_data.errors import StoreExistsError
from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import preset
from odms_data.store.reader import open_store

PARAMS = preset("standard", image_size=(120, 160), sizes=(30, 60))


@pytest.mark.parametrize("scheme", ["file", "memory"])
def test_url_store_matches_a_path_and_is_not_replaced_silently(scheme, tmp_path):
    local = generate(str(tmp_path / "local.zarr"), 12, PARAMS, 5, examples_per_shard=5).digest
    url = f"file://{tmp_path}/url.zarr" if scheme == "file" else f"memory://{tmp_path.name}/url.zarr"
    assert generate(url, 12, PARAMS, 5, examples_per_shard=5).digest == local
    with pytest.raises(StoreExistsError, match="already exists"):
        generate(url, 12, PARAMS, 6)
    assert open_store(url).attrs.digest == local
    replaced = generate(url, 12, PARAMS, 6, overwrite=True).digest
    assert replaced != local and open_store(url).attrs.digest == replaced
