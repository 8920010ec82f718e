"""`odms-data train` and `odms-data predict` as users run them: a tiny run end to end (train ->
predict -> score), an interrupted run resumed, and bad input."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import torch
from click.testing import CliRunner

from odms_data.cli import main
from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import GeneratorParams

SMALL = GeneratorParams(image_size=(120, 160), sizes=(30, 60, 90))


def odms(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "odms_data.cli", *args], capture_output=True, text=True)


def rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def val_store(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("val") / "tiny-val.zarr"
    generate(str(path), 12, SMALL, seed=11, split="tiny-val", workers=1)
    return path


def test_train_predict_score(tmp_path, val_store):
    run = tmp_path / "run"
    r = odms("train", "--model", "odn-l", "--radial", "-o", str(run), "--val", str(val_store),
             "--iterations", "3", "--batch-size", "2", "--val-every", "2", "--workers", "1", "--seed", "4")
    assert r.returncode == 0, r.stderr
    assert "it/s" in r.stderr and "ex/s" in r.stderr and "on cpu" in r.stderr
    files = ["best-tiny-val.pt", "best.pt", "config.json", "curves.csv", "curves.png", "last.pt"]
    assert sorted(p.name for p in run.iterdir()) == files
    c = json.loads((run / "config.json").read_text())["config"]
    assert (c["model"], c["radial"], c["lr"], c["val"]) == ("odn-l", True, 0.001, [str(val_store)])
    curve = rows(run / "curves.csv")
    assert [(int(c["iteration"]), c["set"]) for c in curve] == [
        (1, "train"), (2, "train"), (2, "tiny-val"), (2, "val"), (3, "train"), (3, "tiny-val"), (3, "val")]
    assert (run / "curves.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    best = torch.load(run / "best.pt", weights_only=True)
    lowest = min(float(c["percent_error"]) for c in curve if c["set"] == "val")
    assert best["percent_error"] == pytest.approx(lowest, rel=1e-5)

    preds = tmp_path / "preds.csv"
    r = CliRunner().invoke(main, ["predict", str(run), "--data", str(val_store), "-o", str(preds),
                                  "--workers", "0"])
    assert r.exit_code == 0, r.output
    got = rows(preds)
    assert len(got) == 12 and got[0]["example_id"] == "tiny-val/000000" and float(got[0]["d1"]) != 0
    r = CliRunner().invoke(main, ["score", str(preds), "--data", str(val_store), "--json"])
    assert r.exit_code == 0, r.output
    scored = json.loads(r.stdout)["splits"][0]["mean_percent_error"]
    assert scored == pytest.approx(best["percent_error"], rel=1e-5)  # predict = training's validation


def _train(run: Path, val_store: Path) -> list[str]:
    return ["train", "--model", "odn-d", "-o", str(run), "--val", str(val_store), "--iterations", "6",
            "--batch-size", "2", "--val-every", "2", "--workers", "0", "--seed", "9"]


ONE_THREAD = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}


def _train_process(run: Path, val_store: Path) -> subprocess.Popen:
    """`train` in its own process on one thread: a float sum's order then depends on nothing but
    the code (in-process, torch's threads are whatever earlier tests and the load left)."""
    return subprocess.Popen([sys.executable, "-m", "odms_data.cli", *_train(run, val_store)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, **ONE_THREAD},
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))  # as in a
    # terminal, also when this test runs in the background, where a shell has SIGINT ignored


def test_an_interrupted_run_resumes_where_it_stopped(tmp_path, val_store):
    straight = tmp_path / "straight"
    p = _train_process(straight, val_store)
    _, err = p.communicate(timeout=300)
    assert p.returncode == 0, err

    run = tmp_path / "run"
    p = _train_process(run, val_store)
    deadline = time.monotonic() + 120
    while not (run / "last.pt").exists() and p.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert "rerun the same command to resume" in err
    stopped = torch.load(run / "last.pt", weights_only=True)["iteration"]
    assert 2 <= stopped < 6

    p = _train_process(run, val_store)
    _, err = p.communicate(timeout=300)
    assert p.returncode == 0, err
    assert f"resuming from iteration {stopped}" in err
    # the same batches, Adam state and random state: the same curve, bit for bit
    def curve(path: Path) -> list[tuple[str, ...]]:
        return [(c["iteration"], c["set"], c["loss"], c["percent_error"]) for c in rows(path / "curves.csv")]
    assert curve(run) == curve(straight), f"stopped at {stopped}"
    assert torch.load(run / "last.pt", weights_only=True)["iteration"] == 6

    again = CliRunner().invoke(main, _train(run, val_store))
    assert again.exit_code == 0 and "the run is complete (6 iterations)" in again.stdout


