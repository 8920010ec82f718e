"""Importing the official release: time, store size and random access, against baselines measured
in the same run.

Run by hand: `python benchmarks/import.py [--archive ../shared/data/odms-v1.tar.gz]`.
- Import: `odms-data import odms` in a subprocess; wall time and CPU time (user + sys of the
  whole process tree). Baseline: `cv2.imread` of a sample of the release's PNGs in one process,
  extrapolated to all of them (decoding alone, nothing written).
- Scan: listing every split's PNGs confined to their folders (`paths.listed_inside`, which resolves
  only links), against resolving every PNG's path (`paths.inside` on each, as the scan did).
- Size: the eight stores (file bytes and disk blocks) against the PNGs and the archive.
- Random access: reading whole examples with `Store.example` against `cv2.imread` of the same
  PNGs (thresholded to the same bool masks), the same random examples, both warm.

Writes benchmarks/results/import.json (_results.py): the figures, the machine, date and commit.
"""

from __future__ import annotations

import argparse
import os
import random
import resource
import shutil
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path
from typing import Any

import _results
import cv2
import numpy as np

from odms_data.importers.release import scan_split
from odms_data.inputs import inside, listed_inside
from odms_data.protocol import OFFICIAL_SPLITS as SPLITS
from odms_data.store.reader import open_store

REPO = Path(__file__).resolve().parents[1]
ARCHIVE = Path(os.environ.get("ODMS_SHARED", REPO.parent / "shared")) / "data" / "odms-v1.tar.gz"


def tree_bytes(path: Path) -> tuple[int, int]:
    """(file bytes, disk bytes) under path."""
    files = [p for p in path.rglob("*") if p.is_file()]
    return sum(p.stat().st_size for p in files), sum(p.stat().st_blocks * 512 for p in files)


def children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def decode_baseline(pngs: list[Path], sample: int) -> float:
    """CPU seconds per PNG of cv2.imread (GRAYSCALE) over a random sample."""
    chosen = random.Random(0).sample(pngs, min(sample, len(pngs)))
    t = time.process_time()
    for p in chosen:
        cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
    return (time.process_time() - t) / len(chosen)


def confine_times(data: Path) -> tuple[float, float]:
    """CPU seconds to list every release folder's PNGs confined to it: (listed_inside, inside on
    each path); the faster of two rounds each, alternated, so that neither gains from a cache."""
    folders = [f for split in SPLITS for f in (data / split.split("-")[1] / split.split("-")[0]).iterdir()
               if f.is_dir()]

    def png(p: Path) -> bool:
        return p.suffix.lower() == ".png"

    def each_path() -> None:
        for f in folders:
            [inside(f, p.name, str(f)) for p in f.iterdir() if png(p)]

    def listing() -> None:
        for f in folders:
            listed_inside(f, png)

    best = {listing: float("inf"), each_path: float("inf")}
    for _ in range(2):
        for fn in best:
            t = time.process_time()
            fn()
            best[fn] = min(best[fn], time.process_time() - t)
    return best[listing], best[each_path]


