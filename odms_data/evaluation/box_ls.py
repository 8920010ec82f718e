"""Box_LS, the least-squares baseline of ODMD (Griffin & Corso, CVPR 2021), on any store.

A box's width and height shrink with depth: with D_k = d1 + (z_k - z_1) the object's depth at
observation k (z_1 the closest observation), w_k D_k and h_k D_k are constants c_w, c_h. Least
squares over the observations of

    [w_k, 1, 0] [d1, -c_w, -c_h]^T = w_k m_k,    [h_k, 0, 1] [d1, -c_w, -c_h]^T = h_k m_k,

with m_k = z_1 - z_k the camera movement to the closest observation, gives the estimate d1.
Boxes and movements are the store's box examples (store/box_rule.py `example_boxes`), far to near.
With more than N observations, N evenly spaced ones are used, as VOS-DE uses them.

As in the authors' code: a box of zero width is a missing detection and takes the box of the
nearest observation that has one (the farther one on a tie); an example whose A^T A is singular
(e.g. no detection at all) is unsolvable and predicts 0, and so is one whose camera never moved; one
solved with A^T A's condition number past 1 / eps (e.g. one detection in ten) keeps the authors'
answer and is counted ill-conditioned.

`odmd_conversion=True` reproduces how ODMD's converted ODMS sets read the masks (docs/ODMD.md):
observations are ordered far to near and chosen by truncating `linspace` in that order; a robot
example is its window of consecutive frames, so chosen from the far end; and camera movement k is
z_(n-1-k) - z_0 of the far-to-near order, the movements of the near-to-far order paired with the
far-to-near boxes. On the official test sets that gives the published Box_LS figures.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..store.box_rule import chosen_frames, example_boxes
from ..store.reader import Store
from .baseline_result import BaselineResult
from .least_squares import first_unknown, unmoved

DEFAULT_N_OBS = 10


def fill_missing(boxes: np.ndarray, prefer_later: bool) -> np.ndarray:
    """(E, k, 4) boxes with each zero-width box replaced by the nearest one present in its row;
    on a tie the later one when `prefer_later`, else the earlier. Rows with none stay as they are."""
    out = boxes.copy()
    present = boxes[..., 2] != 0
    k = boxes.shape[1]
    pos = np.arange(k)
    for e, j in zip(*np.nonzero(~present), strict=True):
        have = pos[present[e]]
        if len(have):
            dist = np.abs(have - j) * 2 - (have > j if prefer_later else have < j)
            out[e, j] = boxes[e, have[np.argmin(dist)]]
    return out


def solve(boxes: np.ndarray, move: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Batched Box_LS on (E, k, 4) boxes and (E, k) camera movements: (d1 estimates, unsolvable,
    ill-conditioned)."""
    E, k = move.shape
    w, h = boxes[..., 2], boxes[..., 3]
    A = np.zeros((E, 2 * k, 3))
    A[:, :k, 0], A[:, k:, 0] = w, h
    A[:, :k, 1], A[:, k:, 2] = 1.0, 1.0
    d1, bad, ill = first_unknown(A, np.concatenate([w * move, h * move], axis=1))
    bad |= unmoved(move)
    return np.where(bad, 0.0, d1), bad, ill & ~bad


def box_ls(store: Store, n_obs: int = DEFAULT_N_OBS, odmd_conversion: bool = False) -> BaselineResult:
    """Box_LS estimates for every example of `store` (d1 at the closest observation), from its
    boxes; it flags examples with a missing detection (a zero-width box) among the used observations."""
    if n_obs < 2:
        raise InputError(f"n_obs must be at least 2, got {n_obs}")
    counts = np.array([len(f) for f in chosen_frames(store, n_obs, odmd_conversion)], np.int64)
    E = store.n_examples
    d1, unsolvable, missing, ill = np.zeros(E), np.zeros(E, bool), np.zeros(E, bool), np.zeros(E, bool)
    for k in np.unique(counts):
        rows = np.flatnonzero(counts == k)
        ex = example_boxes(store, rows, n_obs, odmd_conversion)  # far first: fill from the farther
        missing[rows] = (ex.boxes[..., 2] == 0).any(axis=1)
        filled = fill_missing(ex.boxes, prefer_later=False)
        d1[rows], unsolvable[rows], ill[rows] = solve(filled, ex.move[..., 2])
    d1[unsolvable] = 0.0
    return BaselineResult(store.attrs.split, store.example_ids, d1, unsolvable, "missing_detections",
                          missing, ill)