def _fails(args: list[str], *fragments: str) -> None:
    r = CliRunner().invoke(main, args)
    lines = r.stderr.strip().splitlines()
    assert r.exit_code == 2 and len(lines) == 1 and lines[0].startswith("odms-data: error: "), r.stderr
    for f in fragments:
        assert f in lines[0], lines[0]


def test_bad_input(tmp_path, val_store):
    run = tmp_path / "run"
    base = ["train", "-o", str(run), "--iterations", "1", "--batch-size", "2", "--workers", "0"]
    _fails([*base, "--val", str(tmp_path / "none.zarr")], "none.zarr")
    _fails([*base, "--val", str(val_store), "--n-obs", "11"], "tiny-val.zarr", "n_obs=11", "10 frames")
    _fails([*base, "--val", str(val_store), "--device", "gpu0"], "'gpu0' is not a device name")
    _fails([*base, "--val", str(val_store), "--seed", "20200002"], "20200002", "sim-test")
    named_val = tmp_path / "v.zarr"
    generate(str(named_val), 2, SMALL, seed=1, split="val", workers=1)
    _fails([*base, "--val", str(named_val)], "v.zarr", "none named train or val")
    assert not run.exists()  # nothing written before the input was found good
    (tmp_path / "notes").mkdir()
    (tmp_path / "notes" / "mine.txt").write_text("keep")
    _fails(["train", "-o", str(tmp_path / "notes"), "--val", str(val_store)], "holds no training run")

    assert CliRunner().invoke(main, [*base, "--val", str(val_store)]).exit_code == 0
    _fails([*base, "--val", str(val_store), "--lr", "0.01"], "another configuration",
           "lr 0.001 here, 0.01 asked")
    preds, other = tmp_path / "p.csv", tmp_path / "q.csv"
    preds.write_text("mine")
    predict = ["predict", "--data", str(val_store), "--workers", "0"]
    _fails([*predict, str(run), "-o", str(preds)], "p.csv: already exists")
    assert preds.read_text() == "mine"
    _fails([*predict, str(tmp_path / "notes"), "-o", str(other)], "not a training run")
    config = run / "config.json"
    config.write_text(config.read_text().replace('"radial": false', '"radial": true'))
    _fails([*predict, str(run), "-o", str(other)], "best.pt: its weights do not fit", "radial True")
    (run / "best.pt").write_bytes(b"not a checkpoint")
    _fails([*predict, str(run), "-o", str(other)], "best.pt: not a readable")
    assert not other.exists()


def test_per_set_checkpoints_predict_their_own_domain(tmp_path, val_store):
    """Each validation set keeps its own best checkpoint, and --checkpoint per-set predicts each
    store with the one of its domain (the authors' choice for Table 1)."""
    other = tmp_path / "other-val.zarr"
    generate(str(other), 12, SMALL, seed=12, split="other-val", workers=1)
    run = tmp_path / "run"
    r = CliRunner().invoke(main, ["train", "--model", "odn-d", "-o", str(run), "--val", str(val_store),
                                  "--val", str(other), "--iterations", "5", "--batch-size", "2",
                                  "--val-every", "1", "--workers", "0", "--seed", "6"])
    assert r.exit_code == 0, r.output
    curve = rows(run / "curves.csv")
    scores = {}
    for split in ("tiny-val", "other-val"):
        errors = {int(c["iteration"]): float(c["percent_error"]) for c in curve if c["set"] == split}
        saved = torch.load(run / f"best-{split}.pt", weights_only=True)
        assert saved["iteration"] == min(errors, key=errors.__getitem__)
        scores[split] = saved["percent_error"]
        assert scores[split] == pytest.approx(min(errors.values()), rel=1e-5)
    test = tmp_path / "tiny-test.zarr"  # the tiny domain's test set: predicted by best-tiny-val.pt
    generate(str(test), 12, SMALL, seed=11, split="tiny-test", workers=1)  # tiny-val's examples

    preds = tmp_path / "p.csv"
    r = CliRunner().invoke(main, ["predict", str(run), "--data", str(val_store), "--data", str(other),
                                  "--data", str(test), "--checkpoint", "per-set", "-o", str(preds),
                                  "--workers", "0"])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(main, ["score", str(preds), "--data", str(val_store), "--data", str(other),
                                  "--data", str(test), "--json"])
    assert r.exit_code == 0, r.output
    got = {s["split"]: s["mean_percent_error"] for s in json.loads(r.stdout)["splits"]}
    assert got == pytest.approx({**scores, "tiny-test": scores["tiny-val"]}, rel=1e-5)

    lone = tmp_path / "lone-test.zarr"
    generate(str(lone), 2, SMALL, seed=13, split="lone-test", workers=1)
    _fails(["predict", str(run), "--data", str(lone), "--checkpoint", "per-set",
            "-o", str(tmp_path / "q.csv")], "lone-test's own validation set", "other-val, tiny-val")
    assert not (tmp_path / "q.csv").exists()
