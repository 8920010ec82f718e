"""The cache of the imported official release (tests/official_cache.py): built once, reused while
intact, rebuilt when a file is lost or changed, read-only while cached."""

from __future__ import annotations

import io
import tarfile

from official_cache import official_entry


def _archive(path):
    with tarfile.open(path, "w:gz") as tar:
        data = b"png bytes"
        info = tarfile.TarInfo("data/val/robot/0.png")
        info.size = len(data)
        tar.addfile(info, io.BytesIO(data))
    return path


def test_built_once_reused_and_rebuilt_when_damaged(tmp_path, monkeypatch):
    monkeypatch.setenv("ODMS_TEST_CACHE", str(tmp_path / "cache"))
    archive = _archive(tmp_path / "release.tar.gz")
    imports = []

    def import_release(data, out):
        imports.append(data)
        out.mkdir()
        (out / "robot-val.zarr").write_bytes((data / "val/robot/0.png").read_bytes() + b" imported")

    entry = official_entry(archive, import_release)
    store = entry / "stores" / "robot-val.zarr"
    assert store.read_bytes() == b"png bytes imported" and len(imports) == 1
    assert official_entry(archive, import_release) == entry and len(imports) == 1
    assert not any(p.stat().st_mode & 0o222 for p in [entry, *entry.rglob("*")])  # read-only
    store.chmod(0o644)
    store.write_bytes(b"damaged")
    assert official_entry(archive, import_release) == entry and len(imports) == 2
    assert store.read_bytes() == b"png bytes imported"
    assert [p.name for p in (tmp_path / "cache").iterdir()] == [entry.name]  # no partial left
