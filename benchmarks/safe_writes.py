"""What the safety of outputs and inputs costs (issue 15), against baselines measured in the same run.

Run by hand: `python benchmarks/safe_writes.py [--count 2000] [--main-src DIR]`.

- HDF5 writes: `convert` of a Zarr store to HDF5 (I/O only) and `generate` into HDF5, through the
  fail-safe file of store/backends/hdf5.py (h5py's fileobj driver), against the same with h5py's own
  `sec2` driver (the baseline, what the writer used before);
- the fsync of a finished Zarr store before its rename: `convert` of an HDF5 store to Zarr with
  and without it;
- reading predictions: `read_predictions` line by line, against `pandas.read_csv` of the same
  file alone, for the official size (15,650 rows) and 1,000,000 rows; and, each in a fresh
  process, the peak memory of reading a 1,000,000-row file whole, stopping at the truth's 15,650
  rows, and (with --main-src, a checkout of the code before) the previous reader.

Each in-process figure is the median of --repeat runs.
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from unittest import mock

import pandas as pd

from odms_data.evaluation.predictions import read_predictions
from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import PRESETS
from odms_data.store import backends, writer
from odms_data.store.convert import convert


class Sec2Hdf5(backends.Hdf5Backend):
    """The baseline: HDF5 written by h5py's own driver, as before the fail-safe file."""

    def __init__(self, path: str, mode: backends.Mode) -> None:
        import h5py

        self.path, self._raw = path, None
        self.file = h5py.File(path, mode)


def median_time(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def fresh(path: Path):
    def clear() -> None:
        shutil.rmtree(path, ignore_errors=True) if path.is_dir() else path.unlink(missing_ok=True)
    return clear


def timed_write(fn, out: Path, repeat: int) -> float:
    def once() -> None:
        fresh(out)()
        fn()
    return median_time(once, repeat)


def timed_read(call: str) -> str:
    """Code that times `call` of read_predictions (as `r`), an error being an answer too."""
    return ("import time\nfrom odms_data.evaluation.predictions import read_predictions as r\n"
            f"t = time.perf_counter()\ntry:\n    {call}\nexcept Exception:\n    pass\n"
            "seconds = time.perf_counter() - t")


def in_child(code: str, pythonpath: str | None = None) -> tuple[float, float]:
    """(seconds, peak MiB) that `python -c code` reports: `code` sets `seconds`; the peak is the
    process's own high-water mark (VmHWM), imports included."""
    env = dict(os.environ, **({"PYTHONPATH": pythonpath} if pythonpath else {}))
    report = ("\nimport re; print(seconds, re.search(r'VmHWM:\\s+(\\d+)', "
              "open('/proc/self/status').read()).group(1))")
    out = subprocess.run([sys.executable, "-c", code + report], env=env, capture_output=True, text=True,
                         check=True).stdout.split()
    return float(out[0]), int(out[1]) / 1024


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=2000, help="examples of the stores written")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--main-src", help="a checkout of the previous code, for its predictions reader")
    a = ap.parse_args()
    tmp = Path(tempfile.mkdtemp())
    try:
        src_zarr, src_h5 = tmp / "src.zarr", tmp / "src.h5"
        generate(str(src_zarr), a.count, PRESETS["perturb"], 1, workers=2)
        convert(str(src_zarr), str(src_h5))
        print(f"stores of {a.count} examples (perturb), {os.cpu_count()} cores")

        out_h5 = tmp / "out.h5"
        safe = timed_write(lambda: convert(str(src_zarr), str(out_h5)), out_h5, a.repeat)
        with mock.patch.object(backends, "Hdf5Backend", Sec2Hdf5):
            base = timed_write(lambda: convert(str(src_zarr), str(out_h5)), out_h5, a.repeat)
        print(f"convert to HDF5: fail-safe file {safe:.2f} s, h5py sec2 {base:.2f} s: {safe / base:.2f} x")

        n = max(1, a.count // 4)
        safe = timed_write(lambda: generate(str(out_h5), n, PRESETS["standard"], 2), out_h5, a.repeat)
        with mock.patch.object(backends, "Hdf5Backend", Sec2Hdf5):
            base = timed_write(lambda: generate(str(out_h5), n, PRESETS["standard"], 2), out_h5, a.repeat)
        print(f"generate {n} into HDF5: fail-safe file {safe:.2f} s, sec2 {base:.2f} s: {safe / base:.2f} x")

        out_zarr = tmp / "out.zarr"
        synced = timed_write(lambda: convert(str(src_h5), str(out_zarr)), out_zarr, a.repeat)
        with mock.patch.object(writer, "fsync_tree", lambda path: None):
            base = timed_write(lambda: convert(str(src_h5), str(out_zarr)), out_zarr, a.repeat)
        print(f"convert to Zarr: with fsync {synced:.2f} s, without {base:.2f} s: {synced / base:.2f} x")

        for rows in (15_650, 1_000_000):
            path = tmp / f"p{rows}.csv"
            with open(path, "w") as f:
                f.write("split,example_id,d1\n")
                f.writelines(f"normal-test,normal-test/{i:07d},{0.1 + i * 1e-6!r}\n" for i in range(rows))
            ours = median_time(lambda p=path: read_predictions(p), a.repeat)
            base = median_time(lambda p=path: pd.read_csv(p), a.repeat)
            line = (f"read {rows} rows: read_predictions {ours:.3f} s, pandas.read_csv alone {base:.3f} s: "
                    f"{ours / base:.1f} x")
            if a.main_src:
                before, _ = in_child(timed_read(f"r('{path}')"), a.main_src)
                line += f"; the previous reader {before:.3f} s: {ours / before:.2f} x"
            print(line)
        big = f"'{tmp / 'p1000000.csv'}'"
        runs = [
            ("imports alone", "import odms_data.evaluation.predictions; seconds = 0", None),
            ("the 1,000,000-row file whole", timed_read(f"r({big})"), None),
            ("stopped at 15,650 rows (the official truth)", timed_read(f"r({big}, max_rows=15650)"), None),
        ]
        if a.main_src:
            runs.append(("the previous reader, whole", timed_read(f"r({big})"), a.main_src))
        for what, code, where in runs:
            secs, mib = in_child(code, where)
            print(f"peak memory, {what}: {mib:.0f} MiB (reading {secs:.1f} s)")
    finally:
        shutil.rmtree(tmp)


if __name__ == "__main__":
    main()
