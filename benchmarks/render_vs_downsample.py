"""How masks rendered straight at 112x112 differ from 480x640 masks shrunk to 112x112.

    python benchmarks/render_vs_downsample.py [--examples 300]

For each preset, over every frame of the examples: IoU of the two binary masks (the shrunk one
is the loaders' default, INTER_AREA rounded), their relative area difference, the area difference
against the exact covered area (INTER_AREA fractions), and the difference in the scale cue
sqrt(a_n / a_1) = d1 / d_n each gives.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from odms_data.simulate.object_model import sample_example
from odms_data.simulate.params import preset
from odms_data.simulate.render import reference_masks
from odms_data.simulate.shrink import resize_masks

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _results  # noqa: E402

SIZE = (112, 112)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--examples", type=int, default=300)
    _results.add_options(ap)
    args = ap.parse_args()
    rows = []
    for name in ("standard", "perturb"):
        params = preset(name)
        iou, rel_area, rel_exact, rel_exact_shrunk, scale_diff, empty = [], [], [], [], [], 0
        for index in range(args.examples):
            spec = sample_example(params, 123, index)
            full = reference_masks(spec, params)
            direct = reference_masks(spec, params, SIZE).astype(bool)
            shrunk = resize_masks(full, SIZE).astype(bool)
            exact = np.maximum(resize_masks(full, SIZE, coverage=True).sum(axis=(1, 2)), 1e-9)
            a_d, a_s = direct.sum(axis=(1, 2)), shrunk.sum(axis=(1, 2))
            ok = (a_d > 0) & (a_s > 0)
            empty += int((~ok).sum())
            union = (direct | shrunk).sum(axis=(1, 2))
            iou += list(((direct & shrunk).sum(axis=(1, 2)) / np.maximum(union, 1))[ok])
            rel_area += list((np.abs(a_d - a_s) / np.maximum(a_s, 1))[ok])
            rel_exact += list((np.abs(a_d - exact) / exact)[ok])
            rel_exact_shrunk += list((np.abs(a_s - exact) / exact)[ok])
            if ok[0] and ok[-1]:
                scale_diff.append(abs(np.sqrt(a_d[-1] / a_d[0]) - np.sqrt(a_s[-1] / a_s[0])))
        iou, rel_area = np.array(iou), np.array(rel_area)
        print(f"{name}: {args.examples} examples, {len(iou)} frames at 112x112 "
              f"({empty} left out: empty in one of the two)")
        print(f"  IoU(direct, shrunk): mean {iou.mean():.4f}, 1st percentile {np.percentile(iou, 1):.4f}, "
              f"identical frames {np.mean(iou == 1):.1%}")
        print(f"  |area direct - area shrunk| / area shrunk: mean {rel_area.mean():.2%}, "
              f"95th percentile {np.percentile(rel_area, 95):.2%}")
        print(f"  vs exact covered area: direct {np.mean(rel_exact):.2%}, "
              f"shrunk {np.mean(rel_exact_shrunk):.2%}")
        print(f"  |sqrt(a_n/a_1) direct - shrunk|: mean {np.mean(scale_diff):.4f}, "
              f"max {np.max(scale_diff):.4f}")
        rows.append({"preset": name, "frames": len(iou), "frames left out (empty)": empty,
                     "IoU mean": float(iou.mean()), "IoU 1st percentile": float(np.percentile(iou, 1)),
                     "frames identical": float(np.mean(iou == 1)),
                     "rel. area difference mean": float(rel_area.mean()),
                     "rel. area difference 95th pct": float(np.percentile(rel_area, 95)),
                     "area vs exact, direct": float(np.mean(rel_exact)),
                     "area vs exact, shrunk": float(np.mean(rel_exact_shrunk)),
                     "scale cue difference mean": float(np.mean(scale_diff)),
                     "scale cue difference max": float(np.max(scale_diff))})
    _results.save(args, "Masks drawn at 112x112 against 480x640 masks shrunk to 112x112",
                  {"what": "480x640 masks shrunk with INTER_AREA (the loaders' default)", "value": None,
                   "unit": ""}, rows, {"examples": args.examples, "seed": 123})


if __name__ == "__main__":
    main()
