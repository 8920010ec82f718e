"""Does the box generator (simulate/box_examples.py) draw what ODMD's official sets hold?

    python benchmarks/box_distributions.py --odmd $ODMD_DATA [--seed 1]

`--odmd` is the data/ folder of the authors' repository griffbr/ODMD (odmd/{val,test}/*.pk, read
with the restricted pickle reader). For each generated set (normal, perturb motion, perturb
detection; robot is recorded data, not generated) and each of ten per-example statistics, a
two-sample Kolmogorov-Smirnov test compares as many generated examples as the test set holds
(the preset of that set, `--seed`) with the official test set. The yardstick is the official
val set against the test set, both drawn by the authors' generator: a generator that draws
from the same distribution differs from the test set by about as much as the val set does.
Baseline: the largest val-vs-test D of the run.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.stats import ks_2samp

from odms_data.pickles import load_pickle
from odms_data.simulate.box_examples import BOX_PRESETS, sample_box_examples

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402

SETS = {"normal": "odmd-normal", "perturb_motion": "odmd-perturb-motion",
        "perturb_detection": "odmd-perturb-detection"}


def statistics(boxes: np.ndarray, move: np.ndarray, depth: np.ndarray) -> dict[str, np.ndarray]:
    """Ten statistics per example of boxes (E, n, 4), move (E, n, 3), depth (E,)."""
    last, first = boxes[:, -1], boxes[:, 0]
    return {"depth": depth, "move x": move[:, 0, 0], "move y": move[:, 0, 1], "move z": move[:, 0, 2],
            "movement length": np.linalg.norm(move[:, 0], axis=1), "last x_c": last[:, 0],
            "last y_c": last[:, 1], "last w": last[:, 2], "last h": last[:, 3],
            "w last / w first": last[:, 2] / np.where(first[:, 2] == 0, np.nan, first[:, 2])}


def official(path: Path) -> dict[str, np.ndarray]:
    """The statistics of one of ODMD's sets: bb (n, 5, E) boxes and depths, camera_movement
    (n - 1, 3, E), the last row zero as the generator writes it."""
    d = load_pickle(path)
    bb, cam = d["bb"]["bboxes"], d["bb_3D"]["camera_movement"]
    boxes = bb[:, :4, :].transpose(2, 0, 1)
    move = np.zeros((bb.shape[2], bb.shape[0], 3))
    move[:, :-1] = cam.transpose(2, 0, 1)
    return statistics(boxes, move, bb[-1, 4, :])


def _ks(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    r = ks_2samp(a[np.isfinite(a)], b[np.isfinite(b)])
    return float(r.statistic), float(r.pvalue)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--odmd", type=Path, required=True, help="griffbr/ODMD's data/ folder")
    ap.add_argument("--seed", type=int, default=1)
    _results.add_options(ap)
    args = ap.parse_args()
    rows = []
    for name, preset in SETS.items():
        test = official(args.odmd / "odmd" / "test" / f"test_{name}.pk")
        val = official(args.odmd / "odmd" / "val" / f"val_{name}.pk")
        n = len(test["depth"])
        g = sample_box_examples(BOX_PRESETS[preset], args.seed, np.arange(n))
        ours = statistics(g["boxes"], g["move"], g["depth"])
        for stat in test:
            d_gen, p_gen = _ks(ours[stat], test[stat])
            d_val, p_val = _ks(val[stat], test[stat])
            rows.append({"set": name, "statistic": stat, "D generated vs test": d_gen, "p": p_gen,
                         "D val vs test (yardstick)": d_val, "p yardstick": p_val})
    print("| set | statistic | D generated vs test | p | D val vs test | p |")
    print("| --- | --- | ---: | ---: | ---: | ---: |")
    for r in rows:
        print(f"| {r['set']} | {r['statistic']} | {r['D generated vs test']:.3f} | {r['p']:.3f} | "
              f"{r['D val vs test (yardstick)']:.3f} | {r['p yardstick']:.3f} |")
    gen = [r["D generated vs test"] for r in rows]
    yard = [r["D val vs test (yardstick)"] for r in rows]
    low = sum(r["p"] < 0.05 for r in rows)
    print(f"D generated vs test {min(gen):.3f}-{max(gen):.3f}; yardstick {min(yard):.3f}-{max(yard):.3f}; "
          f"{low} of {len(rows)} p-values below 0.05")
    _results.save(args, "The box generator against ODMD's official sets: two-sample KS per statistic",
                  {"what": "largest D, ODMD's val set vs its test set", "value": max(yard), "unit": "D"},
                  rows,
                  {"generated_D_range": [min(gen), max(gen)], "yardstick_D_range": [min(yard), max(yard)],
                   "p_below_0.05": low, "seed": args.seed})


if __name__ == "__main__":
    main()
