"""The box of each frame's object, as ODMD (Griffin & Corso, CVPR 2021) defines it, from the masks.

The rule, measured on ODMD's own conversion of the ODMS release (docs/ODMD.md has the figures):

- the pixels that count are those of the mask's largest 8-connected region (the first in raster
  order when regions tie), the region VOS-DE measures as `largest_area`;
- with x_min, x_max, y_min, y_max the extreme pixel columns and rows of that region (inclusive),
  the box is [x_c, y_c, w, h] = [(x_min + x_max) / 2 / W, (y_min + y_max) / 2 / H,
  (x_max - x_min) / W, (y_max - y_min) / H]: so a region one pixel wide has w = 0;
- an empty mask gives [0, 0, 0, 0].

Frames whose mask is one region (largest_area == area) take their box from the stored `bbox`
without decoding; the others decode their mask once. A store of boxes (FORMAT.md, version 2)
gives its stored boxes and movements as they are, its frames already in ODMD's order.

`example_boxes` gives whole examples as DBox and Box_LS take them (loaders/box_transform.py's
convention): ODMD's orientation, frames far to near, the label the depth at the last (closest)
frame, which for a mask store is its d1. The movement of frame k is the object's displacement
from frame k to the last one: (0, 0, z_last - z_k), ODMS cameras moving along the optical axis
only. With `odmd_conversion` the frames and movements are those of ODMD's converted ODMS sets
(docs/ODMD.md): frames chosen far-first, robot windows from their far end, and movement k
z_(n-1-k) - z_0, the near-first order's movements paired with the far-first boxes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..protocol import evenly_spaced, observation_indices
from .masks import _opencv
from .reader import Store


def box_of_region(x0: np.ndarray, y0: np.ndarray, x1: np.ndarray, y1: np.ndarray, width: int,
                  height: int) -> np.ndarray:
    """(k, 4) ODMD boxes [x_c, y_c, w, h] of half-open pixel rectangles [x0, x1) x [y0, y1)
    (all zeros where the rectangle is empty)."""
    x0, y0 = np.asarray(x0, np.float64), np.asarray(y0, np.float64)
    xm, ym = np.asarray(x1, np.float64) - 1, np.asarray(y1, np.float64) - 1  # inclusive maxima
    out = np.stack([(x0 + xm) / 2 / width, (y0 + ym) / 2 / height, (xm - x0) / width,
                    (ym - y0) / height], axis=-1)
    out[(np.asarray(x1) <= np.asarray(x0)) | (np.asarray(y1) <= np.asarray(y0))] = 0.0
    return out


def largest_region_rect(mask: np.ndarray) -> tuple[int, int, int, int]:
    """Half-open rectangle (x0, y0, x1, y1) of the largest 8-connected region of a 2-D mask (the
    first in raster order on a tie); zeros for an empty mask."""
    cv2 = _opencv()
    m = np.ascontiguousarray(mask, dtype=np.uint8)
    n, _, stats, _ = cv2.connectedComponentsWithStats(m, connectivity=8, ltype=cv2.CV_32S)
    if n < 2:
        return 0, 0, 0, 0
    k = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
    x, y, w, h = (int(v) for v in stats[k, :4])
    return x, y, x + w, y + h


def frame_boxes(store: Store, frames: np.ndarray) -> np.ndarray:
    """(k, 4) float64 ODMD boxes [x_c, y_c, w, h] (normalised by the image size) of the given
    frame rows of `store`."""
    frames = np.asarray(frames, np.int64)
    if store.kind == "boxes":
        return store.box[frames]
    rect = store.bbox[frames].astype(np.int64)
    several = np.flatnonzero(store.largest_area[frames] < store.area[frames])
    for i in several:  # more than one region: the box is the largest one's, read from the mask
        x0, y0, x1, y1 = rect[i]
        mask = store.read_masks(frames[i : i + 1])[0, y0:y1, x0:x1]
        rx0, ry0, rx1, ry1 = largest_region_rect(mask)
        rect[i] = (x0 + rx0, y0 + ry0, x0 + rx1, y0 + ry1)
    return box_of_region(rect[:, 0], rect[:, 1], rect[:, 2], rect[:, 3], store.width, store.height)


@dataclass(frozen=True)
class BoxExamples:
    """E box examples of n frames each, far to near: `boxes` (E, n, 4) [x_c, y_c, w, h]
    normalised, `move` (E, n, 3) the object's displacement in x, y, z from each frame to the last
    (m; the last row 0), `depth` (E,) the label at the last frame (m), and `frames` (E, n) the
    store's frame rows they come from."""

    boxes: np.ndarray
    move: np.ndarray
    depth: np.ndarray
    frames: np.ndarray


