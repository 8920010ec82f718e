"""The cost of the checks on untrusted input (issue 27), against the old code in the same run.

Run by hand: `python benchmarks/untrusted_checks.py [--old main] [--frames 600] [--repeats 3]`.
- Import: `odms-data import recording` of a written recording (480 x 640 PNG masks, one worker)
  in a subprocess, with this checkout's code and with `--old` (a git revision, extracted with
  `git archive`), alternating, the median wall and CPU time (user + sys) of each.
- Per mask file: the header check and path confinement alone (`mask_files.image_size`,
  `paths.inside`) against decoding the file with cv2, in this process.
- score --entry: what `score` reads of a generated store (`load_truth`, the labels) against the
  verification an entry adds (`verify_truth`, every mask read and digested).
Writes benchmarks/results/untrusted_checks.json (_results.py), the --old code's import CPU time as
the baseline.
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from odms_data.evaluation.ground_truth import load_truth, verify_truth
from odms_data.importers.mask_files import image_size
from odms_data.inputs import inside
from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import GeneratorParams

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "benchmarks"))
import _results  # noqa: E402


def write_recording(root: Path, n: int) -> tuple[Path, Path]:
    masks = root / "masks"
    masks.mkdir(parents=True)
    rows = ["frame,z,depth"]
    for i in range(n):
        img = np.zeros((480, 640), np.uint8)
        cv2.circle(img, (320, 240), 40 + i % 150, 255, -1)
        cv2.imwrite(str(masks / f"f{i:04d}.png"), img)
        rows.append(f"f{i:04d}.png,{0.2 + 0.001 * i:.4f},{0.5 + 0.001 * i:.4f}")
    (root / "positions.csv").write_text("\n".join(rows) + "\n")
    return masks, root / "positions.csv"


def old_code(revision: str, into: Path) -> Path:
    """The package (and what it reads at run time) at git `revision`, extracted into `into`/old."""
    old = into / "old"
    old.mkdir()
    tracked = ["odms_data", "splits", "schemas", "leaderboard", "setup.cfg"]
    archive = subprocess.run(["git", "archive", revision, *tracked], cwd=REPO, capture_output=True,
                             check=True).stdout
    subprocess.run(["tar", "-x", "-C", str(old)], input=archive, check=True)
    return old


def children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def time_import(code: Path, masks: Path, csv: Path, out: Path) -> tuple[float, float]:
    cpu, t = children_cpu(), time.perf_counter()
    subprocess.run([sys.executable, "-m", "odms_data.cli", "import", "recording", str(masks), "--positions",
                    str(csv), "-o", str(out), "--workers", "1", "--overwrite"], check=True,
                   cwd=out.parent, env={**os.environ, "PYTHONPATH": str(code)},
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t, children_cpu() - cpu


def per_file(masks: Path) -> dict[str, float]:
    files = sorted(masks.iterdir())
    t = time.process_time()
    for f in files:
        image_size(f)
        inside(masks, f.name, "bench")
    checks = time.process_time() - t
    t = time.process_time()
    for f in files:
        cv2.imdecode(np.fromfile(f, np.uint8), cv2.IMREAD_UNCHANGED)
    decode = time.process_time() - t
    return {"checks_ms": 1e3 * checks / len(files), "cv2_decode_ms": 1e3 * decode / len(files),
            "checks_over_decode": checks / decode}


def verification(root: Path, examples: int) -> dict[str, float]:
    store = root / "bench.zarr"
    generate(str(store), examples, GeneratorParams(), 0, split="bench", workers=1)
    t = time.perf_counter()
    truth = load_truth(store)
    read = time.perf_counter() - t
    t = time.perf_counter()
    verify_truth(truth)
    verify = time.perf_counter() - t
    return {"examples": examples, "load_truth_s": read, "verify_truth_s": verify}


def table(figures: dict[str, dict]) -> list[dict[str, object]]:
    """One row a measurement: its seconds, what it is compared with and the ratio to that."""
    imp, per, entry = figures["import_recording"], figures["per_mask_file"], figures["score_entry"]
    name = f"import recording, {imp['frames']} frames"
    return [
        {"measurement": f"{name}, old code, CPU", "seconds": imp["old"]["cpu_s"], "against": "itself",
         "ratio": 1.0},
        {"measurement": f"{name}, this code, CPU", "seconds": imp["new"]["cpu_s"], "against": "old code",
         "ratio": imp["cpu_new_over_old"]},
        {"measurement": f"{name}, old code, wall", "seconds": imp["old"]["wall_s"], "against": "itself",
         "ratio": 1.0},
        {"measurement": f"{name}, this code, wall", "seconds": imp["new"]["wall_s"], "against": "old code",
         "ratio": imp["new"]["wall_s"] / imp["old"]["wall_s"]},
        {"measurement": "header check + path confinement, per mask file", "seconds": per["checks_ms"] / 1e3,
         "against": "cv2 decode", "ratio": per["checks_over_decode"]},
        {"measurement": "cv2 decode, per mask file", "seconds": per["cv2_decode_ms"] / 1e3,
         "against": "itself", "ratio": 1.0},
        {"measurement": f"score: load_truth, {entry['examples']} examples", "seconds": entry["load_truth_s"],
         "against": "itself", "ratio": 1.0},
        {"measurement": f"score --entry: verify_truth, {entry['examples']} examples",
         "seconds": entry["verify_truth_s"], "against": "load_truth",
         "ratio": entry["verify_truth_s"] / entry["load_truth_s"]},
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", default="main", help="git revision of the old code")
    ap.add_argument("--frames", type=int, default=600)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--examples", type=int, default=2000, help="of the store score --entry verifies")
    _results.add_options(ap)
    a = ap.parse_args()
    tmp = Path(tempfile.mkdtemp())
    try:
        old = old_code(a.old, tmp)
        masks, csv = write_recording(tmp / "rec", a.frames)
        runs: dict[str, list[tuple[float, float]]] = {"old": [], "new": []}
        for _ in range(a.repeats):
            for name, code in (("old", old), ("new", REPO)):
                runs[name].append(time_import(code, masks, csv, tmp / f"{name}.zarr"))
        imports = {name: {"wall_s": statistics.median(w for w, _ in r),
                          "cpu_s": statistics.median(c for _, c in r)} for name, r in runs.items()}
        ratio = imports["new"]["cpu_s"] / imports["old"]["cpu_s"]
        figures = {"import_recording": {"frames": a.frames, "repeats": a.repeats, **imports,
                                        "cpu_new_over_old": ratio},
                   "per_mask_file": per_file(masks), "score_entry": verification(tmp, a.examples)}
        for row in table(figures):
            print(row)
        _results.save(a, "Untrusted input: the cost of the checks against the old code",
                      {"what": f"the code at {a.old} importing {a.frames} frames, CPU",
                       "value": imports["old"]["cpu_s"], "unit": "CPU-s"}, table(figures),
                      {"old_revision": a.old, "examples": a.examples})
    finally:
        shutil.rmtree(tmp)


if __name__ == "__main__":
    main()
