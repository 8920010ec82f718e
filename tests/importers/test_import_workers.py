"""Imports on worker processes: the store builder runs an import's tasks on local workers as it
runs generation's, and the store is the one a single worker writes."""

from __future__ import annotations

import pytest
from test_import_recording import write_recording
from test_release import fake_release

from odms_data.importers import recording, release
from odms_data.importers.recording import import_recording
from odms_data.importers.release import import_release
from odms_data.store.reader import open_store
from odms_data.store.validate import validate


@pytest.mark.parametrize("fmt", ["zarr", "hdf5"])
def test_a_recording_imported_by_two_workers_is_the_one_worker_store(tmp_path, monkeypatch, fmt):
    rec = write_recording(tmp_path)
    suffix = ".zarr" if fmt == "zarr" else ".h5"
    one = import_recording(rec["masks"], rec["csv"], tmp_path / f"one{suffix}", windows=[5, 10], n_obs=5,
                           name="cup", workers=1)
    monkeypatch.setattr(recording, "FRAMES_PER_CHUNK", 2)  # 12 frames in three tasks
    monkeypatch.setattr(recording, "FRAMES_PER_SHARD", 4)
    two = import_recording(rec["masks"], rec["csv"], tmp_path / f"two{suffix}", windows=[5, 10], n_obs=5,
                           name="cup", workers=2)
    assert one.attrs.digest == two.attrs.digest
    with open_store(str(two.path)) as s:
        assert s.backend.array("masks").chunks[0] == 2 and s.n_frames == 12
    assert validate(str(two.path)).ok


def test_a_release_split_imported_by_two_workers_is_the_one_worker_store(tmp_path, monkeypatch):
    data = fake_release(tmp_path, folders=4)
    one = import_release(data, tmp_path / "one", splits=["normal-val"], workers=1, verify=False)
    monkeypatch.setitem(release.CHUNKING, "normal", (5, 10))  # 40 frames in four tasks
    two = import_release(data, tmp_path / "two", splits=["normal-val"], workers=2, verify=False)
    assert one[0].attrs.digest == two[0].attrs.digest
    assert one[0].attrs.split == two[0].attrs.split == "normal-val-modified"
    assert validate(str(two[0].path)).ok
