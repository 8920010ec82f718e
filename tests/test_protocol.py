"""The benchmark's facts agree with the shipped split manifests."""

from odms_data.importers.odmd import ODMD_SETS
from odms_data.protocol import (
    MAX_RECORDING_FRAMES,
    OFFICIAL_COUNTS,
    OFFICIAL_SPLITS,
    evenly_spaced,
    protocol_windows,
    window_id,
    window_of_id,
)
from odms_data.store.manifests import load_manifest, split_names


def test_official_splits_and_counts_are_the_imported_manifests():
    imported = [s for s in split_names() if load_manifest(s).origin == "imported" and s not in ODMD_SETS]
    assert sorted(imported) == sorted(OFFICIAL_SPLITS) == sorted(OFFICIAL_COUNTS)
    assert {s: load_manifest(s).count for s in imported} == OFFICIAL_COUNTS
    assert sum(OFFICIAL_COUNTS.values()) == 15_650


def test_evenly_spaced_truncates_and_the_robot_protocol_has_55_windows():
    assert evenly_spaced(0, 29, 10).tolist() == [0, 3, 6, 9, 12, 16, 19, 22, 25, 29]
    windows = protocol_windows(30, (10, 15, 20, 25, 30), 10)
    assert len(windows) == 55
    assert windows[-1][0] == 30 and windows[-1][2].tolist() == evenly_spaced(0, 29, 10).tolist()


def test_odmds_sets_have_manifests_of_the_sizes_odmd_publishes():
    counts = {s: load_manifest(s).count for s in ODMD_SETS}
    assert sum(c for s, c in counts.items() if s.startswith("odmd-")) == 21_600  # 4 x 2,400 + 4 x 3,000
    converted = {s.removeprefix("odms-detect-"): c for s, c in counts.items() if s.startswith("odms-detect-")}
    assert converted == OFFICIAL_COUNTS  # ODMD's conversion of ODMS keeps every example


def test_a_window_id_reads_back_and_other_ids_name_no_window():
    assert window_of_id(window_id("cup", 15, 7, 2), "cup") == (7, 15)
    assert window_of_id(window_id("cup", 10, 123, 2), "cup") == (123, 10)
    assert window_of_id("cup/all", "cup") == (0, None)
    for other in ("cup/w15-07x", "mug/w15-07", "cup/w0-01", "cup/w-1-01", "cup/00042", "cup/w15",
                  f"cup/w9-{MAX_RECORDING_FRAMES}", "cup/w99999999-0"):
        assert window_of_id(other, "cup") is None, other
