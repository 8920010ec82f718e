"""The depth metrics against a hand-computed case, and the cluster-bootstrap intervals."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from _stores import make_store
from click.testing import CliRunner

from odms_data.cli import main
from odms_data.evaluation.bootstrap import RESAMPLES, cluster_codes, interval, resampled_means
from odms_data.evaluation.ground_truth import SplitTruth
from odms_data.evaluation.metrics import METRICS, depth_metrics, score_split
from odms_data.evaluation.predictions import HEADER
from odms_data.evaluation.scoring import sequence_codes
from odms_data.protocol import object_of, sequence_of


def test_every_metric_against_a_hand_computed_case():
    truth, pred = np.array([1.0, 2.0, 4.0, 0.5]), np.array([1.08, 1.5, 4.0, -0.5])
    # errors 0.08, 0.5, 0, 1.0; percent errors 8, 25, 0, 200; -0.5 counts as 1 mm in logs and ratios
    m = depth_metrics(pred, truth)
    assert m["abs_rel"] == pytest.approx((0.08 + 0.25 + 0 + 2.0) / 4)
    assert m["sq_rel"] == pytest.approx((0.0064 / 1 + 0.25 / 2 + 0 + 1.0 / 0.5) / 4)
    assert m["rmse"] == pytest.approx(math.sqrt((0.0064 + 0.25 + 0 + 1.0) / 4))
    logs = [math.log(1 / 1.08), math.log(2 / 1.5), 0.0, math.log(0.5 / 0.001)]
    assert m["rmse_log"] == pytest.approx(math.sqrt(sum(x * x for x in logs) / 4))
    # ratios 1.08, 1.33, 1, 500 against 1.25, 1.5625, 1.953
    assert (m["delta1"], m["delta2"], m["delta3"]) == (0.5, 0.75, 0.75)
    assert (m["within_5"], m["within_10"], m["within_25"]) == (0.25, 0.5, 0.75)  # 25 % is within 25 %
    # sorted 0, 8, 25, 200: the 90th percentile at position 2.7, the 95th at 2.85
    assert m["p90_percent"] == pytest.approx(25 + 0.7 * 175)
    assert m["p95_percent"] == pytest.approx(25 + 0.85 * 175)
    assert list(m) == list(METRICS)


def test_absrel_is_the_mean_percent_error_over_100():
    rng = np.random.default_rng(3)
    truth = rng.uniform(0.1, 60, 500)
    s = score_split("driving-test", "driving", truth * rng.lognormal(0, 0.4, 500), truth, 500)
    assert s.metrics["abs_rel"] == pytest.approx(s.mean_percent_error / 100, rel=1e-12)


def test_an_interval_resamples_whole_sequences():
    # two sequences of five examples, errors 0 and 10: a resample draws each sequence whole, so
    # every resampled mean is 0, 5 or 10; alone, examples give the eleven means between
    terms = np.repeat([0.0, 10.0], 5)[None, :]
    clustered = resampled_means(terms, cluster_codes(["a"] * 5 + ["b"] * 5), "x")
    assert clustered.shape == (1, RESAMPLES) and set(np.unique(clustered)) == {0.0, 5.0, 10.0}
    alone = resampled_means(terms, cluster_codes([None] * 10), "x")
    assert len(np.unique(alone)) > 3
    lo, hi = interval(clustered[0])
    assert (lo, hi) == (0.0, 10.0) and interval(alone[0])[1] - interval(alone[0])[0] < hi - lo


def test_intervals_are_seeded_by_the_split():
    rng = np.random.default_rng(0)
    terms = rng.normal(size=(2, 300))
    codes = cluster_codes([str(i // 3) for i in range(300)])
    first = resampled_means(terms, codes, "robot-test")
    assert np.array_equal(first, resampled_means(terms, codes, "robot-test"))
    assert not np.array_equal(first, resampled_means(terms, codes, "robot-val"))


def test_sequences_and_objects_follow_the_records():
    approach = "test/robot/foam_brick_clutter"
    assert sequence_of("robot-test", "robot", approach) == approach
    assert object_of("robot-test", "robot", "test/robot/foam_brick_clutter") == "foam_brick"
    seq = sequence_of("driving-val", "driving", "val/driving/SYNTHIA-SEQS-01-DAWN_309_10_3")
    assert seq == "val/driving/SYNTHIA-SEQS-01-DAWN"
    assert sequence_of("sim-val", "generated", "odms-data generator") is None
    assert sequence_of("my-rec", "recording", "") is None and sequence_of("my-rec", "recording", "r1") == "r1"
    truth = SplitTruth("sim-val", "generated", "", "", ["sim-val/0", "sim-val/1"], np.ones(2), ["g", "g"])
    assert sequence_codes(truth, np.arange(2)).tolist() == [0, 1]  # generated: each alone


def test_score_json_gives_metrics_and_intervals_and_the_table_shows_them(tmp_path):
    ex = [{"z": [d, d + 0.1], "areas": [100, 64], "d1": d} for d in (0.5, 1.0, 1.5, 2.0)]
    make_store(tmp_path / "s.zarr", "mine", ex, domain="generated")  # each example alone
    preds = tmp_path / "p.csv"
    pairs = zip((0.5, 1.0, 1.5, 2.0), (1.1, 0.9, 1.0, 1.2), strict=True)
    rows = [f"mine,mine/{i:03d},{d * f!r}" for i, (d, f) in enumerate(pairs)]
    preds.write_text("\n".join([HEADER, *rows]) + "\n")
    run = CliRunner().invoke
    js = json.loads(run(main, ["score", str(preds), "--data", str(tmp_path / "s.zarr"), "--json"]).stdout)
    split = js["splits"][0]
    assert split["metrics"]["abs_rel"] == pytest.approx(0.1)
    assert split["mean_percent_error"] == pytest.approx(10)
    lo, hi = split["ci95"]["mean_percent_error"]
    assert 0 <= lo < 10 < hi <= 20 and js["intervals"]["resamples"] == RESAMPLES
    plain = run(main, ["score", str(preds), "--data", str(tmp_path / "s.zarr")]).stdout
    shown = run(main, ["score", str(preds), "--data", str(tmp_path / "s.zarr"), "--metrics", "--ci"]).stdout
    assert "AbsRel" not in plain and "95% CI" not in plain
    assert "AbsRel" in shown and f"[{lo:.2f}, {hi:.2f}]" in shown and "0.100" in shown
    md = run(main, ["score", str(preds), "--data", str(tmp_path / "s.zarr"), "--markdown", "--metrics"])
    assert "| AbsRel |" in md.stdout
    make_store(tmp_path / "one.zarr", "mine", ex, domain="recording")  # one recorded sequence: no interval
    js = json.loads(run(main, ["score", str(preds), "--data", str(tmp_path / "one.zarr"), "--json"]).stdout)
    assert js["splits"][0]["ci95"] == {}
    assert js["splits"][0]["mean_percent_error"] == split["mean_percent_error"]
