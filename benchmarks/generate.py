"""Generation throughput and peak memory, against a baseline measured in the same run.

Run by hand: `python benchmarks/generate.py [--count 4000]`. Each configuration runs `odms-data
generate` in a subprocess (n = 10, 480x640, writing a store); peak RSS is the largest sum over
the process tree, sampled every 20 ms; CPU-seconds are the whole machine's busy time while the
command runs (its workers are forked by a fork server that it does not wait for, so its own
accounting misses them), less this process's own (the sampling costs about a tenth of a core):
run it on an otherwise idle machine. The baseline renders masks as the
paper's released generator does (dense Bezier points marked on a float64 image, holes filled
with scipy.ndimage.binary_fill_holes, 2000 points per segment), without perturbing or writing
anything; "x release" is the command's examples per CPU-second over the baseline's. "x flood" is
the same against those masks filled by OpenCV's flood fill instead, an upper bound on that
approach. The floor is the work no generator of these stores avoids, in one process:
cv2.fillPoly of each frame's polygon (its vertices and box computed beforehand), the erosion or
dilation that the preset's perturbation asks for (its masks are not drawn without it), packing
the drawn rows and compressing each example's chunk with zstd, the fastest of three passes,
measured just before and just after each row (the mean of the two is the row's "floor"); "x
floor" is the command's CPU-seconds per example (its start-up included) over the floor's. The
rows "in this process, started" time the same pipeline in the benchmark's own process once it
has imported the package and loaded the kernels (half of --count examples, the fastest of three
passes).
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import cv2
import numpy as np
import psutil
import scipy.ndimage
import zstandard

from odms_data.simulate.batch_render import frame_geometry
from odms_data.simulate.generate_store import generate
from odms_data.simulate.object_model import sample_example
from odms_data.simulate.params import PRESETS
from odms_data.simulate.render import CROSS

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402

Measured = TypeVar("Measured")


def fill_like_release(points: np.ndarray, H: int, W: int) -> np.ndarray:
    """The released generator's mask: the points marked on a float64 image, holes filled by SciPy."""
    image = np.zeros((H, W))
    image[points[:, 1], points[:, 0]] = 1
    return scipy.ndimage.binary_fill_holes(image)


def fill_by_flood(points: np.ndarray, H: int, W: int) -> np.ndarray:
    """The same mask, the outside flood-filled by OpenCV instead (20 times faster here)."""
    outline = np.zeros((H + 2, W + 2), np.uint8)
    outline[points[:, 1] + 1, points[:, 0] + 1] = 1
    cv2.floodFill(outline, None, (0, 0), 2)
    return outline[1:-1, 1:-1] != 2


def baseline_examples_per_cpu_second(count: int, fill: Callable[[np.ndarray, int, int], np.ndarray]) -> float:
    """Mark the points of a 2000-samples-per-segment contour (the released generator's density) and
    fill the holes with `fill`, per mask, into float32 masks; nothing written, nothing perturbed."""
    p = PRESETS["standard"]
    dense = p.__class__(**{**p.__dict__, "curve_samples": 2000})
    H, W = p.image_size
    t = time.process_time()
    for i in range(count):
        spec = sample_example(dense, 1, i)
        masks = np.zeros((p.n_obs, H, W), np.float32)
        for k, z in enumerate(spec.z):
            scale = p.d_min / z
            pts = spec.contour * scale + [W / 2 - scale * spec.size / 2, H / 2 - scale * spec.size / 2]
            x, y = np.clip(pts[:, 0].astype(int), 0, W - 1), np.clip(pts[:, 1].astype(int), 0, H - 1)
            masks[k] = fill(np.stack([x, y], axis=1), H, W)
    return count / (time.process_time() - t)


