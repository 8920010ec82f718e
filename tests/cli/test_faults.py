"""Fault injection: kill -9 at random moments, and two writers on one store."""

import os
import random
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import PRESETS
from odms_data.store.manifests import load_manifest
from odms_data.store.reader import open_store
from odms_data.store.validate import validate

KILLS = 20


def start(*args: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "odms_data.cli", *args],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def kill_at_random_moments(args: list[str], out: Path, expected_digest: str, seed: int) -> None:
    """Kill the command KILLS times at random moments; the output must never look complete
    unless it is, and a final run must finish with the expected digest."""
    rng = random.Random(seed)
    completed_before_kill = 0
    for _ in range(KILLS):
        with start(*args, "--overwrite") as proc:  # its stderr pipe closed, as it waits for it
            time.sleep(rng.uniform(0.0, 2.5))
            os.kill(proc.pid, signal.SIGKILL)
        if out.exists():
            # the rename into place is the last step: whatever is there is a whole store
            report = validate(str(out))
            assert report.ok and report.digest == expected_digest, report.problems
            completed_before_kill += 1
            shutil.rmtree(out) if out.is_dir() else out.unlink()  # the next check is about the next run
        else:
            assert not validate(str(out)).ok
    final = subprocess.run([sys.executable, "-m", "odms_data.cli", *args, "--overwrite"],
                           capture_output=True, text=True)
    assert final.returncode == 0, final.stderr
    assert open_store(str(out)).attrs.digest == expected_digest
    assert not Path(str(out) + ".partial").exists() and not Path(str(out) + ".lock").exists()
    assert completed_before_kill < KILLS  # the kills did land mid-write


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> tuple[Path, str]:
    path = tmp_path_factory.mktemp("ref") / "ref.zarr"
    attrs = generate(str(path), 600, PRESETS["perturb"], 21, examples_per_shard=40)
    return path, attrs.digest


def test_generate_survives_kill_9(tmp_path, reference):
    out = tmp_path / "gen.zarr"
    args = ["generate", "-n", "600", "--preset", "perturb", "--seed", "21", "-o", str(out),
            "--workers", "1", "--examples-per-shard", "40"]
    kill_at_random_moments(args, out, reference[1], seed=1)


def test_convert_survives_kill_9(tmp_path, reference):
    out = tmp_path / "conv.h5"
    kill_at_random_moments(["convert", str(reference[0]), str(out)], out, reference[1], seed=2)


def test_second_writer_is_refused(tmp_path):
    out = tmp_path / "busy.zarr"
    with start("generate", "-n", "5000", "-o", str(out), "--workers", "1") as first:
        lock = Path(str(out) + ".lock")
        deadline = time.monotonic() + 60
        while not lock.exists() and time.monotonic() < deadline:
            time.sleep(0.05)
        second = subprocess.run([sys.executable, "-m", "odms_data.cli", "generate", "-n", "5", "-o",
                                 str(out)], capture_output=True, text=True)
        first.kill()
    assert second.returncode == 2
    assert f"another odms-data process (pid {first.pid}) is writing this store" in second.stderr
    assert len(second.stderr.strip().splitlines()) == 1


def test_import_survives_kill_9(tmp_path, official_data_dir):
    out_dir = tmp_path / "stores"
    expected = load_manifest("robot-val").digest
    args = ["import", "odms", str(official_data_dir), "--split", "robot-val", "-o", str(out_dir),
            "--workers", "1"]
    kill_at_random_moments(args, out_dir / "robot-val.zarr", expected, seed=3)
