"""Shrinking binary masks with cv2 INTER_AREA, and doing it for a mask's box alone.

cv2's INTER_AREA weights depend only on the scale, so a crop whose edges fall on a whole period
of the input/output pixel grids (40 input columns per 7 output ones for 640 -> 112) shrinks to
exactly the same pixels as the full frame: `shrink_boxes` (stored masks, whose boxes the store
records) and batch_render.render_shrunk (generated masks) shrink only each object's box.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from ..store.masks import unpack

cv2.setNumThreads(1)


def resize_masks(masks: np.ndarray, size: tuple[int, int], coverage: bool = False) -> np.ndarray:
    """(k, H, W) binary masks to (k, h, w) with cv2 INTER_AREA: uint8 0/1 (the covered fraction
    rounded) or, with `coverage`, float32 fractions."""
    h, w = size
    k, H, W = masks.shape
    dtype = np.float32 if coverage else np.uint8
    m = masks.astype(dtype, copy=False)
    if (H, W) == (h, w):
        return m
    out = np.empty((k, h, w), dtype)
    for i in range(k):
        out[i] = cv2.resize(m[i], (w, h), interpolation=cv2.INTER_AREA)
    return out


def _aligned(a: int, b: int, period: int) -> tuple[int, int]:
    """[a, b) widened to multiples of period."""
    return a // period * period, -(-b // period) * period


def periods_of(full: tuple[int, int], size: tuple[int, int]) -> tuple[int, int, int, int]:
    """Input and output pixels per period of INTER_AREA's grid: rows py -> qy, columns px -> qx."""
    (H0, W0), (h, w) = full, size
    gy, gx = math.gcd(H0, h), math.gcd(W0, w)
    return H0 // gy, h // gy, W0 // gx, w // gx


def shrink_into(out: np.ndarray, crop: np.ndarray, X0: int, Y0: int, periods: tuple) -> None:
    """Write the INTER_AREA shrink of `crop`, the aligned region at (X0, Y0) of a full frame, into
    its place in `out`, the shrunk frame."""
    py, qy, px, qx = periods
    oy0, ox0 = Y0 // py * qy, X0 // px * qx
    oh, ow = crop.shape[0] // py * qy, crop.shape[1] // px * qx
    out[oy0 : oy0 + oh, ox0 : ox0 + ow] = cv2.resize(crop, (ow, oh), interpolation=cv2.INTER_AREA)


def shrink_packed(
    packed: np.ndarray, width: int, boxes: np.ndarray, size: tuple[int, int], coverage: bool = False
) -> np.ndarray:
    """`shrink_boxes(unpack(packed, width), boxes, size, coverage)` for (k, H, ceil(W/8)) packed
    masks (store.masks.pack), unpacking only each box widened to the grid: the widened columns
    start on a whole byte, as a period of the grid is a multiple of 8 columns when W is."""
    k, H0, _ = packed.shape
    periods = periods_of((H0, width), size)
    py, _, px, _ = periods
    if size[0] > H0 or size[1] > width or px % 8:
        return shrink_boxes(unpack(packed, width), boxes, size, coverage)
    out = np.zeros((k, *size), np.float32 if coverage else np.uint8)
    for j, (x0, y0, x1, y1) in enumerate(np.asarray(boxes, np.int64)):
        if x0 >= x1 or y0 >= y1:
            continue
        X0, X1 = _aligned(x0, x1, px)
        Y0, Y1 = _aligned(y0, y1, py)
        crop = np.unpackbits(packed[j, Y0:Y1, X0 // 8 : -(-X1 // 8)], axis=-1, count=X1 - X0)
        shrink_into(out[j], crop.astype(out.dtype, copy=False), int(X0), int(Y0), periods)
    return out


def shrink_boxes(masks: np.ndarray, boxes: np.ndarray, size: tuple[int, int], coverage: bool = False):
    """`resize_masks(masks, size, coverage)` for (k, H, W) masks whose objects lie inside `boxes`
    (k, 4: x0, y0, x1, y1 half-open, as stored): only each box, widened to the grid, is shrunk."""
    k, H0, W0 = masks.shape
    if size[0] > H0 or size[1] > W0:
        return resize_masks(masks, size, coverage)
    out = np.zeros((k, *size), np.float32 if coverage else np.uint8)
    periods = periods_of((H0, W0), size)
    py, _, px, _ = periods
    for j, (x0, y0, x1, y1) in enumerate(np.asarray(boxes, np.int64)):
        if x0 >= x1 or y0 >= y1:
            continue
        X0, X1 = _aligned(x0, x1, px)
        Y0, Y1 = _aligned(y0, y1, py)
        crop = masks[j, Y0:Y1, X0:X1].astype(out.dtype)
        shrink_into(out[j], crop, X0, Y0, periods)
    return out
