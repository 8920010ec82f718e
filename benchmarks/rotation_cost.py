"""What camera rotation costs Box_LS: its error on generated box examples whose camera turns.

    python benchmarks/rotation_cost.py [--examples 3000] [--seed 1]

ODMS and ODMD assume a camera that translates without turning. Here the examples of the box
generator's `odmd-normal` preset (no perturbation, so Box_LS is exact without rotation) get a
camera that also turns: about an axis drawn uniformly on the sphere per example, steadily from
the first frame to the last, by `angle` in all. The last frame's camera is the reference: the
label, and ODMD's movements (the true translations, in its axes), are unchanged. Each frame's
object centre is moved into its turned camera and projected; its box keeps the object's size at
the depth along the turned optical axis. Box_LS (evaluation/box_ls.py `solve`) then estimates
the last depth from those boxes and the movements, as it would from a turning camera's
detections. Per angle: the mean and median percent error, and the share of examples whose box
centre leaves the image at some frame. Baseline: the error at angle 0 (exact up to rounding).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from odms_data.evaluation.box_ls import solve
from odms_data.simulate.box_examples import BOX_PRESETS, sample_box_examples

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402

ANGLES_DEG = (0, 0.5, 1, 2, 3, 4, 5, 7.5, 10, 15, 20, 30)


def rotations(axes: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotation matrices about unit `axes` (..., 3) by `angles` (...) radians (Rodrigues)."""
    x, y, z = axes[..., 0], axes[..., 1], axes[..., 2]
    zero = np.zeros_like(x)
    k = np.stack([np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1), np.stack([-y, x, zero], -1)], -2)
    s, c = np.sin(angles)[..., None, None], np.cos(angles)[..., None, None]
    return np.eye(3) + s * k + (1 - c) * (k @ k)


def turned_boxes(g: dict[str, np.ndarray], axes: np.ndarray, angle: float) -> np.ndarray:
    """(E, n, 4) boxes of the generated examples `g` seen by cameras that turn by `angle` radians
    about `axes` (E, 3) from the first frame to the last (the last unturned)."""
    p = BOX_PRESETS["odmd-normal"]
    h, w = p.image_dim
    fxn, fyn, cxn, cyn = p.fx / w, p.fy / h, p.cx / w, p.cy / h
    boxes, z = g["boxes"], g["frame_depth"]
    n = z.shape[1]
    centre = np.stack([(boxes[..., 0] - cxn) * z / fxn, (boxes[..., 1] - cyn) * z / fyn, z], -1)
    size = np.stack([boxes[..., 2] * z / fxn, boxes[..., 3] * z / fyn], -1)
    turn = angle * (n - 1 - np.arange(n)) / (n - 1)  # the first frame turned by `angle`, the last not
    r = rotations(np.repeat(axes[:, None], n, 1), np.broadcast_to(turn, z.shape))
    seen = np.einsum("enji,enj->eni", r, centre)  # R^T p: the centre in the turned camera
    zt = seen[..., 2]
    return np.stack([seen[..., 0] * fxn / zt + cxn, seen[..., 1] * fyn / zt + cyn,
                     size[..., 0] * fxn / zt, size[..., 1] * fyn / zt], -1)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--examples", type=int, default=3000)
    ap.add_argument("--seed", type=int, default=1)
    _results.add_options(ap)
    a = ap.parse_args()
    g = sample_box_examples(BOX_PRESETS["odmd-normal"], a.seed, np.arange(a.examples))
    axes = np.random.default_rng(a.seed).standard_normal((a.examples, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    rows = []
    for deg in ANGLES_DEG:
        boxes = turned_boxes(g, axes, np.radians(deg))
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
