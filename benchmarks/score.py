"""VOS-DE over the eight official splits and scoring its 15,650 predictions, with baselines.

Run by hand: `python benchmarks/score.py --data DIR` (DIR holds the eight official stores, as
`odms-data import` writes them; default $ODMS_DATA). Everything is measured in this run:

- VOS-DE from the stored per-frame statistics (`largest_area`, `z`), all eight splits;
- the baseline: VOS-DE the way the released code works, decoding every used mask and finding its
  largest 8-connected region, timed on a sample of examples per split and scaled to the split;
  the two must give the same estimates on the sample;
- scoring: reading and checking the 15,650-row predictions file, loading the labels and scoring,
  against `pandas.read_csv` of the same file alone (the floor any CSV-based scorer pays);
- the two commands end to end in a fresh interpreter (imports included).

Each in-process figure is the median of --repeat runs.

"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from odms_data.evaluation.ground_truth import data_locations, find_stores, load_truth
from odms_data.evaluation.predictions import read_predictions, write_predictions
from odms_data.evaluation.scoring import score
from odms_data.evaluation.vosde import solve, vosde
from odms_data.protocol import observation_indices, split_order
from odms_data.store.masks import mask_stats
from odms_data.store.reader import open_store

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402

OFFICIAL = [f"{d}-{f}" for f in ("val", "test") for d in ("robot", "driving", "normal", "perturb")]


def median_time(fn, repeat: int) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), out


def vosde_from_stats(paths: dict[str, Path]) -> list[tuple[str, str, float]]:
    rows = []
    for split in OFFICIAL:
        with open_store(str(paths[split])) as s:
            rows += vosde(s).rows()
    return rows


def vosde_decoding_masks(path: Path, sample: int) -> tuple[float, int, float]:
    """(seconds per example, examples timed, largest |difference| to the stored-statistics path)."""
    with open_store(str(path)) as s:
        fast = vosde(s).d1
        rows = np.linspace(0, s.n_examples - 1, min(sample, s.n_examples)).astype(int)
        t = time.perf_counter()
        est = []
        for i in rows:
            ex = s.example(int(i))
            cols = observation_indices(ex.n, 10)
            areas = np.array([mask_stats(m)[1] for m in ex.masks[cols]], np.float64)
            d1, bad = solve(np.sqrt(areas)[None], (ex.z[cols] - ex.z[0])[None])
            est.append(0.0 if bad[0] else d1[0])
        per = (time.perf_counter() - t) / len(rows)
    return per, len(rows), float(np.max(np.abs(np.array(est) - fast[rows])))


def run_score(preds: Path, paths: dict[str, Path]):
    p = read_predictions(preds)
    truths = {s: load_truth(paths[s]) for s in sorted(paths, key=split_order)}
    return score(p, truths)


def cli_seconds(args: list[str]) -> float:
    t = time.perf_counter()
    code = "from odms_data.cli import main; main(prog_name='odms-data')"
    subprocess.run([sys.executable, "-c", code, *args], check=True, capture_output=True)
    return time.perf_counter() - t


def official_stores(data: str | None, script: str) -> dict[str, Path]:
    """The eight official stores in `data` (default $ODMS_DATA), by split; exits naming any missing."""
    found = find_stores(data_locations([data] if data else []))
    missing = [s for s in OFFICIAL if s not in found]
    if missing:
        sys.exit(f"benchmarks/{script}: the data folder lacks {', '.join(missing)}")
    return {s: Path(found[s]) for s in OFFICIAL}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=None, help="folder of the eight official stores (default $ODMS_DATA)")
    ap.add_argument("--sample", type=int, default=100, help="examples per split, decoding baseline")
    ap.add_argument("--repeat", type=int, default=3)
    _results.add_options(ap)
    a = ap.parse_args()
    paths = official_stores(a.data, "score.py")

    t_stats, rows = median_time(lambda: vosde_from_stats(paths), a.repeat)
    n_ex = len(rows)
    base_total, worst = 0.0, 0.0
    per_split = []
    for split in OFFICIAL:
        per, k, diff = vosde_decoding_masks(paths[split], a.sample)
        with open_store(str(paths[split])) as s:
            base_total += per * s.n_examples
        per_split.append((split, per, k))
        worst = max(worst, diff)

    with tempfile.TemporaryDirectory() as tmp:
        preds = Path(tmp) / "vosde.csv"
        write_predictions(preds, rows)
        t_score, report = median_time(lambda: run_score(preds, paths), a.repeat)
        t_pandas, _ = median_time(lambda: pd.read_csv(preds), a.repeat)
        data = str(paths[OFFICIAL[0]].parent)
        cli_vosde = cli_seconds(["baseline", "vosde", "--data", data, "-o", str(Path(tmp) / "c.csv")])
        cli_score = cli_seconds(["score", str(preds), "--data", data])

    print(f"machine: {os.cpu_count()} cores; python {sys.version.split()[0]}")
    print("\n| measurement | seconds | ratio |\n|---|---:|---:|")
    print(f"| VOS-DE, stored statistics, {n_ex} examples (8 splits) | {t_stats:.3f} | 1 |")
    print(f"| VOS-DE, decoding masks (as released), scaled from {a.sample}/split | {base_total:.1f} | "
          f"{base_total / t_stats:.0f}x slower |")
    print(f"| score {n_ex} rows: read + check + labels + metrics | {t_score:.3f} | "
          f"{t_score / t_pandas:.1f}x pandas.read_csv |")
    print(f"| pandas.read_csv of the same file | {t_pandas:.3f} | 1 |")
    print(f"| `odms-data baseline vosde` end to end (fresh interpreter) | {cli_vosde:.2f} | |")
    print(f"| `odms-data score` end to end (fresh interpreter) | {cli_score:.2f} | |")
    print("\nmask-decoding baseline per example: "
          + ", ".join(f"{s} {per * 1000:.1f} ms" for s, per, _ in per_split))
    print(f"largest |d1 difference| between the two VOS-DE paths on the sample: {worst:.2e} m")
    print(f"All (test) = {report.all['test']:.2f}, All (val) = {report.all['val']:.2f}")
    table = [
        {"measurement": f"VOS-DE, stored statistics, {n_ex} examples (8 splits)", "seconds": t_stats,
         "ratio": 1.0, "against": "itself"},
        {"measurement": f"VOS-DE, decoding masks (as released), scaled from {a.sample}/split",
         "seconds": base_total, "ratio": base_total / t_stats, "against": "stored statistics"},
        {"measurement": f"score {n_ex} rows: read + check + labels + metrics", "seconds": t_score,
         "ratio": t_score / t_pandas, "against": "pandas.read_csv"},
        {"measurement": "pandas.read_csv of the same file", "seconds": t_pandas, "ratio": 1.0,
         "against": "itself"},
        {"measurement": "`odms-data baseline vosde` end to end", "seconds": cli_vosde, "ratio": None,
         "against": ""},
        {"measurement": "`odms-data score` end to end", "seconds": cli_score, "ratio": None, "against": ""},
    ]
    _results.save(a, "Scoring: VOS-DE over the eight official splits and scoring its predictions",
                  {"what": "VOS-DE decoding every used mask, as the released code does", "value": base_total,
                   "unit": "s"}, table, {"largest_d1_difference_m": worst, "all_test": report.all["test"],
                                        "all_val": report.all["val"]})


if __name__ == "__main__":
    main()
