"""`odms-data import odmd`: ODMD-like pickles into stores of boxes that validate, score and run
Box_LS; malformed sets refused in one line; ODMD's own sets (when on this machine) match their
manifests and give ODMD's published Box_LS row."""

from __future__ import annotations

import json
import pickle
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from odms_data.cli import main
from odms_data.cli.import_commands import odmd as odmd_command
from odms_data.importers.odmd import ODMD_SETS
from odms_data.protocol import BENCHMARKS
from odms_data.store.reader import open_store

PUBLISHED_TEST = {"odmd-normal-test": 0.00, "odmd-perturb-motion-test": 4.47,
                  "odmd-perturb-detection-test": 21.60, "odmd-robot-test": 21.23}  # ODMD README, Box_LS


def _odmd_like(E: int = 5, P: int = 10, seed: int = 0) -> dict:
    """A set as ODMD pickles one: boxes of size c / depth, far to near, camera moving in x, y, z."""
    rng = np.random.default_rng(seed)
    cm = np.zeros((P - 1, 3, E))
    cm[:, :2] = rng.uniform(-0.1, 0.1, (P - 1, 2, E))
    cm[:, 2] = -np.linspace(1.0, 0.1, P - 1)[:, None]
    last = rng.uniform(0.5, 2.0, E)
    depth = np.vstack([last - cm[:, 2], last])  # (P, E)
    bb = np.zeros((P, 5, E))
    bb[:, 0] = bb[:, 1] = 0.5
    bb[:, 2], bb[:, 3], bb[:, 4] = 0.1 / depth, 0.07 / depth, depth
    return {"bb": {"bboxes": bb, "n_positions": P, "n_ex": E, "image_dim": [480, 640]},
            "bb_3D": {"camera_movement": cm, "n_ex": E, "n_positions": P}}


def _data(tmp_path, sets: dict[str, dict]) -> Path:
    root = tmp_path / "data"
    for split, obj in sets.items():
        p = root / ODMD_SETS[split][0]
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(pickle.dumps(obj, protocol=3))
    return root


def test_an_odmd_like_set_becomes_a_store_of_boxes_that_box_ls_solves_exactly(tmp_path, monkeypatch):
    # a set named like none of splits/ is not checked against a manifest: import it under its own name
    monkeypatch.setitem(ODMD_SETS, "mine-val", ("odmd/val/val_mine.pk", "odmd"))
    # --set's choices were copied from ODMD_SETS when the command was first imported
    option = next(p for p in odmd_command.params if p.name == "sets")
    monkeypatch.setattr(option.type, "choices", (*option.type.choices, "mine-val"))
    data = _data(tmp_path, {"mine-val": _odmd_like()})
    run = CliRunner()
    res = run.invoke(main, ["import", "odmd", str(data), "-o", str(tmp_path / "out"), "--set", "mine-val",
                            "--json"])
    assert res.exit_code == 0, res.output
    store = json.loads(res.stdout[res.stdout.index("{"):])["stores"][0]["path"]
    with open_store(store) as s:
        assert s.kind == "boxes" and s.n_examples == 5 and s.example_ids[0] == "mine-val/00000"
        np.testing.assert_array_equal(s.move[9], 0.0)  # the last frame of example 0
    assert run.invoke(main, ["validate", store]).exit_code == 0
    out = tmp_path / "p.csv"
    res = run.invoke(main, ["baseline", "box-ls", store, "-o", str(out)])
    assert res.exit_code == 0, res.output
    res = run.invoke(main, ["score", str(out), "--data", str(tmp_path / "out"), "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout)["splits"][0]["mean_percent_error"] == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize(("broken", "message"), [
    (lambda d: d["bb"].update(bboxes=np.zeros((10, 4, 5))), "'bb.bboxes' has shape (10, 4, 5)"),
    (lambda d: d["bb_3D"].update(camera_movement=np.zeros((10, 3, 5))), "expected (9, 3, 5)"),
    (lambda d: d["bb"].update(image_dim="big"), "'bb.image_dim'"),
    (lambda d: d.pop("bb_3D"), "'bb_3D.camera_movement' is not a 3-D numeric array"),
])
def test_a_malformed_set_is_refused_in_one_line_and_nothing_is_written(tmp_path, broken, message):
    obj = _odmd_like()
    broken(obj)
    data = _data(tmp_path, {"odmd-normal-val": obj})
    res = CliRunner().invoke(main, ["import", "odmd", str(data), "-o", str(tmp_path / "out"),
                                    "--set", "odmd-normal-val"])
    assert res.exit_code == 2 and message in res.output and res.output.count("\n") == 1, res.output
    assert not list((tmp_path / "out").glob("*")) if (tmp_path / "out").exists() else True


def test_a_set_that_differs_from_its_manifest_is_refused(tmp_path):
    data = _data(tmp_path, {"odmd-normal-val": _odmd_like()})
    res = CliRunner().invoke(main, ["import", "odmd", str(data), "-o", str(tmp_path / "out"),
                                    "--set", "odmd-normal-val"])
    assert res.exit_code != 0 and "does not match split 'odmd-normal-val'" in res.output, res.output
    assert not (tmp_path / "out" / "odmd-normal-val.zarr").exists()


def test_odmds_test_sets_import_verified_and_give_the_published_box_ls(tmp_path, odmd_data):
    data, run = odmd_data, CliRunner()
    args = [a for s in PUBLISHED_TEST for a in ("--set", s)]
    res = run.invoke(main, ["import", "odmd", str(data), "-o", str(tmp_path / "s"), *args])
    assert res.exit_code == 0, res.output
    got = {}
    for split in PUBLISHED_TEST:
        out = str(tmp_path / f"{split}.csv")
        res = run.invoke(main, ["baseline", "box-ls", str(tmp_path / "s" / f"{split}.zarr"), "-o", out])
        assert res.exit_code == 0, res.output
        res = run.invoke(main, ["score", out, "--data", str(tmp_path / "s"), "--json"])
        assert res.exit_code == 0, res.output
        got[split] = json.loads(res.stdout)["splits"][0]["mean_percent_error"]
    assert {s: round(v, 2) for s, v in got.items()} == PUBLISHED_TEST
    assert round(sum(got.values()) / 4, 2) == 11.83
    # all four at once: score gives ODMD's All, the mean of the unrounded per-set means (published
    # 11.83, the mean of the rounded figures)
    stores = [str(tmp_path / "s" / f"{split}.zarr") for split in PUBLISHED_TEST]
    res = run.invoke(main, ["baseline", "box-ls", *stores, "-o", str(tmp_path / "all.csv")])
    assert res.exit_code == 0, res.output
    res = run.invoke(main, ["score", str(tmp_path / "all.csv"), "--data", str(tmp_path / "s"), "--json"])
    alls = json.loads(res.stdout)["benchmark_alls"]
    assert [(a["benchmark"], a["family"]) for a in alls] == [("odmd", "test")]
    value = alls[0]["mean_percent_error"]
    assert value == pytest.approx(sum(got.values()) / 4, abs=1e-12) and abs(value - 11.83) < 0.01
    assert alls[0]["splits"] == list(BENCHMARKS["odmd"].splits("test"))
    res = run.invoke(main, ["score", str(tmp_path / "all.csv"), "--data", str(tmp_path / "s")])
    assert f"ODMD All (test) = {value:.2f}" in res.output, res.output
