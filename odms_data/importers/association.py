"""Which detections are the object's: a track's rows, or the association rule over per-frame
detections (in the first frame with a candidate, the one of best score; in each later frame, the
candidate that overlaps most (IoU) the box chosen last, if it overlaps at least `min_iou`, else a
missed detection), with the frames where it chose between close candidates (a runner-up scoring
within SCORE_MARGIN of the best first choice, or overlapping within IOU_MARGIN of the best)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InputError

if TYPE_CHECKING:
    from .detection_files import Detections

DEFAULT_MIN_IOU = 0.3  # overlap with the box chosen last that continues the object
SCORE_MARGIN = 0.05  # a runner-up scoring within this of the best makes a first choice close
IOU_MARGIN = 0.1  # a runner-up overlapping within this of the best makes a continued choice close


@dataclass(frozen=True)
class Choice:
    """The object's box in every frame (F, 4), zeros where it was missed, the detection row chosen
    (-1 where missed) and the frames where the rule chose between close candidates (one line each)."""

    boxes: np.ndarray
    rows: np.ndarray
    close: list[str]


def iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Intersection over union of the box `a` with each of `b` (k, 4), all [x_c, y_c, w, h]."""
    lo = np.maximum(a[:2] - a[2:] / 2, b[:, :2] - b[:, 2:] / 2)
    hi = np.minimum(a[:2] + a[2:] / 2, b[:, :2] + b[:, 2:] / 2)
    inter = np.prod(np.clip(hi - lo, 0, None), axis=1)
    union = a[2] * a[3] + b[:, 2] * b[:, 3] - inter
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(union > 0, inter / union, 0.0)


def choose_track(dets: Detections, track: int, where: str) -> Choice:
    """The rows of track `track`, one a frame."""
    rows = np.full(len(dets.frames), -1, np.int64)
    for r in np.flatnonzero(dets.label == track):
        f = dets.frame[r]
        if rows[f] >= 0:
            raise InputError(f"{dets.rows[r]}: track {track} has a second box in frame {dets.frames[f]} "
                             f"(the first: {dets.rows[rows[f]]})")
        rows[f] = r
    if not (rows >= 0).any():
        raise InputError(f"{where}: no box of track {track}")
    return _choice(dets, rows, [])


def _choice(dets: Detections, rows: np.ndarray, close: list[str]) -> Choice:
    boxes = np.zeros((len(rows), 4))
    boxes[rows >= 0] = dets.box[rows[rows >= 0]]
    return Choice(boxes, rows, close)


def associate(dets: Detections, category: int | None, min_iou: float, where: str) -> Choice:
    """The association rule (module doc) over the detections of `category` (None: all)."""
    candidates = np.flatnonzero(dets.label == category) if category is not None else np.arange(len(dets.rows))
    if not len(candidates):
        raise InputError(f"{where}: no detection of category {category}")
    by_frame = candidates[np.argsort(dets.frame[candidates], kind="stable")]
    starts = np.searchsorted(dets.frame[by_frame], np.arange(len(dets.frames) + 1))
    rows, close, last = np.full(len(dets.frames), -1, np.int64), [], None
    for f in range(len(dets.frames)):
        cand = by_frame[starts[f] : starts[f + 1]]
        if not len(cand):
            continue
        name = dets.frames[f]
        if last is None:
            order = cand[np.lexsort((-dets.score[cand],))]
            s = dets.score[order]
            if len(order) > 1 and s[1] >= s[0] - SCORE_MARGIN:
                close.append(f"frame {name}: first choice by score, {s[0]:.3g} over {s[1]:.3g}")
        else:
            overlap = iou(last, dets.box[cand])
            keep = overlap >= min_iou
            if not keep.any():
                continue
            cand, overlap = cand[keep], overlap[keep]
            rank = np.lexsort((-dets.score[cand], -overlap))
            order, o = cand[rank], overlap[rank]
            if len(order) > 1 and o[1] >= o[0] - IOU_MARGIN:
                close.append(f"frame {name}: IoU {o[0]:.3g} over {o[1]:.3g} with the box before")
        rows[f] = order[0]
        last = dets.box[order[0]]
    return _choice(dets, rows, close)
