"""Shared fixtures: the official ODMS archive (from ../shared, skipped when absent) and stores."""

from __future__ import annotations

import os
import tarfile
from pathlib import Path

import pytest
from hypothesis import settings

from odms_data.protocol import OFFICIAL_SPLITS

# The property-based tests draw the same examples in every run, so that a run's verdict is the
# code's and not the draw's (a new failure is found by changing the code or the tests, not by luck).
settings.register_profile("reproducible", derandomize=True)
settings.load_profile("reproducible")

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("ODMS_SHARED", REPO.parent / "shared"))
ARCHIVE = SHARED / "data" / "odms-v1.tar.gz"


@pytest.fixture(scope="session")
def official_archive() -> Path:
    if not ARCHIVE.is_file():
        pytest.skip(f"official ODMS archive not found at {ARCHIVE} (set ODMS_SHARED to its shared/ folder)")
    return ARCHIVE


@pytest.fixture(scope="session")
def official_data_dir(official_archive, tmp_path_factory) -> Path:
    """The release's data/ folder, extracted once per test session."""
    root = tmp_path_factory.mktemp("odms-release")
    with tarfile.open(official_archive) as tar:
        tar.extractall(root, filter="data")
    return root / "data"


@pytest.fixture(scope="session")
def official_stores(official_data_dir, tmp_path_factory) -> dict[str, Path]:
    """The eight official splits imported once per session: split name -> store path."""
    from odms_data.importers.release import import_release

    out = tmp_path_factory.mktemp("odms-stores")
    import_release(official_data_dir, out)
    return {name: out / f"{name}.zarr" for name in OFFICIAL_SPLITS}
