"""Scoring the 15,650 official examples with and without the 95 % intervals, in one run.

Run by hand: `python benchmarks/score_intervals.py --data DIR` (DIR holds the eight official
stores; default $ODMS_DATA). VOS-DE's predictions are computed once; then, each the median of
--repeat runs in this process: `scoring.score` without intervals (the baseline), with them
(2,000 cluster bootstrap resamples of every mean-based metric of every split and All), a
breakdown by depth with intervals, and `compare` of the file against itself (bootstrap and
10,000 sign flips per split).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

from odms_data.evaluation.bootstrap import FLIPS, RESAMPLES
from odms_data.evaluation.breakdown import breakdown
from odms_data.evaluation.compare import compare
from odms_data.evaluation.ground_truth import load_truth
from odms_data.evaluation.predictions import read_predictions, write_predictions
from odms_data.evaluation.scoring import score
from odms_data.evaluation.vosde import vosde
from odms_data.protocol import OFFICIAL_SPLITS
from odms_data.store.reader import open_store

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402
from score import median_time, official_stores  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=None, help="folder of the eight official stores (default $ODMS_DATA)")
    ap.add_argument("--repeat", type=int, default=3)
    _results.add_options(ap)
    a = ap.parse_args()
    found = official_stores(a.data, "score_intervals.py")
    rows = []
    for split in OFFICIAL_SPLITS:
        with open_store(str(found[split])) as s:
            rows += vosde(s).rows()
    truths = {s: load_truth(found[s]) for s in OFFICIAL_SPLITS}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "vosde.csv"
        write_predictions(path, rows)
        preds = read_predictions(path)
    t_plain, plain = median_time(lambda: score(preds, truths, intervals=False), a.repeat)
    t_ci, report = median_time(lambda: score(preds, truths), a.repeat)
    t_by, _ = median_time(lambda: breakdown(report, "depth"), a.repeat)
    t_cmp, _ = median_time(lambda: compare(plain, plain), a.repeat)
    assert report.all == plain.all  # the intervals change no figure
    n = len(rows)
    table = [
        {"measurement": f"score {n} examples, no intervals", "seconds": t_plain, "ratio": 1.0},
        {"measurement": f"score {n} examples with 95 % intervals ({RESAMPLES} resamples)", "seconds": t_ci,
         "ratio": t_ci / t_plain},
        {"measurement": "breakdown by depth, with intervals", "seconds": t_by, "ratio": t_by / t_plain},
        {"measurement": f"compare the file with itself ({RESAMPLES} resamples, {FLIPS} flips a split)",
         "seconds": t_cmp, "ratio": t_cmp / t_plain},
    ]
    print(f"machine: {os.cpu_count()} cores")
    for r in table:
        print(f"{r['measurement']}: {r['seconds']:.3f} s ({r['ratio']:.1f}x)")
    ci = {a.family: a.ci95["mean_percent_error"] for a in report.alls if a.benchmark == "odms"}
    _results.save(a, "Scoring with and without 95 % intervals: VOS-DE's 15,650 official predictions",
                  {"what": "score without intervals", "value": t_plain, "unit": "s"}, table,
                  {"all": report.all, "all_ci95": ci, "resamples": RESAMPLES, "flips": FLIPS})


if __name__ == "__main__":
    main()
