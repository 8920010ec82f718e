"""What the untrusted-read checks (issue 27) cost on the hot read paths, against the code before
them, measured in the same run.

Run by hand: `python benchmarks/untrusted_reads.py [--count 2000] [--repeat 5] [--base main]`.

A store of --count generated examples is written in Zarr and HDF5 with this checkout. The code of
--base (git archive of it) and this checkout's then each, in fresh interpreters taking turns:

- open: `open_store` alone (the declared-shape checks: chunk listing, HDF5 link/filter/chunk
  checks, the bytes on disk);
- read: open and read every example with its masks (`Store.example`, what the loaders call; each
  chunk decompressed with its bound);
- zarr: open and read every example's masks through zarr (`Store.backend.array`), as a store at a
  URL is read: odms-data's codecs (the bounded zstd, the refusal of a missing chunk) on each chunk;
- score: the labels of the store and scoring a predictions file of every example (what `score`
  does after parsing its arguments).

Each figure is the median of --repeat child runs; written to benchmarks/results/untrusted_reads.json
(_results.py), the --base code reading the Zarr store as the baseline.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
import _results  # noqa: E402

CHILD = r"""
import sys, time
from pathlib import Path
from odms_data.evaluation.ground_truth import load_truth
from odms_data.evaluation.predictions import read_predictions
from odms_data.evaluation.scoring import score
from odms_data.store.reader import open_store
import h5py, zarr, zarr.codecs  # imported before the clock, as the first store would
store, what, preds = sys.argv[1], sys.argv[2], sys.argv[3]
t = time.perf_counter()
if what == "open":
    open_store(store).close()
elif what == "read":
    with open_store(store) as s:
        for i in range(len(s)):
            s.example(i)
elif what == "zarr":
    with open_store(store) as s:
        masks = s.backend.array("masks")
        for i in range(len(s)):
            frames = s.frames_of(i)
            masks[int(frames.min()) : int(frames.max()) + 1]
else:
    truth = load_truth(Path(store))
    score(read_predictions(preds), {truth.split: truth})
print(time.perf_counter() - t)
"""


OPERATIONS = {"zarr": ("open", "read", "zarr", "score"), "hdf5": ("open", "read", "score")}


def child_seconds(src: Path, store: Path, what: str, preds: Path) -> float:
    env = {**os.environ, "PYTHONPATH": str(src)}
    r = subprocess.run([sys.executable, "-c", CHILD, str(store), what, str(preds)], env=env,
                       capture_output=True, text=True, cwd=store.parent)
    if r.returncode:
        raise SystemExit(f"{src}: {what} of {store} failed:\n{r.stderr[-2000:]}")
    return float(r.stdout.strip().splitlines()[-1])


def base_source(base: str, into: Path) -> str:
    """The package and its data files at commit `base`, unpacked into `into`; its full hash."""
    commit = subprocess.run(["git", "rev-parse", base], cwd=ROOT, check=True, capture_output=True,
                            text=True).stdout.strip()
    archive = subprocess.run(["git", "archive", commit, "odms_data", "schemas", "splits", "leaderboard",
                              "setup.cfg"],
                             cwd=ROOT, check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(into)], input=archive, check=True)
    return commit


def table(figures: dict[str, dict[str, float]]) -> list[dict[str, object]]:
    """One row a store format and operation: the --base code's seconds, this code's, their ratio."""
    return [{"store": key.split()[0], "operation": key.split()[1], "base_s": f["base_s"], "new_s": f["new_s"],
             "new_over_base": f["ratio"]} for key, f in figures.items()]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--count", type=int, default=2000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--base", default="main")
    _results.add_options(ap)
    args = ap.parse_args()

    from odms_data.evaluation.predictions import write_predictions
    from odms_data.simulate.generate_store import generate
    from odms_data.simulate.params import PRESETS
    from odms_data.store.reader import open_store

    with tempfile.TemporaryDirectory() as tmp:
        tmp_path = Path(tmp)
        (tmp_path / "base").mkdir()
        base_commit = base_source(args.base, tmp_path / "base")
        stores = {}
        for fmt, suffix in (("zarr", ".zarr"), ("hdf5", ".h5")):
            stores[fmt] = tmp_path / f"bench{suffix}"
            generate(str(stores[fmt]), args.count, PRESETS["standard"], 11, split="bench")
        with open_store(str(stores["zarr"])) as s:
            ids, split = s.example_ids, s.attrs.split
        preds = tmp_path / "p.csv"
        write_predictions(preds, [(split, e, 1.0) for e in ids])
        sources = {"base": tmp_path / "base", "new": ROOT}
        times: dict[str, list[float]] = {}
        for _ in range(args.repeat):
            for fmt, store in stores.items():
                for what in OPERATIONS[fmt]:
                    for name, src in sources.items():  # taking turns: the machine's load falls on both
                        key = f"{fmt} {what} {name}"
                        times.setdefault(key, []).append(child_seconds(src, store, what, preds))
        figures = {}
        for fmt in stores:
            for what in OPERATIONS[fmt]:
                base = statistics.median(times[f"{fmt} {what} base"])
                new = statistics.median(times[f"{fmt} {what} new"])
                figures[f"{fmt} {what}"] = {"base_s": round(base, 4), "new_s": round(new, 4),
                                            "ratio": round(new / base, 3)}
    for row in table(figures):
        print(row)
    _results.save(args, f"Untrusted reads: open, read and score of {args.count} examples against --base",
                  {"what": f"the code at {args.base} ({base_commit[:12]}) reading every example, Zarr",
                   "value": figures["zarr read"]["base_s"], "unit": "s"}, table(figures),
                  {"base_commit": base_commit, "examples": args.count, "repeat": args.repeat})


if __name__ == "__main__":
    main()
