"""Stores at fsspec URLs (file://, memory://), read and written through zarr: same content, no silent
replace, and the same checks as a local store (a shard lacking a chunk, a bounded zarr.json)."""

from __future__ import annotations

import fsspec  # noqa: F401
import pytest
from broken_stores import rewrite_shard

from odms_data.errors import StoreError, StoreExistsError
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


def test_url_store_lacking_a_chunk_of_a_shard_is_damage_not_zeros(tmp_path):
    """A store at a URL is read through zarr, not odms-data's direct shard reader: a mask chunk marked
    missing in its shard's index is refused too, where zarr would read zeros."""
    generate(str(tmp_path / "s.zarr"), 12, PARAMS, 5, examples_per_shard=5)
    url = f"file://{tmp_path}/s.zarr"
    assert open_store(url).read_packed(0, 60).any()  # masks are drawn: zeros would be visible
    rewrite_shard(tmp_path / "s.zarr", 1, None)
    store = open_store(url)
    with pytest.raises(StoreError, match=r"s\.zarr: masks of frames .*chunk 1 of a shard is missing"):
        store.read_packed(0, store.n_frames)


def test_url_store_metadata_is_bounded_before_zarr_parses_it(tmp_path):
    """zarr.json at a URL goes through the same depth bound as a local one (safe_json.py)."""
    generate(str(tmp_path / "s.zarr"), 4, PARAMS, 5)
    meta = tmp_path / "s.zarr" / "zarr.json"
    meta.write_text(meta.read_text().replace('"attributes": {', '"attributes": {"x": ' + "[" * 100_000
                                             + "]" * 100_000 + ", ", 1))
    with pytest.raises(StoreError, match=r"s\.zarr/zarr\.json: JSON nested deeper than 64 levels"):
        open_store(f"file://{tmp_path}/s.zarr")
