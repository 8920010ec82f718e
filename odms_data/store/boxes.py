"""The box of each frame's object, as ODMD (Griffin & Corso, CVPR 2021) defines it, from the masks.

The rule, measured on ODMD's own conversion of the ODMS release (docs/ODMD.md has the figures):

- the pixels that count are those of the mask's largest 8-connected region (the first in raster
  order when regions tie), the region VOS-DE measures as `largest_area`;
- with x_min, x_max, y_min, y_max the extreme pixel columns and rows of that region (inclusive),
  the box is [x_c, y_c, w, h] = [(x_min + x_max) / 2 / W, (y_min + y_max) / 2 / H,
  (x_max - x_min) / W, (y_max - y_min) / H]: so a region one pixel wide has w = 0;
- an empty mask gives [0, 0, 0, 0].

Frames whose mask is one region (largest_area == area) take their box from the stored `bbox`
without decoding; the others decode their mask once.
"""

from __future__ import annotations

import numpy as np

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
    rect = store.bbox[frames].astype(np.int64)
    several = np.flatnonzero(store.largest_area[frames] < store.area[frames])
    for i in several:  # more than one region: the box is the largest one's, read from the mask
        x0, y0, x1, y1 = rect[i]
        mask = store.read_masks(frames[i : i + 1])[0, y0:y1, x0:x1]
        rx0, ry0, rx1, ry1 = largest_region_rect(mask)
        rect[i] = (x0 + rx0, y0 + ry0, x0 + rx1, y0 + ry1)
    return box_of_region(rect[:, 0], rect[:, 1], rect[:, 2], rect[:, 3], store.width, store.height)


def store_boxes(store: Store) -> np.ndarray:
    """(F, 4) ODMD boxes of every frame of `store`, in frame-row order."""
    return frame_boxes(store, np.arange(store.n_frames))
