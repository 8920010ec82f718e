"""`score --by KEY`: groups measured by the same code as the whole, with the record's bins, on
small stores and on the official robot and driving sets."""

from __future__ import annotations

import json

import numpy as np
import pytest
from _stores import make_store
from click.testing import CliRunner

from odms_data.cli import main
from odms_data.evaluation.breakdown import KEYS
from odms_data.evaluation.metrics import score_split
from odms_data.evaluation.predictions import HEADER
from odms_data.protocol import BENCHMARKS

DEPTHS = (0.12, 0.18, 0.25, 0.35, 0.45, 0.55)


def _score_by(preds, data, key, *extra):
    res = CliRunner().invoke(main, ["score", str(preds), "--data", str(data), "--json", "--by", key, *extra])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def test_groups_are_scored_by_the_same_code_in_the_records_bins(tmp_path):
    # a store named normal-val: ODMS's normal bins apply; travel 0.1 (n = 2) or 0.3 (n = 3)
    ex = [{"z": [d, d + 0.1] if i % 2 else [d, d + 0.15, d + 0.3], "areas": [100, 64, 49][: 2 + (i % 2 == 0)],
           "d1": d} for i, d in enumerate(DEPTHS)]
    store = make_store(tmp_path / "normal-val.zarr", "normal-val", ex, domain="normal")
    factors = np.array([1.1, 0.8, 1.05, 1.3, 0.9, 1.0])
    preds = tmp_path / "p.csv"
    rows = [f"normal-val,normal-val/{i:03d},{float(d * f)!r}" for i, (d, f) in enumerate(zip(DEPTHS, factors,
                                                                                              strict=True))]
    preds.write_text("\n".join([HEADER, *rows]) + "\n")
    js = _score_by(preds, store, "depth", "--allow-partial")
    groups = js["breakdown"]["groups"]
    edges = BENCHMARKS["odms"].depth_bins["normal"]
    names = [f"[{lo:g}, {hi:g}) m" for lo, hi in zip(edges[:-1], edges[1:], strict=True)]
    assert [g["group"] for g in groups] == names
    assert [g["n"] for g in groups] == [2, 1, 1, 1, 1]  # 0.12 and 0.18 share [0, 0.2)
    truth, pred = np.array(DEPTHS[:2]), np.array(DEPTHS[:2]) * factors[:2]
    first = score_split("normal-val", "normal", pred, truth, 2)
    assert groups[0]["mean_percent_error"] == first.mean_percent_error
    assert groups[0]["metrics"] == first.metrics
    motion = _score_by(preds, store, "motion", "--allow-partial")["breakdown"]["groups"]
    assert [(g["group"], g["n"]) for g in motion] == [("[0, 0.15) m", 3), ("[0.3, 0.4) m", 3)]
    nobs = _score_by(preds, store, "n-obs", "--allow-partial")["breakdown"]["groups"]
    assert [(g["group"], g["n"]) for g in nobs] == [("n = 2", 3), ("n = 3", 3)]
    split = js["splits"][0]
    weighted = sum(g["n"] * g["mean_percent_error"] for g in groups) / 6
    assert weighted == pytest.approx(split["mean_percent_error"])


def test_a_breakdown_shows_in_the_table_and_markdown(tmp_path):
    ex = [{"z": [d, d + 0.1], "areas": [100, 64], "d1": d} for d in DEPTHS]
    store = make_store(tmp_path / "mine.zarr", "mine", ex, domain="generated")
    preds = tmp_path / "p.csv"
    rows = [f"mine,mine/{i:03d},{d * 1.1!r}" for i, d in enumerate(DEPTHS)]
    preds.write_text("\n".join([HEADER, *rows]) + "\n")
    run = CliRunner().invoke
    text = run(main, ["score", str(preds), "--data", store, "--by", "window"]).stdout
    assert "by window:" in text and "2 frames" in text
    md = run(main, ["score", str(preds), "--data", store, "--by", "depth", "--markdown"]).stdout
    assert "| split | depth | n |" in md  # a store of no benchmark is cut at its quintiles
    assert len([line for line in md.splitlines() if line.startswith("| mine | [")]) == 5
    assert set(KEYS) == {"depth", "motion", "window", "object", "sequence", "n-obs"}


@pytest.fixture(scope="module")
def vosde_robot_driving(official_stores, tmp_path_factory):
    out = tmp_path_factory.mktemp("by") / "vosde.csv"
    stores = [str(official_stores[s]) for s in ("robot-test", "driving-test")]
    res = CliRunner().invoke(main, ["baseline", "vosde", *stores, "-o", str(out)])
    assert res.exit_code == 0, res.output
    return out, official_stores["robot-test"].parent


def test_official_robot_and_driving_groups(vosde_robot_driving):
    preds, data = vosde_robot_driving
    by = {k: _score_by(preds, data, k) for k in ("sequence", "object", "window")}
    count = {k: {} for k in by}
    for k, js in by.items():
        for g in js["breakdown"]["groups"]:
            count[k].setdefault(g["split"], []).append(g["n"])
    assert len(count["sequence"]["robot-test"]) == 48 and set(count["sequence"]["robot-test"]) == {55}
    assert len(count["sequence"]["driving-test"]) == 12 and sum(count["sequence"]["driving-test"]) == 750
    assert len(count["object"]["robot-test"]) == 24 and set(count["object"]["robot-test"]) == {110}
    assert count["window"]["robot-test"] == [21 * 48, 16 * 48, 11 * 48, 6 * 48, 48]  # 10, 15, ... 30 frames
    js = by["window"]
    robot = next(s for s in js["splits"] if s["split"] == "robot-test")
    lo, hi = robot["ci95"]["mean_percent_error"]
    assert lo < robot["mean_percent_error"] < hi
