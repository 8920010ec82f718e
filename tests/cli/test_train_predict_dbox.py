"""`odms-data train --model dbox` and `predict` with DBox, as users run them: a tiny run on the
generated box stream validated on a store of masks through the box rule, a stopped run resumed,
a weights file (as ODMD's pretrained DBox) predicting a store, and bad input."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
import torch
from click.testing import CliRunner

from odms_data.cli import main
from odms_data.loaders.box_transform import BoxTransform
from odms_data.loaders.sources import StoreExamples
from odms_data.network.dbox import DBox
from odms_data.network.run_folder import TrainConfig
from odms_data.network.training import train
from odms_data.simulate.generate_box_store import generate_box_store
from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import GeneratorParams

SMALL = GeneratorParams(image_size=(120, 160), sizes=(30, 60, 90))


def rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def val_store(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("val") / "tiny-val.zarr"
    generate(str(path), 12, SMALL, seed=11, split="tiny-val", workers=1)
    return path


def _train_args(run: Path, val_store: Path, *more: str) -> list[str]:
    return ["train", "--model", "dbox", "-o", str(run), "--val", str(val_store), "--iterations", "4",
            "--batch-size", "8", "--val-every", "2", "--workers", "0", "--seed", "3", *more]


def test_train_predict_score(tmp_path, val_store):
    run = tmp_path / "run"
    r = CliRunner().invoke(main, _train_args(run, val_store, "--json"))
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    c = out["config"]
    assert (c["model"], c["preset"], c["lr"], c["radial"]) == ("dbox", "odmd", 0.001, False)  # the recipe's
    assert out["iteration"] == 4 and out["best_iteration"] in (2, 4)
    assert sorted(p.name for p in run.iterdir() if p.suffix in (".pt", ".csv", ".json")) == [
        "best-tiny-val.pt", "best.pt", "config.json", "curves.csv", "last.pt"]
    curve = rows(run / "curves.csv")
    assert [(int(c["iteration"]), c["set"]) for c in curve] == [
        (1, "train"), (2, "train"), (2, "tiny-val"), (2, "val"), (3, "train"), (4, "train"), (4, "tiny-val"),
        (4, "val")]
    best = torch.load(run / "best.pt", weights_only=True)
    assert set(best["model"]) == set(DBox().state_dict())

    preds = tmp_path / "preds.csv"
    r = CliRunner().invoke(main, ["predict", str(run), "--data", str(val_store), "-o", str(preds),
                                  "--workers", "0", "--json"])
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["model"] == "dbox"
    got = rows(preds)
    assert len(got) == 12 and all(float(g["d1"]) != 0 for g in got)
    r = CliRunner().invoke(main, ["score", str(preds), "--data", str(val_store), "--json"])
    assert r.exit_code == 0, r.output
    scored = json.loads(r.stdout)["splits"][0]["mean_percent_error"]
    assert scored == pytest.approx(best["percent_error"], rel=1e-5)  # predict = training's validation


class _Stop(KeyboardInterrupt):
    pass


def test_a_stopped_run_resumes_with_the_same_batches(tmp_path, val_store):
    config = TrainConfig.recipe("dbox", iterations=6, batch_size=8, val_every=2, seed=5,
                                val=(str(val_store),))
    train(tmp_path / "straight", config)

    def stop_after_4(s):
        if s.iteration == 4:
            raise _Stop

    with pytest.raises(_Stop):
        train(tmp_path / "run", config, report=stop_after_4)
    assert torch.load(tmp_path / "run" / "last.pt", weights_only=True)["iteration"] == 4
    resumed = train(tmp_path / "run", config)
    assert resumed.started_at == 4 and resumed.iteration == 6
    a, b = rows(tmp_path / "straight" / "curves.csv"), rows(tmp_path / "run" / "curves.csv")
    assert [(r["iteration"], r["set"]) for r in a] == [(r["iteration"], r["set"]) for r in b]
    assert [float(r["loss"]) for r in b] == pytest.approx([float(r["loss"]) for r in a], rel=1e-4)


def test_a_stop_returned_as_another_error_keeps_the_run_to_resume(tmp_path, val_store):
    """A stop that a C extension turned into another error (a SystemError caused by it) is still
    a stop: the run folder stays, to resume, where a failure removes the folder it made."""
    from odms_data.errors import Interrupted

    config = TrainConfig.recipe("dbox", iterations=4, batch_size=8, val_every=2, val=(str(val_store),))

    def stopped_inside_an_extension(s):
        if s.iteration == 2:
            raise SystemError("returned a result with an exception set") from Interrupted(2)

    with pytest.raises(SystemError):
        train(tmp_path / "run", config, report=stopped_inside_an_extension)
    assert torch.load(tmp_path / "run" / "last.pt", weights_only=True)["iteration"] == 2
    assert train(tmp_path / "run", config).started_at == 2


def test_training_leaves_the_callers_random_state_alone(tmp_path, val_store):
    """train seeds PyTorch from its config, and the caller's global random state is as it was."""
    config = TrainConfig.recipe("dbox", iterations=2, batch_size=8, val_every=2, val=(str(val_store),))
    torch.manual_seed(1234)
    expected = torch.rand(3)
    torch.manual_seed(1234)
    train(tmp_path / "run", config)
    assert torch.equal(torch.rand(3), expected)


