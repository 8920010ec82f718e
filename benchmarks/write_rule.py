"""What the one write rule (outputs.py: siblings made with O_EXCL/O_NOFOLLOW, marked, checked)
costs, against the code before it, measured in the same run.

Run by hand: `python benchmarks/write_rule.py --before DIR [--files 300] [--count 200]`, where DIR
holds the previous code's `odms_data` package (e.g. `git archive main odms_data | tar -x -C DIR`).
Each side runs in a fresh process: the median of --repeat times of writing --files small files
(write_text, the path of entries, CSVs and plots) and of `generate` of --count examples into a
Zarr store and into an HDF5 store. Writes benchmarks/results/write_rule.json (_results.py), the
previous code's writing of the files as the baseline.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402

CHILD = """
import json, shutil, statistics, sys, tempfile, time
from pathlib import Path
from odms_data.outputs import write_text
from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import PRESETS
files, count, repeat = map(int, sys.argv[1:4])
tmp = Path(tempfile.mkdtemp())
def median(fn):
    times = []
    for _ in range(repeat):
        shutil.rmtree(tmp); tmp.mkdir()
        t = time.perf_counter(); fn(); times.append(time.perf_counter() - t)
    return statistics.median(times)
out = {
    "files_s": median(lambda: [write_text(tmp / f"f{i}.json", "{}") for i in range(files)]),
    "generate_zarr_s": median(lambda: generate(str(tmp / "g.zarr"), count, PRESETS["standard"], 1,
                                               workers=1)),
    "generate_hdf5_s": median(lambda: generate(str(tmp / "g.h5"), count, PRESETS["standard"], 1,
                                               workers=1)),
}
shutil.rmtree(tmp)
print(json.dumps(out))
"""


def run(src: str, files: int, count: int, repeat: int) -> dict[str, float]:
    env = dict(os.environ, PYTHONPATH=src)
    out = subprocess.run([sys.executable, "-c", CHILD, str(files), str(count), str(repeat)], env=env,
                         capture_output=True, text=True, check=True, cwd=tempfile.gettempdir())
    return json.loads(out.stdout.splitlines()[-1])


def table(before: dict[str, float], after: dict[str, float], files: int,
          count: int) -> list[dict[str, object]]:
    """One row a measurement: the previous code's seconds, this code's, their ratio."""
    cases = {"files_s": f"write_text of {files} small files",
             "generate_zarr_s": f"generate {count} examples, Zarr",
             "generate_hdf5_s": f"generate {count} examples, HDF5"}
    return [{"measurement": what, "before_s": before[k], "after_s": after[k],
             "after_over_before": after[k] / before[k]} for k, what in cases.items()]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", required=True, help="folder holding the previous code's odms_data")
    ap.add_argument("--files", type=int, default=300)
    ap.add_argument("--count", type=int, default=200)
    ap.add_argument("--repeat", type=int, default=3)
    _results.add_options(ap)
    a = ap.parse_args()
    here = str(Path(__file__).resolve().parents[1])
    after = run(here, a.files, a.count, a.repeat)
    before = run(a.before, a.files, a.count, a.repeat)
    rows = table(before, after, a.files, a.count)
    for row in rows:
        print(row)
    _results.save(a, "The write rule (outputs.py) against the code before it",
                  {"what": f"the previous code's write_text of {a.files} small files",
                   "value": before["files_s"], "unit": "s"}, rows,
                  {"files": a.files, "count": a.count, "repeat": a.repeat})


if __name__ == "__main__":
    main()
