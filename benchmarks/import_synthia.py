"""Importing a SYNTHIA sequence: frames per second against decoding the same PNGs alone.

Run by hand: `python benchmarks/import_synthia.py [--frames 300] [--workers 2]`.
A sequence of `--frames` frames (760x1280, SYNTHIA's layout) is rendered with the tests' scene
writer (tests/importers/synthia_scenes.py) into a temporary folder. Then, in the same run:
- Baseline: `cv2.imread` of every label and depth PNG of the sequence in one process (decoding
  alone, nothing else): frames per second, CPU seconds.
- Import: `odms-data import synthia` in a subprocess with 1 and with `--workers` workers: wall
  time, CPU time (user + sys of the whole process tree), frames per second, store rows/examples.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests" / "importers"))
import synthia_scenes as scenes  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402


def long_street(n_frames: int) -> scenes.Scene:
    """Driving 1.25 m per frame, turning gently, past an object every 8 frames on alternate
    sides: cars, pedestrians and bicycles, a third of them moving."""
    scene = scenes.Scene("SYNTHIA-SEQS-05-FALL", [1.25] * (n_frames - 1), yaw_rate=0.001)
    kinds = [(scenes.CAR, "box", (0.9, 0.75, 2.1)), (scenes.PEDESTRIAN, "ellipsoid", (0.3, 0.9, 0.25)),
             (scenes.BICYCLE, "ellipsoid", (0.3, 0.8, 0.9))]
    for j, k in enumerate(range(30, n_frames + 30, 8)):
        cls, shape, half = kinds[j % 3]
        M = scene.pose(min(k, n_frames - 1))
        ahead = (k - min(k, n_frames - 1)) * 1.25
        side = (1 if j % 2 else -1) * (2.5 + j % 3)
        centre = M[:3, 3] + side * M[:3, 0] + ahead * -M[:3, 2]
        centre[1] = half[1]
        velocity = (0.0, 0.0, -0.3) if j % 3 == 2 else (0.0, 0.0, 0.0)
        scene.things.append(scenes.Thing(j + 1, cls, shape, tuple(centre), half, velocity))
    return scene


def cpu_children() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", type=int, default=300)
    ap.add_argument("--workers", type=int, default=2)
    _results.add_options(ap)
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        seq = scenes.write_sequence(Path(tmp), long_street(args.frames))
        print(f"wrote {args.frames} frames in {time.perf_counter() - t:.1f} s")
        pngs = sorted((seq / "GT/LABELS" / scenes.CAMERA).glob("*.png")) + \
            sorted((seq / "Depth" / scenes.CAMERA).glob("*.png"))
        t, c = time.perf_counter(), time.process_time()
        for p in pngs:
            cv2.imread(str(p), cv2.IMREAD_UNCHANGED)
        wall, cpu = time.perf_counter() - t, time.process_time() - c
        base = args.frames / wall
        print(f"decode baseline: {wall:.1f} s wall, {cpu:.1f} CPU s, {base:.1f} frames/s")
        for workers in sorted({1, args.workers}):
            out = Path(tmp) / f"out{workers}.zarr"
            c0, t = cpu_children(), time.perf_counter()
            command = [sys.executable, "-m", "odms_data.cli", "import", "synthia", str(seq), "-o", str(out),
                       "--workers", str(workers), "--json"]
            r = subprocess.run(command, capture_output=True, text=True, check=True)
            wall, cpu = time.perf_counter() - t, cpu_children() - c0
            s = json.loads(r.stdout)
            rate = args.frames / wall
            print(f"import, {workers} worker(s): {wall:.1f} s wall, {cpu:.1f} CPU s, {rate:.1f} frames/s "
                  f"({rate / base:.2f} x the decode baseline); {s['examples']} examples, {s['frames']} rows")
            rows.append({"workers": workers, "seconds": wall, "CPU-s": cpu, "frames/s": rate,
                         "x baseline": rate / base, "examples": s["examples"], "rows": s["frames"]})
    _results.save(args, f"Importing a SYNTHIA sequence of {args.frames} frames (760x1280)",
                  {"what": "cv2.imread of the same label and depth PNGs, one process", "value": base,
                   "unit": "frames/s"}, rows)


if __name__ == "__main__":
    main()