class Floor:
    """The work no generator of these stores avoids, for one preset: draw (cv2.fillPoly, 1/16 px
    vertices), perturb (cv2.erode or cv2.dilate, as the preset asks), pack and zstd-compress
    `count` examples in one process. Each frame's polygon and box are made once; `rate()` times
    the rest."""

    def __init__(self, preset: str, count: int) -> None:
        p = self.params = PRESETS[preset]
        specs = [sample_example(p, 1, i) for i in range(count)]
        g = frame_geometry(specs, p, np.arange(p.n_obs), p.image_size)  # the generator's own arithmetic
        lo, hi = np.maximum(g.lo, 0), np.minimum(g.hi, p.image_size[::-1])
        self.frames = [
            (np.round((g.poly[g.starts[f] : g.starts[f + 1]] + g.lo[f]) * 16).astype(np.int32),
             (slice(lo[f, 1], hi[f, 1]), slice(lo[f, 0], hi[f, 0])), int(g.k[f]),
             cv2.dilate if g.dilate[f] else cv2.erode)
            for f in range(len(g.k))
        ]

    def rate(self) -> float:
        """Examples per CPU-second, the fastest of three passes (one pass moved by a third)."""
        p = self.params
        (H, W), n = p.image_size, p.n_obs
        frame = np.zeros((H, W), np.uint8)
        packed = np.zeros((n, H, (W + 7) // 8), np.uint8)
        zstd = zstandard.ZstdCompressor(level=3, write_checksum=True)
        count, best = len(self.frames) // n, np.inf
        for _ in range(3):
            t = time.process_time()
            for e in range(count):
                for i, (poly, (rows, columns), k, operation) in enumerate(self.frames[e * n : e * n + n]):
                    cv2.fillPoly(frame, [poly], 1, cv2.LINE_8, 4)
                    if k:
                        frame[rows, columns] = operation(frame[rows, columns], CROSS, iterations=k)
                    packed[i, rows] = np.packbits(frame[rows], axis=-1)
                    frame[rows] = 0
                zstd.compress(packed.data)
                packed[...] = 0
            best = min(best, time.process_time() - t)
        return count / best

    def around(self, measure: Callable[..., Measured], *args: Any) -> tuple[Measured, float]:
        """`measure(*args)` and the floor's rate, the mean of its rates just before and just after: this
        machine's speed drifts by a fifth within minutes, so each row gets its own floor."""
        before = self.rate()
        value = measure(*args)
        return value, (before + self.rate()) / 2


def in_process_examples_per_cpu_second(preset: str, count: int, folder: Path) -> float:
    """The whole pipeline in this process once it has started (imports done, kernels loaded):
    `generate` on one worker into a Zarr store, the fastest of three passes."""
    params = PRESETS[preset]
    generate(str(folder / "warm.zarr"), 64, params, 0, workers=1, overwrite=True)
    best = np.inf
    for _ in range(3):
        t = time.process_time()
        generate(str(folder / "in-process.zarr"), count, params, 0, workers=1, overwrite=True)
        best = min(best, time.process_time() - t)
    return count / best


def busy_cpu_seconds() -> float:
    """CPU-seconds the machine has spent on anything but idling and waiting for I/O."""
    t = psutil.cpu_times()
    return t.user + t.nice + t.system + t.irq + t.softirq


def run(args: list[str]) -> tuple[float, float, float]:
    """Wall seconds, CPU-seconds and peak RSS (MB, whole process tree) of one odms-data command."""
    c0, own, t = busy_cpu_seconds(), time.process_time(), time.perf_counter()
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
    cpu = busy_cpu_seconds() - c0 - (time.process_time() - own)  # not the sampling above
    return time.perf_counter() - t, cpu, peak / 2**20


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=4000)
    ap.add_argument("--large", type=int, default=20000, help="count of the memory-bound run (0: none)")
    _results.add_options(ap)
    a = ap.parse_args()
    base = baseline_examples_per_cpu_second(10, fill_like_release)
    flood = baseline_examples_per_cpu_second(30, fill_by_flood)
    floors = {preset: Floor(preset, 500) for preset in ("standard", "perturb")}
    ceiling = ", ".join(f"{p} {f.rate() / base:.0f}" for p, f in floors.items())
    print(f"examples/CPU-s: released generator's rasterisation (SciPy fill) {base:.1f}, the same with "
          f"OpenCV's flood fill {flood:.1f}; load average {psutil.getloadavg()[0]:.1f} on "
          f"{psutil.cpu_count()} CPUs; each row's floor (draw, pack, compress) measured just before "
          f"and after it; the floor now, x release (the most a row can read): {ceiling}")
    header = ("preset", "format", "workers", "count", "ex/s", "ex/CPU-s", "x release", "x flood", "floor",
              "x floor", "peak MB")
    print("{:9} {:6} {:>7} {:>6} {:>8} {:>9} {:>9} {:>8} {:>6} {:>8} {:>8}".format(*header))
    tmp, rows = Path(tempfile.mkdtemp()), []
    try:
        for preset in ("standard", "perturb"):
            rate, floor = floors[preset].around(in_process_examples_per_cpu_second, preset, a.count // 2, tmp)
            print(f"{preset:9} zarr   in this process, started: {rate:9.0f} ex/CPU-s {'':18} {floor:6.0f} "
                  f"{floor / rate:8.2f}")
            rows.append({"preset": preset, "format": "zarr", "workers": "in this process, started",
                         "examples": a.count // 2, "seconds": None, "examples/s": None,
                         "examples/CPU-s": rate,
                         "x release": rate / base, "x flood": rate / flood, "floor examples/CPU-s": floor,
                         "x floor (CPU per example)": floor / rate, "peak MB": None})
        configs = [(p, "zarr", w, a.count) for p in ("standard", "perturb") for w in (1, 2)]
        configs += [("standard", "hdf5", 2, a.count)]
        configs += [("perturb", "zarr", 2, a.large)] if a.large else []
        for preset, fmt, workers, count in configs:
            out = tmp / f"{preset}-{workers}.{'h5' if fmt == 'hdf5' else 'zarr'}"
            args = ["generate", "-n", str(count), "--preset", preset, "-o", str(out),
                    "--workers", str(workers), "--format", fmt, "--overwrite"]
            (secs, cpu, peak), floor = floors[preset].around(run, args)
            rate, per_cpu = count / secs, count / cpu
            ratios = f"{per_cpu / base:9.0f} {per_cpu / flood:8.0f} {floor:6.0f} {floor / per_cpu:8.2f}"
            row = f"{preset:9} {fmt:6} {workers:7d} {count:6d} {rate:8.0f} {per_cpu:9.0f}"
            print(f"{row} {ratios} {peak:8.0f}")
            rows.append({"preset": preset, "format": fmt, "workers": workers, "examples": count,
                         "seconds": secs, "examples/s": rate, "examples/CPU-s": per_cpu,
                         "x release": per_cpu / base, "x flood": per_cpu / flood,
                         "floor examples/CPU-s": floor,
                         "x floor (CPU per example)": floor / per_cpu, "peak MB": peak})
    finally:
        shutil.rmtree(tmp)
    _results.save(a, "Generation: `odms-data generate` throughput and peak memory",
                  {"what": "the released generator's rasterisation (SciPy hole fill)", "value": base,
                   "unit": "examples/CPU-s"}, rows, {"baseline_flood_fill_examples_per_cpu_second": flood})


if __name__ == "__main__":
    main()