def _window(row: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The consecutive frame rows from an example's first to its last frame, when their z
    ascends (a robot window, say); else the example's own frames."""
    run = np.arange(row[0], row[-1] + 1)
    return run if len(run) > len(row) and np.all(np.diff(z[run]) > 0) else row


def example_frames(store: Store, i: int, n_obs: int, odmd_conversion: bool) -> np.ndarray:
    """The frame rows of example `i` that give its boxes: as VOS-DE chooses them, closest first
    (default), or as ODMD's conversion chooses them, farthest first."""
    row = store.frames_of(i)
    if store.kind == "boxes":  # in ODMD's order already, far to near
        if odmd_conversion:
            raise InputError(f"{store.path}: ODMD's conversion reads stores of masks; this one holds boxes")
        return row[observation_indices(len(row), n_obs)]
    if not odmd_conversion:
        return row[observation_indices(len(row), n_obs)]
    far_first = _window(row, store.z)[::-1]
    n = len(far_first)
    return far_first if n <= n_obs else far_first[evenly_spaced(0, n - 1, n_obs)]


def chosen_frames(store: Store, n_obs: int, odmd_conversion: bool) -> list[np.ndarray]:
    """`example_frames` of every example of `store`; an n_obs beyond an example's frames is refused
    naming the store and the example, as the loaders do."""
    chosen = []
    for i in range(store.n_examples):
        try:
            chosen.append(example_frames(store, i, n_obs, odmd_conversion))
        except InputError as e:
            raise InputError(f"{store.path}: example {store.example_ids[i]}: {e}") from None
    return chosen


def example_boxes(store: Store, rows: np.ndarray | list[int], n_obs: int = 10,
                  odmd_conversion: bool = False) -> BoxExamples:
    """The box examples of example `rows` of `store`, far to near, n_obs frames each (an example of
    fewer is refused; ODMD's conversion takes at most n_obs of its window), the same number for
    every row asked for."""
    rows = np.asarray(rows, np.int64)
    chosen = [example_frames(store, int(i), n_obs, odmd_conversion) for i in rows]
    counts = {len(f) for f in chosen}
    if len(counts) > 1:
        raise InputError(f"{store.path}: examples of {min(counts)} to {max(counts)} frames asked for "
                         f"together with n_obs={n_obs}; ask for examples of one length at a time")
    n = counts.pop() if counts else n_obs
    f = np.stack(chosen) if chosen else np.zeros((0, n), np.int64)
    if not odmd_conversion and store.kind == "masks":
        f = f[:, ::-1]  # near-first as chosen; far-first as ODMD orders them
    used, inverse = np.unique(f, return_inverse=True)
    boxes = frame_boxes(store, used)[inverse.reshape(f.shape)] if f.size else np.zeros((*f.shape, 4))
    if store.kind == "boxes":  # movements to the last frame chosen (the example's last)
        stored = store.move[f]
        return BoxExamples(boxes, stored - stored[:, -1:], store.d1[rows].astype(np.float64), f)
    z = store.z
    move = np.zeros((*f.shape, 3))
    if odmd_conversion:  # the near-first order's movements, as ODMD pairs them
        move[:, :-1, 2] = z[f[:, ::-1][:, :-1]] - z[f[:, :1]]
    else:
        move[:, :, 2] = z[f[:, -1:]] - z[f]
    return BoxExamples(boxes, move, store.d1[rows].astype(np.float64), f)
