"""What camera rotation costs Box_LS: its error on generated box examples whose camera turns.

    python benchmarks/rotation_cost.py [--examples 3000] [--seed 1]

ODMS and ODMD assume a camera that translates without turning. Here the examples of the box
generator's `odmd-normal` preset (no perturbation, so Box_LS is exact without rotation) get a
camera that also turns: the generator's `rotation` setting (simulate/box_examples.py), about an
axis drawn uniformly on the sphere per example, steadily from the first frame to the last, by
`angle` in all. The last frame's camera is the reference: the label, and ODMD's movements (the
true translations, in its axes), are unchanged. Each frame's object centre is moved into its
turned camera and projected; its box keeps the object's size at the depth along the turned
optical axis. Box_LS (evaluation/box_ls.py `solve`) then estimates
the last depth from those boxes and the movements, as it would from a turning camera's
detections. Per angle: the mean and median percent error, and the share of examples whose box
centre leaves the image at some frame. Baseline: the error at angle 0 (exact up to rounding).
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from odms_data.evaluation.box_ls import solve
from odms_data.simulate.box_examples import BOX_PRESETS, sample_box_examples

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402

ANGLES_DEG = (0, 0.5, 1, 2, 3, 4, 5, 7.5, 10, 15, 20, 25)  # the preset allows up to 27.1


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--examples", type=int, default=3000)
    ap.add_argument("--seed", type=int, default=1)
    _results.add_options(ap)
    a = ap.parse_args()
    rows = []
    for deg in ANGLES_DEG:
        params = replace(BOX_PRESETS["odmd-normal"], rotation=deg)
        g = sample_box_examples(params, a.seed, np.arange(a.examples))
        boxes = g["boxes"]
        d1, bad, _ = solve(boxes, g["move"][..., 2])
        err = np.abs(d1 - g["depth"]) / g["depth"] * 100
        outside = ((boxes[..., :2] < 0) | (boxes[..., :2] > 1)).any(axis=(1, 2))
        rows.append({"rotation_deg": deg, "mean_percent_error": float(err.mean()),
                     "median_percent_error": float(np.median(err)), "unsolvable": int(bad.sum()),
                     "share_leaving_image": float(outside.mean())})
        print(rows[-1])
    _results.save(a, "What camera rotation costs Box_LS (generated odmd-normal examples, a turning camera)",
                  {"what": "Box_LS's mean percent error without rotation",
                   "value": rows[0]["mean_percent_error"], "unit": "%"},
                  rows, {"examples": a.examples, "seed": a.seed})


if __name__ == "__main__":
    main()
