"""DBox's network inputs (Griffin & Corso, CVPR 2021) from one box example, framework-free, as
the authors' released code builds them (griffbr/ODMD, dbox/model_utils.py, BoundingBoxToNetwork).

A box example is, per frame i of n: `boxes` (n, 4) [xc, yc, w, h], each divided by the image
width (x, w) or height (y, h); `move` (n, 3) the object's displacement in x, y, z from frame i to
the last frame, m (ODMD's camera movement: the camera moves the opposite way; the last row is 0);
and the label `depth`, the object's depth at the last frame, m.

The inputs, in float32 throughout, in the authors' order of operations:

1. `n_obs` frames, `linspace(0, n-1, n_obs)` truncated; a frame whose box has zero width (a missed
   detection) takes the box of the nearest frame with one (the earlier on a tie, frame 0 if none).
2. Movements at `linspace(0, n-2, n_obs-1)` truncated, then a zero row for the last observation
   (the same frames as step 1 when n == n_obs, the only case ODMD's sets and generator have).
3. `normalized` (DBox; not DBox_Abs): movements and label divided by `norm`, the length of the
   first observation's movement, so the network predicts depth in units of the camera's travel.
4. `inputs` (n_obs, 7): [box, movement] per observation; with `relative` (DBox, not DBox_Abs:
   the authors' `sequence_dist`) the movement then replaced by its change from the previous
   observation (0 for the first).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..errors import InputError
from ..protocol import evenly_spaced, observation_indices

DBOX_OBS = 10  # observations DBox takes (ODMD's num_pos)
FEATURES = 7  # per observation: 4 box coordinates, 3 movement components


def fill_missed(boxes: np.ndarray, chosen: np.ndarray) -> np.ndarray:
    """The boxes of frames `chosen`, each of zero width replaced by the box of the nearest frame
    (of all n) with a nonzero width, the earlier one on a tie; by frame 0's if no frame has one."""
    out = boxes[chosen].copy()
    valid = np.flatnonzero(boxes[:, 2] != 0)
    for k in np.flatnonzero(out[:, 2] == 0):
        out[k] = boxes[valid[np.argmin(np.abs(valid - chosen[k]))]] if len(valid) else boxes[0]
    return out


@dataclass(frozen=True)
class BoxTransform:
    """One box example (boxes (n, 4), move (n, 3), depth) to DBox's inputs: `inputs` (n_obs, 7),
    the label `depth_norm` (the depth divided by `norm`; the depth itself when not normalized),
    `norm` (1 when not normalized) and `depth`, all float32."""

    kind: ClassVar[str] = "boxes"  # the kind of example it takes (kinds.py)
    n_obs: int = DBOX_OBS
    normalized: bool = True
    relative: bool = True

    def __post_init__(self) -> None:
        if self.n_obs < 2:
            raise InputError(f"n_obs must be at least 2, got {self.n_obs}")

    def select(self, n: int) -> np.ndarray:
        """Which of an example's n frames give the boxes."""
        return observation_indices(n, self.n_obs)

    def __call__(self, boxes: np.ndarray, move: np.ndarray, depth: float) -> dict[str, np.ndarray]:
        """One example's inputs: boxes (n, 4), move (n, 3), depth."""
        return {k: v[0] for k, v in self.batch(np.asarray(boxes)[None], np.asarray(move)[None],
                                               np.asarray(depth)[None]).items()}

    def batch(self, boxes: np.ndarray, move: np.ndarray, depth: np.ndarray) -> dict[str, np.ndarray]:
        """The inputs of B examples of n frames: boxes (B, n, 4), move (B, n, 3), depth (B,); each
        example's the same as alone (the operations are element-wise or per example)."""
        boxes, move, depth = np.asarray(boxes), np.asarray(move), np.asarray(depth)
        b, n = boxes.shape[:2]
        if boxes.shape != (b, n, 4) or move.shape != (b, n, 3) or depth.shape != (b,):
            raise InputError(f"box examples need boxes (n, 4), move (n, 3) and a depth each, "
                             f"got {boxes.shape[1:]}, {move.shape[1:]} and {depth.shape[1:]}")
        chosen = self.select(n)
        x = np.zeros((b, self.n_obs, FEATURES), np.float32)
        x[:, :, :4] = boxes[:, chosen]
        for k in np.flatnonzero((boxes[:, chosen, 2] == 0).any(axis=1)):
            x[k, :, :4] = fill_missed(boxes[k], chosen)
        x[:, :-1, 4:] = move[:, evenly_spaced(0, n - 2, self.n_obs - 1)]
        label = depth.astype(np.float32)
        norm = np.ones(b, np.float32)
        if self.normalized:
            norm = np.linalg.norm(x[:, 0, 4:], axis=1)  # as the authors reduce, per row
            if not np.all(norm > 0):
                raise InputError("a box example whose first observation has no camera movement "
                                 "cannot be normalized")
            x[:, :, 4:] *= (1 / norm)[:, None, None]
            label = label / norm
        if self.relative:
            x[:, 1:, 4:] = np.diff(x[:, :, 4:], axis=1)
            x[:, 0, 4:] = 0
        return {"inputs": x, "depth_norm": label, "norm": norm, "depth": depth.astype(np.float32)}


DBOX_TRANSFORM = BoxTransform()
