"""`odms-data compare`: paired differences, their intervals and p-values, and refusals."""

from __future__ import annotations

import json

import numpy as np
import pytest
from _stores import make_store
from click.testing import CliRunner

from odms_data.cli import main
from odms_data.evaluation.bootstrap import cluster_codes, flip_statistics, p_value
from odms_data.evaluation.predictions import HEADER

DEPTHS = np.linspace(0.3, 2.0, 40)


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    root = tmp_path_factory.mktemp("compare")
    ex = [{"z": [d, d + 0.1], "areas": [100, 64], "d1": d} for d in DEPTHS]
    make_store(root / "sim.zarr", "sim", ex, domain="generated")  # each example alone
    return root


def _preds(path, factors, ids=None):
    ids = range(len(DEPTHS)) if ids is None else ids
    rows = [f"sim,sim/{i:03d},{float(DEPTHS[i] * f)!r}" for i, f in zip(ids, factors, strict=False)]
    path.write_text("\n".join([HEADER, *rows]) + "\n")
    return str(path)


def test_a_clearly_better_file_is_called_better_and_a_file_against_itself_is_a_tie(tmp_path, data):
    rng = np.random.default_rng(1)
    good = _preds(tmp_path / "good.csv", 1 + rng.normal(0, 0.02, len(DEPTHS)))
    bad = _preds(tmp_path / "bad.csv", 1 + rng.normal(0, 0.3, len(DEPTHS)))
    run = CliRunner().invoke
    res = run(main, ["compare", good, bad, "--data", str(data), "--json"])
    assert res.exit_code == 0, res.output
    js = json.loads(res.stdout)
    d = js["splits"][0]
    assert d["difference"] == pytest.approx(d["mean_a"] - d["mean_b"]) and d["difference"] < 0
    assert d["ci95"][1] < 0 and d["p_value"] < 0.001 and d["better"] == "A"
    assert d["clusters"] == len(DEPTHS)
    text = run(main, ["compare", good, bad, "--data", str(data)]).stdout
    assert f"{good} is better on sim" in text
    same = json.loads(run(main, ["compare", good, good, "--data", str(data), "--json"]).stdout)["splits"][0]
    assert (same["difference"], same["ci95"], same["p_value"], same["better"]) == (0.0, [0.0, 0.0], 1.0, None)
    assert "cannot tell them apart on sim" in run(main, ["compare", good, good, "--data", str(data)]).stdout


def test_two_files_of_other_examples_are_refused_in_one_line(tmp_path, data):
    full = _preds(tmp_path / "full.csv", np.ones(len(DEPTHS)))
    part = _preds(tmp_path / "part.csv", np.ones(10), ids=range(10))
    res = CliRunner().invoke(main, ["compare", full, part, "--data", str(data)])
    assert res.exit_code == 2 and len(res.output.strip().splitlines()) == 1, res.output


def test_the_sign_flip_p_value_by_hand():
    # three clusters summing to 3, 1, -1 over 3 examples: flipped sums are +-5, +-3, +-3, +-1, so
    # the observed mean 1 (sum 3) is reached or passed by 6 of the 8 sign patterns
    diffs = np.array([3.0, 1.0, -1.0])
    flips = flip_statistics(diffs, cluster_codes(["a", "b", "c"]), "x")
    assert set(np.round(flips * 3).astype(int)) <= {5, 3, 1, -1, -3, -5}
    share = np.mean(np.abs(flips) >= 1 - 1e-12)
    assert share == pytest.approx(0.75, abs=0.02)
    assert p_value(1.0, flips) == pytest.approx((1 + share * len(flips)) / (len(flips) + 1))
