"""Importing a tracker's boxes with a SLAM trajectory: 10,000 frames of MOTChallenge boxes (the
object's track and a second track in every frame) and a TUM trajectory matched by time, through
`import_detections`, against a baseline measured in the same run.

Run by hand: `python benchmarks/import_detections.py [--frames 10000] [--rounds 3]`.
- Rows: `import_detections` (reading both files, matching poses, choosing the track, the movements,
  writing the store), as one example over all frames and as the robot protocol's windows
  (10, 15, 20, 25, 30 frames, 10 observations each).
- Baseline: the same store's rows written by the store builder alone (`write_box_store`, the path
  ODMD's sets take in `import odmd`): what any import of these boxes pays, reading aside.
Each is the fastest of `--rounds` rounds, taken in turns after a warm-up round. Writes
benchmarks/results/import_detections.json (_results.py).
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
import time
from pathlib import Path

import _results
import numpy as np
from scipy.spatial.transform import Rotation

from odms_data.importers.detections import Camera, Which, import_detections
from odms_data.store.box_store import BoxRows, write_box_store
from odms_data.store.format import StoreAttrs
from odms_data.store.reader import open_store

H, W, F, FPS, T0 = 480, 640, 500.0, 30.0, 1000.0
WINDOWS = [10, 15, 20, 25, 30]


def write_inputs(root: Path, n: int) -> tuple[Path, Path]:
    """gt.txt (MOTChallenge, tracks 1 and 2) and tum.txt for a camera approaching a box."""
    rng = np.random.default_rng(0)
    depth = np.linspace(3.0, 0.5, n)
    p = np.stack([0.003 * rng.standard_normal(n), 0.003 * rng.standard_normal(n), depth], axis=1)
    R = Rotation.from_euler("xyz", [20, -35, 50], degrees=True)
    centre = -R.apply(p)
    w, h = 0.1 * F / depth, 0.15 * F / depth
    x, y = p[:, 0] * F / depth + W / 2 - w / 2, p[:, 1] * F / depth + H / 2 - h / 2
    lines = []
    for k in range(n):
        lines.append(f"{k + 1},1,{x[k]:.3f},{y[k]:.3f},{w[k]:.3f},{h[k]:.3f},0.9,-1,-1,-1\n")
        lines.append(f"{k + 1},2,{x[k] + 150:.3f},{y[k] + 40:.3f},{w[k]:.3f},{h[k]:.3f},0.8,-1,-1,-1\n")
    (root / "gt.txt").write_text("".join(lines))
    q = R.as_quat()
    (root / "tum.txt").write_text("".join(
        f"{T0 + k / FPS:.6f} {c[0]:.9f} {c[1]:.9f} {c[2]:.9f} {q[0]:.9f} {q[1]:.9f} {q[2]:.9f} {q[3]:.9f}\n"
        for k, c in enumerate(centre)))
    return root / "gt.txt", root / "tum.txt"


def timed_import(gt: Path, tum: Path, out: Path, windows: list[int] | None) -> float:
    shutil.rmtree(out, ignore_errors=True)
    t = time.perf_counter()
    import_detections("mot", gt, Camera(tum, fps=FPS, start_time=T0), out, which=Which(track=1),
                      image_size=(H, W), windows=windows, d1=0.5, name="bench")
    return time.perf_counter() - t


def timed_rows(store: Path, out: Path) -> float:
    """The builder writing the imported store's rows again, timed from rows in memory."""
    with open_store(store) as s:
        E, n = s.n_examples, len(s.frames_of(0))
        rows = BoxRows(boxes=s.box[:].reshape(E, n, 4), move=s.move[:].reshape(E, n, 3),
                       depth=s.depth[:].reshape(E, n), d1=np.asarray(s.d1[:], np.float64),
                       ids=list(s.example_ids), sources=["gt.txt"] * E)
        attrs = StoreAttrs(split="bench", domain="recording", image_size=(H, W), counts={},
                           source="detections gt.txt", oddities=[])
    shutil.rmtree(out, ignore_errors=True)
    t = time.perf_counter()
    write_box_store(str(out), rows, attrs)
    return time.perf_counter() - t


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=10_000)
    parser.add_argument("--rounds", type=int, default=3)
    _results.add_options(parser)
    args = parser.parse_args()
    root = Path(tempfile.mkdtemp(prefix="bench-detections-"))
    try:
        gt, tum = write_inputs(root, args.frames)
        rows, base = [], {}
        cases = (("one example over all frames", None), ("robot windows 10-30, n_obs 10", WINDOWS))
        for label, windows in cases:
            out, again = root / "d.zarr", root / "r.zarr"
            timed_import(gt, tum, out, windows)  # warm-up: imports, compilation, page cache
            imports, writes = [], []
            for _ in range(args.rounds):
                imports.append(timed_import(gt, tum, out, windows))
                writes.append(timed_rows(out, again))
            with open_store(out) as s:
                examples, frames = s.n_examples, s.n_frames
            base[label] = min(writes)
            rows.append({"store": label, "examples": examples, "frame_rows": frames,
                         "import_s": min(imports), "builder_only_s": min(writes),
                         "import_frames_per_s": args.frames / min(imports),
                         "import_over_builder": min(imports) / min(writes)})
            print(rows[-1], flush=True)
    finally:
        shutil.rmtree(root, ignore_errors=True)
    _results.save(args, f"Importing {args.frames:,} frames of MOTChallenge boxes with a TUM trajectory",
                  {"what": "the store builder writing the same rows (write_box_store, as import odmd does)",
                   "value": base["one example over all frames"], "unit": "s"}, rows)


if __name__ == "__main__":
    main()
