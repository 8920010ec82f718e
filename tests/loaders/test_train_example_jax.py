"""Smoke run of examples/train_odn_jax.py (JAX, grain, optax): a few steps, then a predictions CSV
(grain's prefetch processes are tested in test_grain_loader)."""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import grain  # noqa: F401  (the example needs grain, jax and optax; pip install -e '.[dev]' brings them)
import optax  # noqa: F401
from loader_stores import COUNT, make_store

SCRIPT = Path(__file__).resolve().parents[2] / "examples" / "train_odn_jax.py"


def test_train_odn_jax_smoke(tmp_path):
    store = make_store(tmp_path, "zarr")
    out = tmp_path / "predictions.csv"
    args = ["--steps", "3", "--batch-size", "4", "--threads", "1", "--store", str(store), "--out", str(out)]
    run = subprocess.run([sys.executable, str(SCRIPT), *args], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert "step 3/3" in run.stdout
    with open(out, newline="") as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["split", "example_id", "d1"] and len(rows) == COUNT + 1
    assert rows[1][:2] == ["generated", "generated/000000"] and float(rows[1][2]) > 0
