"""Generation throughput and peak memory, against a baseline measured in the same run.

Run by hand: `python benchmarks/generate.py [--count 4000]`. Each configuration runs
`odms-data generate` in a subprocess (n = 10, 480x640, writing a store); peak RSS is the
largest sum over the process tree, sampled every 20 ms. The baseline renders masks the way
the paper's released generator does (dense Bezier points marked on a float32 image, holes
filled), without writing anything: it is an upper bound on that approach's throughput.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
import psutil

from odms_data.simulate.object_model import sample_example
from odms_data.simulate.params import PRESETS


def baseline_examples_per_second(count: int) -> float:
    """Rasterise points of a 2000-samples-per-segment contour and fill holes, per mask."""
    p = PRESETS["standard"]
    dense = p.__class__(**{**p.__dict__, "curve_samples": 2000})
    H, W = p.image_size
    t = time.perf_counter()
    for i in range(count):
        spec = sample_example(dense, 1, i)
        masks = np.zeros((p.n_obs, H, W), np.float32)
        for k, z in enumerate(spec.z):
            scale = p.d_min / z
            pts = spec.contour * scale + [W / 2 - scale * spec.size / 2, H / 2 - scale * spec.size / 2]
            xs = np.clip(pts[:, 0].astype(int), 0, W - 1)
            ys = np.clip(pts[:, 1].astype(int), 0, H - 1)
            outline = np.zeros((H + 2, W + 2), np.uint8)
            outline[ys + 1, xs + 1] = 1
            outside = outline.copy()
            cv2.floodFill(outside, None, (0, 0), 2)
            masks[k] = (outside[1:-1, 1:-1] != 2).astype(np.float32)
    return count / (time.perf_counter() - t)


def run(args: list[str]) -> tuple[float, float]:
    """Wall seconds and peak RSS (MB, whole process tree) of one odms-data command."""
    t = time.perf_counter()
    proc = psutil.Popen([sys.executable, "-m", "odms_data.cli", *args],
                        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    peak = 0
    while proc.poll() is None:
        try:
            tree = [proc, *proc.children(recursive=True)]
            peak = max(peak, sum(p.memory_info().rss for p in tree if p.is_running()))
        except psutil.Error:
            pass
        time.sleep(0.02)
    if proc.returncode:
        raise SystemExit(f"odms-data {' '.join(args)} failed with exit code {proc.returncode}")
    return time.perf_counter() - t, peak / 2**20


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=4000)
    ap.add_argument("--large", type=int, default=20000, help="count of the memory-bound run")
    a = ap.parse_args()
    base = baseline_examples_per_second(30)
    print(f"baseline (released generator's rasterisation, no I/O): {base:.1f} examples/s")
    header = ("preset", "format", "workers", "count", "ex/s", "x baseline", "peak MB")
    print("{:9} {:6} {:>7} {:>6} {:>8} {:>10} {:>8}".format(*header))
    tmp = Path(tempfile.mkdtemp())
    try:
        configs = [(p, "zarr", w, a.count) for p in ("standard", "perturb") for w in (1, 2)]
        configs += [("standard", "hdf5", 2, a.count), ("perturb", "zarr", 2, a.large)]
        for preset, fmt, workers, count in configs:
            out = tmp / f"{preset}-{workers}.{'h5' if fmt == 'hdf5' else 'zarr'}"
            secs, peak = run(["generate", "-n", str(count), "--preset", preset, "-o", str(out),
                              "--workers", str(workers), "--format", fmt, "--overwrite"])
            rate = count / secs
            print(f"{preset:9} {fmt:6} {workers:7d} {count:6d} {rate:8.0f} {rate / base:10.0f} {peak:8.0f}")
    finally:
        shutil.rmtree(tmp)


if __name__ == "__main__":
    main()
