"""Each benchmark is one record (protocol.BENCHMARKS): its splits, sizes and All, as its readers see them."""

from __future__ import annotations

from pathlib import Path

from odms_data.evaluation.leaderboard import BENCHMARKS as TABLES
from odms_data.evaluation.metrics import SplitScore, all_scores
from odms_data.evaluation.score_tables import benchmarks_markdown
from odms_data.importers.odmd import ODMD_SETS
from odms_data.protocol import BENCHMARKS, benchmark_of, split_order
from odms_data.store.manifests import load_manifest


def test_every_records_sizes_are_its_manifests():
    for b in BENCHMARKS.values():
        assert {s: load_manifest(s).count for s in b.splits()} == b.counts


def test_the_odmd_importer_and_the_leaderboard_read_the_records():
    assert set(ODMD_SETS) == set(BENCHMARKS["odmd"].splits()) | set(BENCHMARKS["odms-detection"].splits())
    assert all(TABLES[k] is BENCHMARKS[k] for k in TABLES)


def test_a_split_belongs_to_a_benchmark_only_with_its_stores_domain():
    assert benchmark_of("odmd-perturb-motion-test", "odmd")[1:] == ("perturb_motion", "test")
    assert benchmark_of("odms-detect-robot-val", "robot")[0].key == "odms-detection"
    assert benchmark_of("robot-val", "generated") is None and benchmark_of("sim-val", "generated") is None
    order = sorted(["sim-val", "odmd-robot-test", "robot-test", "odms-detect-driving-val", "driving-val"],
                   key=split_order)
    assert order == ["driving-val", "robot-test", "odms-detect-driving-val", "odmd-robot-test", "sim-val"]


def _score(split, domain, pct, partial=False):
    return SplitScore(split, domain, 9 if partial else 10, 10, pct, pct, 0.1)


def test_each_benchmarks_all_is_the_mean_of_its_complete_sets():
    sets = BENCHMARKS["odmd"].splits("test")
    odmd = [_score(s, "odmd", p) for s, p in zip(sets, [0, 4, 21, 23], strict=True)]
    detect = [_score(s, s.split("-")[2], 10.0) for s in BENCHMARKS["odms-detection"].splits("val")]
    alls = all_scores([*odmd, *detect])
    assert [(a.benchmark, a.family, a.mean_percent_error) for a in alls] == [
        ("odms-detection", "val", 10.0), ("odmd", "test", 12.0)]
    assert alls[1].splits == BENCHMARKS["odmd"].splits("test")
    assert all_scores([*odmd[:3], _score(odmd[3].split, "odmd", 1.0, partial=True)]) == []
    assert all_scores(odmd[:3]) == []


def test_the_docs_show_the_records():
    text = (Path(__file__).resolve().parents[2] / "docs" / "SCORING.md").read_text()
    start = text.index("-->\n", text.index("<!-- benchmarks:")) + 4
    assert text[start:text.index("<!-- end benchmarks -->")] == benchmarks_markdown()
