"""Box_LS, the least-squares baseline of ODMD (Griffin & Corso, CVPR 2021), on any store.

A box's width and height shrink with depth: with D_k = d1 + (z_k - z_1) the object's depth at
observation k (z_1 the closest observation), w_k D_k and h_k D_k are constants c_w, c_h. Least
squares over the observations of

    [w_k, 1, 0] [d1, -c_w, -c_h]^T = w_k m_k,    [h_k, 0, 1] [d1, -c_w, -c_h]^T = h_k m_k,

with m_k = z_1 - z_k the camera movement to the closest observation, gives the estimate d1.
Boxes are ODMD's boxes of the masks (store/boxes.py). With more than N observations, N evenly
spaced ones are used, as VOS-DE uses them.

As in the authors' code: a box of zero width is a missing detection and takes the box of the
nearest observation that has one (the farther one on a tie); an example whose A^T A is singular
(e.g. no detection at all) is unsolvable and predicts 0.

`odmd_conversion=True` reproduces how ODMD's converted ODMS sets read the masks (docs/ODMD.md):
observations are ordered far to near and chosen by truncating `linspace` in that order; a robot
example is its window of consecutive frames, so chosen from the far end; and camera movement k is
z_(n-1-k) - z_0 of the far-to-near order, the movements of the near-to-far order paired with the
far-to-near boxes. On the official test sets that gives the published Box_LS figures.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..protocol import evenly_spaced
from ..store.boxes import frame_boxes
from ..store.reader import Store
from .baseline_result import BaselineResult
from .vosde import observation_columns

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


def solve(boxes: np.ndarray, move: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Batched Box_LS on (E, k, 4) boxes and (E, k) camera movements: (d1 estimates, unsolvable)."""
    E, k = move.shape
    w, h = boxes[..., 2], boxes[..., 3]
    A = np.zeros((E, 2 * k, 3))
    A[:, :k, 0], A[:, k:, 0] = w, h
    A[:, :k, 1], A[:, k:, 2] = 1.0, 1.0
    b = np.concatenate([w * move, h * move], axis=1)
    At = A.swapaxes(1, 2)
    AtA, Atb = At @ A, At @ b[..., None]
    d1, bad = np.zeros(E), np.zeros(E, bool)
    try:
        return np.linalg.solve(AtA, Atb)[:, 0, 0], bad
    except np.linalg.LinAlgError:
        pass  # at least one singular system: solve one by one to find which
    for i in range(E):
        try:
            d1[i] = np.linalg.solve(AtA[i], Atb[i])[0, 0]
        except np.linalg.LinAlgError:
            bad[i] = True
    return d1, bad


def _window(row: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The consecutive frame rows from an example's first to its last frame, when their z
    ascends (a robot window, say); else the example's own frames."""
    run = np.arange(row[0], row[-1] + 1)
    return run if len(run) > len(row) and np.all(np.diff(z[run]) > 0) else row


def chosen_frames(store: Store, n_obs: int, odmd_conversion: bool) -> list[np.ndarray]:
    """Per example, the frame rows Box_LS uses, closest first (default) or farthest first (ODMD)."""
    out = []
    for i in range(store.n_examples):
        row = store.frames_of(i)
        if not odmd_conversion:
            out.append(row[observation_columns(len(row), n_obs)])
            continue
        far_first = _window(row, store.z)[::-1]
        n = len(far_first)
        out.append(far_first if n <= n_obs else far_first[evenly_spaced(0, n - 1, n_obs)])
    return out


def box_ls(store: Store, n_obs: int = DEFAULT_N_OBS, odmd_conversion: bool = False) -> BaselineResult:
    """Box_LS estimates for every example of `store` (d1 at the closest observation), from the boxes
    of its masks; it flags examples with a missing detection (a zero-width box) among the used
    observations."""
    if n_obs < 2:
        raise InputError(f"n_obs must be at least 2, got {n_obs}")
    frames = chosen_frames(store, n_obs, odmd_conversion)
    used = np.unique(np.concatenate(frames)) if frames else np.zeros(0, np.int64)
    boxes_of = np.zeros((store.n_frames, 4))
    boxes_of[used] = frame_boxes(store, used)
    z = store.z
    E = store.n_examples
    d1, unsolvable, missing = np.zeros(E), np.zeros(E, bool), np.zeros(E, bool)
    counts = np.array([len(f) for f in frames])
    for k in np.unique(counts):
        rows = np.flatnonzero(counts == k)
        f = np.stack([frames[r] for r in rows])  # (e, k)
        boxes = boxes_of[f]
        missing[rows] = (boxes[..., 2] == 0).any(axis=1)
        if odmd_conversion:  # far first; the movements of the near-first order, as ODMD pairs them
            move = np.zeros(f.shape)
            move[:, :-1] = z[f[:, ::-1][:, :-1]] - z[f[:, :1]]
        else:
            move = z[f[:, :1]] - z[f]
        d1[rows], unsolvable[rows] = solve(fill_missing(boxes, prefer_later=not odmd_conversion), move)
    d1[unsolvable] = 0.0
    return BaselineResult(store.attrs.split, store.example_ids, d1, unsolvable, "missing_detections", missing)