def _predict_direct(weights: dict, store: Path, normalized: bool = True) -> np.ndarray:
    """Depths of every example of `store` from DBox with `weights`, computed here without predict."""
    examples = StoreExamples(str(store), BoxTransform(normalized=normalized, relative=normalized))
    b = examples.batch(np.arange(len(examples)))
    net = DBox()
    net.load_state_dict(weights)
    with torch.no_grad():
        out = net(torch.from_numpy(b["inputs"])).double().numpy()
    return out * b["norm"]


def test_a_weights_file_predicts_a_store(tmp_path, val_store):
    torch.manual_seed(1)
    weights = DBox().state_dict()
    path = tmp_path / "weights.pt"
    torch.save(weights, path)
    preds = tmp_path / "p.csv"
    r = CliRunner().invoke(main, ["predict", "--model", "dbox", "--checkpoint", str(path), "--data",
                                  str(val_store), "-o", str(preds), "--workers", "0"])
    assert r.exit_code == 0, r.output
    got = [float(g["d1"]) for g in rows(preds)]
    assert got == pytest.approx(_predict_direct(weights, val_store).tolist(), rel=1e-6)
    note = r.stdout.strip().splitlines()[-1]  # the run says how a store of masks was read
    assert note.startswith("tiny-val: stores of masks, read as boxes") and "its own camera movement" in note


def test_predict_says_which_stores_of_masks_dbox_read_as_boxes(tmp_path, val_store):
    boxes = tmp_path / "boxes.zarr"
    generate_box_store(str(boxes), 5, "odmd", 1, split="boxes-val")
    path = tmp_path / "weights.pt"
    torch.save(DBox().state_dict(), path)
    for data, want in (([val_store, boxes], ["tiny-val"]), ([boxes], None)):
        args = ["predict", "--model", "dbox", "--checkpoint", str(path), "-o", str(tmp_path / "p.csv"),
                "--workers", "0", "--json", "--overwrite"]
        r = CliRunner().invoke(main, [*args, *(a for d in data for a in ("--data", str(d)))])
        assert r.exit_code == 0, r.output
        assert json.loads(r.stdout).get("masks_read_as_boxes") == want


def test_the_authors_pretrained_dbox_predicts_a_store(tmp_path, val_store, odmd_pretrained):
    preds = tmp_path / "p.csv"
    r = CliRunner().invoke(main, ["predict", "--model", "dbox", "--checkpoint", str(odmd_pretrained),
                                  "--data", str(val_store), "-o", str(preds), "--workers", "0", "--json"])
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["predictions"] == 12
    got = [float(g["d1"]) for g in rows(preds)]
    want = _predict_direct(torch.load(odmd_pretrained, map_location="cpu", weights_only=True), val_store)
    assert got == pytest.approx(want.tolist(), rel=1e-6)


def _fails(args: list[str], *fragments: str) -> None:
    r = CliRunner().invoke(main, args)
    lines = r.stderr.strip().splitlines()
    assert r.exit_code == 2 and len(lines) == 1 and lines[0].startswith("odms-data: error: "), r.stderr
    for f in fragments:
        assert f in lines[0], lines[0]


def test_bad_input(tmp_path, val_store):
    run = tmp_path / "run"
    _fails(_train_args(run, val_store, "--radial"), "dbox takes no radial image")
    _fails(_train_args(run, val_store, "--preset", "standard"), "preset 'standard'", "odmd")
    _fails(["train", "--model", "odn-l", "-o", str(run), "--val", str(val_store), "--preset", "odmd"],
           "preset 'odmd'", "standard")
    _fails(_train_args(run, val_store, "--n-obs", "11"), "n_obs=11")
    assert not run.exists()

    out = tmp_path / "p.csv"
    data = ["--data", str(val_store), "-o", str(out), "--workers", "0"]
    weights = tmp_path / "w.pt"
    torch.save(DBox().state_dict(), weights)
    _fails(["predict", "--checkpoint", str(weights), *data], "needs --model")
    _fails(["predict", str(tmp_path), "--model", "dbox", *data], "--model goes with --checkpoint FILE")
    _fails(["predict", *data], "give the RUN folder")
    _fails(["predict", "--model", "odn-l", "--checkpoint", str(weights), *data],
           "odn-l predicts from a training run's folder")
    _fails(["predict", "--model", "dbox", "--checkpoint", str(tmp_path / "none.pt"), *data], "none.pt")
    torch.save({"W": torch.zeros(3)}, weights)
    _fails(["predict", "--model", "dbox", "--checkpoint", str(weights), *data], "w.pt", "not DBox's")
    (tmp_path / "junk.pt").write_bytes(b"junk")
    _fails(["predict", "--model", "dbox", "--checkpoint", str(tmp_path / "junk.pt"), *data], "junk.pt")
    sparse = {k: t.to_sparse() for k, t in DBox().state_dict().items()}  # DBox's names and shapes
    torch.save(sparse, weights)
    _fails(["predict", "--model", "dbox", "--checkpoint", str(weights), *data], "w.pt", "refused",
           "_rebuild_sparse_tensor")  # was exit 3
    assert not out.exists()
