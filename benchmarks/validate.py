"""Validating stores of masks: `validate` against checking their masks the way it did before, in
the same run.

Run by hand: `python benchmarks/validate.py STORES_FOLDER` (a folder of stores, e.g. the eight
that `odms-data import odms` writes).
- validate: `odms_data.store.validate.validate` on each store, CPU time (user + sys) and wall time.
- Baseline: the same store's digest recomputed with the previous mask check, which unpacked each
  block of 1,024 masks whole and computed each mask's statistics from the full mask
  (`mask_stats(m)` for each m of `unpack(block, width)`); the rest of validate is cheap beside
  those two. Both must find the statistics the store holds.
Writes benchmarks/results/validate.json (_results.py).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import _results
import numpy as np

from odms_data.store.digest import recompute_digest
from odms_data.store.masks import FrameStats, unpack
from odms_data.store.reader import open_store
from odms_data.store.validate import validate


def timed(fn) -> tuple[float, float, object]:
    """(CPU seconds of this process, wall seconds, result) of fn()."""
    c, w = time.process_time(), time.perf_counter()
    result = fn()
    return time.process_time() - c, time.perf_counter() - w, result


def previous_check(path: str) -> FrameStats:
    """Every frame's statistics as the previous validate computed them, with the digest."""
    with open_store(path) as store:
        stats = FrameStats.empty(store.n_frames)

        def visit(start: int, block: np.ndarray) -> None:
            for j, m in enumerate(unpack(block, store.width)):
                stats.set(start + j, m)

        recompute_digest(store, visit)
    return stats


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("stores", type=Path, help="folder of stores of masks (*.zarr, *.h5)")
    _results.add_options(ap)
    args = ap.parse_args()
    rows = []
    for path in sorted(p for p in args.stores.iterdir() if p.suffix in (".zarr", ".h5")):
        before_cpu, before_wall, before = timed(lambda p=path: previous_check(str(p)))
        after_cpu, after_wall, report = timed(lambda p=path: validate(str(p)))
        assert report.ok, report.problems  # type: ignore[attr-defined]
        with open_store(str(path)) as s:  # validate found its statistics equal to the stored ones
            assert all(np.array_equal(getattr(before, k), s.raw(k)) for k in ("area", "largest_area", "bbox"))
            frames, size = s.n_frames, f"{s.height}x{s.width}"
        rows.append({"store": path.name, "frames": frames, "mask size": size,
                     "previous check CPU s": before_cpu, "validate CPU s": after_cpu,
                     "previous check wall s": before_wall, "validate wall s": after_wall,
                     "speed-up (CPU)": before_cpu / after_cpu})
        print(rows[-1], flush=True)
    total = {k: sum(r[k] for r in rows) for k in ("previous check CPU s", "validate CPU s")}
    _results.save(args, "Validating stores of masks (statistics from the packed masks)",
                  {"what": "the previous mask check (whole blocks unpacked, mask_stats per mask) "
                           "with the digest, all stores", "value": total["previous check CPU s"],
                   "unit": "CPU s"},
                  rows, {"validate_cpu_s_all_stores": total["validate CPU s"]})


if __name__ == "__main__":
    main()
