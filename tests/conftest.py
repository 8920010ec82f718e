"""Shared fixtures: the official ODMS archive (from ../shared, skipped when absent) and stores,
and ODMD's data folder (skipped when absent)."""

from __future__ import annotations

import os
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
# ODMD's data/ folder (griffbr/ODMD): $ODMD_DATA, else ../shared/odmd/data beside the project.
ODMD_DATA = Path(os.environ.get("ODMD_DATA") or REPO.parent / "shared/odmd/data")
ODMD_PRETRAINED = Path(os.environ.get("ODMD_PRETRAINED")
                       or REPO.parent / "shared/odmd/model/DBox_pretrained_paper.pt")


@pytest.fixture(autouse=True, scope="module")
def _environment_kept():
    """Each test module leaves os.environ as it found it: an in-process Dask cluster sets
    OMP_NUM_THREADS and others for its workers, which the commands later tests start would
    inherit."""
    saved = dict(os.environ)
    yield
    os.environ.clear()
    os.environ.update(saved)


@pytest.fixture(scope="session")
def official_archive() -> Path:
    if not ARCHIVE.is_file():
        pytest.skip(f"official ODMS archive not found at {ARCHIVE} (set ODMS_SHARED to its shared/ folder)")
    return ARCHIVE


@pytest.fixture(scope="session")
def official_entry(official_archive) -> Path:
    """The release extracted and imported, cached across runs (tests/official_cache.py)."""
    from official_cache import official_entry

    from odms_data.importers.release import import_release

    return official_entry(official_archive, import_release)


@pytest.fixture(scope="session")
def official_data_dir(official_entry) -> Path:
    """The release's data/ folder (read-only)."""
    return official_entry / "data"


@pytest.fixture(scope="session")
def official_stores(official_entry) -> dict[str, Path]:
    """The eight official splits, imported: split name -> store path (read-only)."""
    return {name: official_entry / "stores" / f"{name}.zarr" for name in OFFICIAL_SPLITS}


@pytest.fixture(scope="session")
def odmd_data() -> Path:
    """ODMD's data/ folder: its pickled val/test sets (read-only)."""
    if not ODMD_DATA.is_dir():
        pytest.skip(f"ODMD's data folder is not here ({ODMD_DATA}); set ODMD_DATA to griffbr/ODMD's data/")
    return ODMD_DATA


@pytest.fixture(scope="session")
def odmd_pretrained() -> Path:
    """ODMD's published DBox weights file (read-only)."""
    if not ODMD_PRETRAINED.is_file():
        pytest.skip(f"ODMD's pretrained DBox is not here ({ODMD_PRETRAINED}); set ODMD_PRETRAINED to "
                    "griffbr/ODMD's DBox_pretrained_paper.pt")
    return ODMD_PRETRAINED
