"""Smoke runs of examples/train_odn.py (PyTorch) and train_odn_jax.py (JAX, grain): a few steps,
then a predictions CSV for a store."""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import grain  # noqa: F401  (the examples need them; pip install -e '.[dev]' brings them)
import optax  # noqa: F401
import pytest
import torch  # noqa: F401
from loader_stores import COUNT, make_store

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.parametrize("script", ["train_odn.py", "train_odn_jax.py"])
def test_train_odn_smoke(tmp_path, script):
    store = make_store(tmp_path, "zarr")
    out = tmp_path / "predictions.csv"
    args = ["--steps", "3", "--batch-size", "4", "--workers", "0", "--store", str(store), "--out", str(out)]
    run = subprocess.run([sys.executable, str(EXAMPLES / script), *args], capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stderr
    with open(out, newline="") as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["split", "example_id", "d1"] and len(rows) == COUNT + 1
    assert rows[1][:2] == ["generated", "generated/000000"] and float(rows[1][2]) > 0
