"""How many examples' boxes equal ODMD's own conversion of the ODMS release, per split.

    python benchmarks/odmd_boxes.py --data odms-stores/ --odmd ODMD/data

`--data` holds the imported official stores (`odms-data import odms`); `--odmd` is the data/
folder of the authors' repository griffbr/ODMD (its odms_detection/{val,test}/*.pk). ODMD's
examples are matched to the stores' by folder (ODMD lists folders sorted by name; a robot folder's
windows by length, then from the far end: its window (w, s) is the store's w{w}-{30-w-s}), with
the observations `box-ls --odmd-conversion` chooses. An example agrees when all ten of its boxes
equal ODMD's exactly (float64). The frames' depths and the labels are checked to match first.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from odms_data.evaluation.ground_truth import data_locations, find_stores
from odms_data.pickles import load_pickle
from odms_data.protocol import OFFICIAL_SPLITS, ROBOT_FRAMES, ROBOT_WINDOWS
from odms_data.store.box_rule import chosen_frames, frame_boxes
from odms_data.store.reader import open_store


def odmd_order(ids: list[str], sources: list[str], split: str) -> list[int]:
    """Store rows in the order of ODMD's converted set of `split`."""
    domain = split.split("-")[0]
    row = {e: i for i, e in enumerate(ids)}
    order = []
    for folder in sorted({s.rsplit("/", 1)[-1] for s in sources}):
        if domain != "robot":
            order.append(row[f"{split}/{folder}"])
            continue
        for w in ROBOT_WINDOWS:
            starts = range(ROBOT_FRAMES - w + 1)  # from the far end
            order += [row[f"{split}/{folder}/w{w}-{ROBOT_FRAMES - w - s:02d}"] for s in starts]
    return order


def agreement(store_path: Path, pk: Path, split: str) -> dict:
    d = load_pickle(pk)
    bb = d["bb"]["bboxes"]  # (10, 5, E): x_c, y_c, w, h, depth
    with open_store(str(store_path)) as s:
        order = odmd_order(s.example_ids, s.sources, split)
        frames = np.stack([chosen_frames(s, bb.shape[0], True)[i] for i in order])
        depth_ok = bool(np.allclose(np.nan_to_num(s.depth[frames].T, nan=0.0),
                                    np.where(np.isnan(s.depth[frames].T), 0.0, bb[:, 4, :]), atol=1e-6))
        labels_ok = bool(np.allclose(s.d1[order], bb[-1, 4, :], atol=1e-6))
        ours = frame_boxes(s, frames.ravel()).reshape(frames.shape + (4,)).transpose(1, 2, 0)
        ids = [s.example_ids[i] for i in order]
    same = (ours == bb[:, :4, :]).all(axis=1)  # (10, E)
    return {"examples": len(order), "equal": int(same.all(axis=0).sum()), "frames": int(same.size),
            "frames_equal": int(same.sum()), "depths_match": depth_ok, "labels_match": labels_ok,
            "differ": [ids[i] for i in np.flatnonzero(~same.all(axis=0))]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", action="append", default=[], help="folder of the official stores")
    ap.add_argument("--odmd", type=Path, required=True, help="griffbr/ODMD's data/ folder")
    ap.add_argument("--json", type=Path, help="also write the figures here")
    args = ap.parse_args()
    stores = find_stores(data_locations(tuple(args.data)))
    out = {}
    for split in OFFICIAL_SPLITS:
        domain, family = split.split("-")
        pk = args.odmd / "odms_detection" / family / f"{family}_odms_detect_{domain}.pk"
        r = agreement(stores[split], pk, split)
        out[split] = r
        print(f"{split:13s} {r['equal']:5d} / {r['examples']:5d} examples, {r['frames_equal']:6d} / "
              f"{r['frames']:6d} frames equal; depths {r['depths_match']}, labels {r['labels_match']}",
              flush=True)
    if args.json:
        args.json.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
