"""DBox trained with the authors' full recipe, on a GPU host, and scored: the commands a user runs.

    python benchmarks/train_dbox.py --val stores/normal-val.zarr --test stores/normal-test.zarr \\
        --run runs/dbox-full [--device cuda] [--pretrained DBox_pretrained_paper.pt]

`odms-data train --model dbox` with ODMD's recipe (docs/TRAINING.md: 100,000 iterations of 512
generated box examples, Adam 1e-3, L1 on the normalised label; `--iterations` for fewer), on the
--val stores (boxes, or masks through the box rule), then `predict` (best.pt, and per-set with
`--per-set`) and `score` on the --test stores. Rerunning resumes the run from its last.pt.
Baseline, measured in the same run: Box_LS on the same stores (`odms-data baseline box-ls`).
`--pretrained` adds ODMD's published DBox (predict --model dbox --checkpoint FILE) as a row.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402


def odms(*args: str) -> dict[str, Any]:
    """Run an odms-data command with --json; its JSON (progress goes to this terminal)."""
    out = subprocess.run([sys.executable, "-m", "odms_data.cli", *args, "--json"], stdout=subprocess.PIPE,
                         text=True, check=True).stdout
    return json.loads(out)


def scores(predictions: Path, data: list[str]) -> dict[str, float]:
    """{split: mean percent error} of a predictions file."""
    report = odms("score", str(predictions), *data)
    return {s["split"]: s["mean_percent_error"] for s in report["splits"]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--val", action="append", required=True, help="validation store (repeatable)")
    ap.add_argument("--test", action="append", required=True, help="store to score on (repeatable)")
    ap.add_argument("--run", type=Path, required=True, help="run folder (resumed when it exists)")
    ap.add_argument("--iterations", type=int, default=None, help="default: the recipe's 100,000")
    ap.add_argument("--device", default=None)
    ap.add_argument("--workers", type=int, default=None)
    ap.add_argument("--per-set", action="store_true", help="also predict with each domain's best checkpoint")
    ap.add_argument("--pretrained", type=Path, default=None, help="ODMD's DBox_pretrained_paper.pt")
    _results.add_options(ap)
    args = ap.parse_args()
    common = [*(["--device", args.device] if args.device else []),
              *(["--workers", str(args.workers)] if args.workers is not None else [])]
    data = [a for t in args.test for a in ("--data", t)]

    start = time.perf_counter()
    val = [a for v in args.val for a in ("--val", v)]
    trained = odms("train", "--model", "dbox", "-o", str(args.run), *val,
                   *(["--iterations", str(args.iterations)] if args.iterations else []), *common)
    seconds = time.perf_counter() - start
    columns: dict[str, dict[str, float]] = {}
    for which in ("best", "per-set") if args.per_set else ("best",):
        out = args.run / f"predictions-{which}.csv"
        odms("predict", str(args.run), *data, "--checkpoint", which, "-o", str(out), "--overwrite", *common)
        columns[f"DBox here ({which})"] = scores(out, data)
    if args.pretrained:
        out = args.run / "predictions-pretrained.csv"
        odms("predict", "--model", "dbox", "--checkpoint", str(args.pretrained), *data, "-o", str(out),
             "--overwrite", *common)
        columns["ODMD's pretrained DBox"] = scores(out, data)
    box_ls = args.run / "predictions-box-ls.csv"
    odms("baseline", "box-ls", *data, "-o", str(box_ls), "--overwrite")
    baseline = scores(box_ls, data)

    rows = [{"split": split, **{k: v.get(split) for k, v in columns.items()}, "Box_LS": baseline[split]}
            for split in sorted(baseline)]
    for r in rows:
        print(" | ".join(f"{k} {v:.2f}" if isinstance(v, float) else str(v) for k, v in r.items()))
    mean = sum(baseline.values()) / len(baseline)
    _results.save(args, f"DBox, ODMD's recipe ({trained['config']['iterations']:,} iterations of "
                  f"{trained['config']['batch_size']}): mean percent error per set",
                  {"what": "Box_LS on the same stores, mean of the sets", "value": mean, "unit": "%"}, rows,
                  {"train_seconds_this_session": seconds, "config": trained["config"],
                   "best_iteration": trained["best_iteration"], "best_validation": trained["best"]})


if __name__ == "__main__":
    main()
