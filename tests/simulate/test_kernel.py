"""Where the compiled kernels are cached: the user's cache folder or NUMBA_CACHE_DIR, never inside
the package (files pip does not know of would outlive an uninstall and shadow a later install)."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import odms_data

DRAW = """
import numpy as np
from odms_data.simulate.raster import draw_silhouette
canvas = np.zeros((20, 20), np.uint8)
draw_silhouette(canvas, np.array([[2.0, 2.0], [15.0, 3.0], [8.0, 16.0]]))
assert canvas.sum() > 50
"""


def _draw(env: dict[str, str], cwd: Path) -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME")} | env
    run = subprocess.run([sys.executable, "-c", DRAW], env=env, cwd=cwd, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr


def test_kernels_are_cached_outside_the_package(tmp_path):
    package = Path(odms_data.__file__).parent
    started = time.time()
    _draw({"XDG_CACHE_HOME": str(tmp_path / "xdg")}, tmp_path)
    cached = list((tmp_path / "xdg" / "odms-data" / "numba").rglob("raster.draw_silhouettes-*.nbi"))
    assert len(cached) == 1
    _draw({"NUMBA_CACHE_DIR": str(tmp_path / "mine"), "XDG_CACHE_HOME": str(tmp_path / "xdg2")}, tmp_path)
    assert list((tmp_path / "mine").rglob("raster.draw_silhouettes-*.nbi"))
    assert not (tmp_path / "xdg2").exists()
    written = [p for p in package.rglob("*.nb[ic]") if p.stat().st_mtime >= started]
    assert not written, written