def random_access(data: Path, stores: Path, per_split: int) -> list[tuple[str, float, float, float, float]]:
    """(split, then wall and CPU ms per example from the store, then the same via cv2.imread).

    Medians over the same random examples; CPU time (all threads of this process) is the fairer
    figure on a busy machine, where zarr's hand-off to its I/O thread waits for the scheduler.
    """
    out = []
    rng = random.Random(1)
    for split in SPLITS:
        folders, _ = scan_split(data, split, False)
        examples = [(eid, [f.files[i] for i in offsets]) for f in folders for eid, offsets, _ in f.examples]
        chosen = rng.sample(examples, per_split)
        with open_store(str(stores / f"{split}.zarr")) as s:
            s.example(0)  # load the small arrays once
            times: dict[str, list[tuple[float, float]]] = {"store": [], "png": []}
            for eid, files in chosen:
                t, c = time.perf_counter(), time.process_time()
                masks = s.example(eid).masks
                times["store"].append((time.perf_counter() - t, time.process_time() - c))
                t, c = time.perf_counter(), time.process_time()
                pngs = np.stack([cv2.imread(str(f), cv2.IMREAD_GRAYSCALE) > 0 for f in files])
                times["png"].append((time.perf_counter() - t, time.process_time() - c))
                assert np.array_equal(masks, pngs), eid
        med = {k: 1e3 * np.median(np.array(v), axis=0) for k, v in times.items()}
        out.append((split, *med["store"], *med["png"]))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--archive", type=Path, default=ARCHIVE)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--sample", type=int, default=3000, help="PNGs decoded for the baseline")
    ap.add_argument("--examples", type=int, default=100, help="random examples per split")
    _results.add_options(ap)
    a = ap.parse_args()
    if not a.archive.is_file():
        raise SystemExit(f"archive not found: {a.archive}")
    figures: dict[str, Any] = {"workers": a.workers}
    tmp = Path(tempfile.mkdtemp())
    try:
        t = time.perf_counter()
        with tarfile.open(a.archive) as tar:
            tar.extractall(tmp, filter="data")
        data = tmp / "data"
        print(f"extracted the archive in {time.perf_counter() - t:.0f} s")
        pngs = sorted(data.rglob("*.png"))
        png_bytes = sum(p.stat().st_size for p in pngs)
        per_png = {kind: decode_baseline([p for p in pngs if f"/{kind}/" in str(p)], a.sample // 4)
                   for kind in ("robot", "driving", "normal", "perturb")}
        decode_cpu = sum(per_png[k] * sum(f"/{k}/" in str(p) for p in pngs) for k in per_png)
        figures["decode_baseline"] = {"pngs": len(pngs), "cpu_s": decode_cpu,
                                      "ms_per_png": {k: 1e3 * v for k, v in per_png.items()}}
        print(f"baseline: cv2.imread of all {len(pngs)} PNGs ~ {decode_cpu:.0f} CPU s "
              f"({', '.join(f'{k} {1e3 * v:.2f} ms' for k, v in per_png.items())}); "
              f"load average now {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
        t = time.process_time()
        for split in SPLITS:
            scan_split(data, split, False)
        scan = time.process_time() - t
        listing, each_path = confine_times(data)
        figures["scan"] = {"cpu_s": scan, "confine_cpu_s": listing, "confine_each_path_cpu_s": each_path}
        print(f"scan of every split: {scan:.1f} CPU s; confining the PNGs: {listing:.1f} CPU s, against "
              f"{each_path:.1f} CPU s resolving every path ({each_path / listing:.1f} x)")
        stores = tmp / "stores"
        cpu0, t = children_cpu(), time.perf_counter()
        subprocess.run([sys.executable, "-m", "odms_data.cli", "import", "odms", str(data), "-o",
                        str(stores), "--workers", str(a.workers)], check=True, stderr=subprocess.DEVNULL)
        wall, cpu = time.perf_counter() - t, children_cpu() - cpu0
        figures["import"] = {"wall_s": wall, "cpu_s": cpu, "cpu_over_decode_baseline": cpu / decode_cpu}
        print(f"import: {wall:.0f} s wall, {cpu:.0f} CPU s ({cpu / decode_cpu:.2f} x the decode "
              f"baseline; {a.workers} workers; load average now {os.getloadavg()[0]:.1f})")
        total, disk = 0, 0
        for split in SPLITS:
            b, d = tree_bytes(stores / f"{split}.zarr")
            total, disk = total + b, disk + d
            print(f"  {split:13} {b / 1e6:6.2f} MB")
        figures["size"] = {"store_bytes": total, "store_disk_bytes": disk, "masks": len(pngs),
                           "png_bytes": png_bytes, "archive_bytes": a.archive.stat().st_size}
        print(f"size: {total / 1e6:.2f} MB of files ({disk / 1e6:.2f} MB on disk) for {len(pngs)} masks, "
              f"{total / len(pngs):.0f} B/mask; PNGs {png_bytes / 1e6:.0f} MB "
              f"({png_bytes / total:.1f} x), archive {a.archive.stat().st_size / 1e6:.0f} MB")
        print(f"random access, median ms per example over {a.examples} random examples (wall / CPU):")
        access = figures["random_access_ms"] = {}
        for split, w_store, c_store, w_png, c_png in random_access(data, stores, a.examples):
            access[split] = {"store_wall": w_store, "store_cpu": c_store, "png_wall": w_png, "png_cpu": c_png}
            print(f"  {split:13} store {w_store:6.2f} / {c_store:6.2f}   cv2.imread {w_png:7.2f} / "
                  f"{c_png:7.2f}   {w_png / w_store:5.1f} x / {c_png / c_store:5.1f} x faster")
        rows = [{"measurement": "import of the eight splits (wall)", "value": wall, "unit": "s"},
                {"measurement": "scan of the eight splits", "value": scan, "unit": "CPU-s"},
                {"measurement": "confining the PNGs: listed_inside", "value": listing, "unit": "CPU-s"},
                {"measurement": "confining the PNGs: inside, each", "value": each_path, "unit": "CPU-s"}]
        _results.save(a, "Importing the official release: time, size and random access",
                      {"what": "cv2.imread of every PNG (a sample, extrapolated)", "value": decode_cpu,
                       "unit": "CPU-s"}, rows, figures)
    finally:
        shutil.rmtree(tmp)


if __name__ == "__main__":
    main()
