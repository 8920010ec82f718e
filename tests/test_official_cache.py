"""The cache of the imported official release (tests/official_cache.py): built once, reused while
intact, rebuilt when a file is lost or changed, read-only while cached."""

from __future__ import annotations

import io
import os
import subprocess
import sys
import tarfile
from pathlib import Path

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


WAITING_IMPORT = """
import sys, time
from pathlib import Path
sys.path.insert(0, sys.argv[1])
from official_cache import official_entry

def import_release(data, out):
    with open(sys.argv[3], "a") as log:
        log.write("import\\n")
    time.sleep(2)  # long enough for the other run to ask meanwhile
    out.mkdir()
    (out / "robot-val.zarr").write_bytes(b"imported")

print(official_entry(Path(sys.argv[2]), import_release))
"""


def test_two_runs_asking_at_once_import_once(tmp_path):
    """Two pytest-xdist workers (or two suites) share one build: the second waits for the first."""
    archive = _archive(tmp_path / "release.tar.gz")
    log = tmp_path / "imports.log"
    env = {**os.environ, "ODMS_TEST_CACHE": str(tmp_path / "cache")}
    args = [sys.executable, "-c", WAITING_IMPORT, str(Path(__file__).parent), str(archive), str(log)]
    runs = [subprocess.Popen(args, env=env, stdout=subprocess.PIPE, text=True) for _ in range(2)]
    entries = [r.communicate(timeout=60)[0].strip() for r in runs]
    assert all(r.returncode == 0 for r in runs)
    assert entries[0] == entries[1] and log.read_text() == "import\n"
