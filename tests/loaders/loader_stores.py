"""Small generated stores shared by the loader tests (imported by them, not a test module)."""

from __future__ import annotations

from pathlib import Path

from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import GeneratorParams

PARAMS = GeneratorParams(image_size=(120, 160), sizes=(30, 60, 90), perturb_std=1.0)
COUNT = 24


def make_store(root: Path, fmt: str) -> Path:
    path = root / ("small.zarr" if fmt == "zarr" else "small.h5")
    generate(str(path), COUNT, PARAMS, seed=5, fmt=fmt, examples_per_shard=8)
    return path
