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
4. `inputs` (n_obs, 7): [box, movement] per observation, the movement then replaced by its change
   from the previous observation (0 for the first).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..benchmark import evenly_spaced
from ..errors import InputError

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

    n_obs: int = DBOX_OBS
    normalized: bool = True

    def __post_init__(self) -> None:
        if self.n_obs < 2:
            raise InputError(f"n_obs must be at least 2, got {self.n_obs}")

    def select(self, n: int) -> np.ndarray:
        """Which of an example's n frames give the boxes."""
        if not 2 <= self.n_obs <= n:
            raise InputError(f"need 2 <= n_obs <= n, got n_obs={self.n_obs} for an example of {n} frames")
        return evenly_spaced(0, n - 1, self.n_obs)

    def __call__(self, boxes: np.ndarray, move: np.ndarray, depth: float) -> dict[str, np.ndarray]:
        boxes, move = np.asarray(boxes), np.asarray(move)
        n = len(boxes)
        if boxes.shape != (n, 4) or move.shape != (n, 3):
            raise InputError(f"a box example needs boxes (n, 4) and move (n, 3), "
                             f"got {boxes.shape} and {move.shape}")
        x = np.zeros((self.n_obs, FEATURES), np.float32)
        x[:, :4] = fill_missed(boxes, self.select(n))
        x[:-1, 4:] = move[evenly_spaced(0, n - 2, self.n_obs - 1)]
        label = np.float32(depth)
        norm = np.float32(1)
        if self.normalized:
            norm = np.linalg.norm(x[:1, 4:], axis=1)[0]  # as the authors reduce, per row
            if not norm > 0:
                raise InputError("a box example whose first observation has no camera movement "
                                 "cannot be normalized")
            x[:, 4:] *= 1 / norm
            label = np.float32(label / norm)
        x[1:, 4:] = np.diff(x[:, 4:], axis=0)
        x[0, 4:] = 0
        return {"inputs": x, "depth_norm": np.asarray(label, np.float32),
                "norm": np.asarray(norm, np.float32), "depth": np.asarray(depth, np.float32)}


DBOX_TRANSFORM = BoxTransform()
