"""Shrinking binary masks with cv2 INTER_AREA, and doing it for a mask's box alone.

cv2's INTER_AREA weights depend only on the scale, so a crop whose edges fall on a whole period
of the input/output pixel grids (40 input columns per 7 output ones for 640 -> 112) shrinks to
exactly the same pixels as the full frame: `shrink_boxes` (stored masks, whose boxes the store
records) shrinks only each object's box.

`shrink_canvases` (generated masks, batch_render.render_shrunk) computes cv2's result itself, in
cv2's own float32 operations and order, from the object's pixels alone (tests/simulate/
test_shrink.py checks it against cv2.resize). When the scale is not a whole number on both axes,
cv2 sums each source row's pixels times their column weights into each output column, then each
output pixel is the sum, in row order, of its rows' sums times their row weights; weights come
from cv2's table (`area_weights`). On whole-number scales (cv2's fast path) an output pixel is
the count of its source pixels set times 1 / area; both are the same loop with other tables.
"""

from __future__ import annotations

import math
from functools import lru_cache

import cv2
import numba
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


@lru_cache(maxsize=16)
def area_weights(full: int, small: int, whole: bool) -> tuple[np.ndarray, np.ndarray]:
    """For each of `full` source pixels along an axis shrunk to `small`: the (up to two) output
    pixels it adds to, -1 where none, and its float32 weights, as cv2's INTER_AREA tables them
    (`whole`: cv2's fast path for whole-number scales, every weight 1)."""
    dest, weight = np.full((full, 2), -1, np.int64), np.zeros((full, 2), np.float32)
    if whole:
        dest[:, 0], weight[:, 0] = np.arange(full) // (full // small), 1
        return dest, weight
    scale = full / small
    for d in range(small):  # cv2's computeResizeAreaTab, in double, each weight cast to float
        f1, f2 = d * scale, (d + 1) * scale
        cell = min(scale, full - f1)
        s2 = min(math.floor(f2), full - 1)
        s1 = min(math.ceil(f1), s2)
        parts = [(s1 - 1, (s1 - f1) / cell)] if s1 - f1 > 1e-3 else []
        parts += [(s, 1 / cell) for s in range(s1, s2)]
        if f2 - s2 > 1e-3:
            parts.append((s2, min(min(f2 - s2, 1.0), cell) / cell))
        for s, w in parts:
            j = 0 if dest[s, 0] < 0 else 1
            dest[s, j], weight[s, j] = d, np.float32(w)
    return dest, weight


def shrink_tables(full: tuple[int, int], size: tuple[int, int]) -> tuple:
    """shrink_canvases' tables and final factor for frames of `full` (H, W) shrunk to `size`."""
    (H, W), (h, w) = full, size
    whole = H % h == 0 and W % w == 0
    factor = np.float32(1) / np.float32(H // h * (W // w)) if whole else np.float32(1)
    return (*area_weights(H, h, whole), *area_weights(W, w, whole), factor)


@numba.njit(cache=True, nogil=True)
def shrink_canvases(canvases, tops, lo, hi, out, rounded, ydest, yweight, xdest, xweight, factor):
    """out[f] (zeros; float32 coverage, or with `rounded` the uint8 coverage rounded to nearest,
    ties to even, as cv2 rounds outside its fast path)
    = cv2 INTER_AREA of a full frame that is zero but for canvas f: rows tops[f] .. of
    `canvases`, columns 0 .., placed at lo[f] (x, y) of the frame (hi[f]: its far corner,
    exclusive; the frame clips it). Tables: shrink_tables."""
    H0, W0, w = len(ydest), len(xdest), out.shape[2]
    buf = np.zeros(w, np.float32)
    acc = np.zeros((out.shape[1], w), np.float32)
    for f in range(len(tops)):
        x0, y0 = lo[f, 0], lo[f, 1]
        cx0, cx1, cy0, cy1 = max(x0, 0), min(hi[f, 0], W0), max(y0, 0), min(hi[f, 1], H0)
        if cx0 >= cx1 or cy0 >= cy1:
            continue
        dx0, dx1 = xdest[cx0, 0], max(xdest[cx1 - 1, 0], xdest[cx1 - 1, 1]) + 1
        dy0, dy1 = ydest[cy0, 0], max(ydest[cy1 - 1, 0], ydest[cy1 - 1, 1]) + 1
        acc[dy0:dy1, dx0:dx1] = 0
        for sy in range(cy0, cy1):
            row = canvases[tops[f] + sy - y0, cx0 - x0 : cx1 - x0]
            buf[dx0:dx1] = 0
            drawn = False
            for i in range(len(row)):
                if row[i]:  # cv2 adds pixel * weight; a zero pixel adds nothing
                    drawn = True
                    for j in range(2):
                        if xdest[cx0 + i, j] >= 0:
                            buf[xdest[cx0 + i, j]] += xweight[cx0 + i, j]
            if drawn:
                for j in range(2):
                    dy, beta = ydest[sy, j], yweight[sy, j]
                    if dy >= 0:
                        for dx in range(dx0, dx1):
                            acc[dy, dx] += beta * buf[dx]
        for dy in range(dy0, dy1):
            for dx in range(dx0, dx1):
                v = acc[dy, dx] * factor
                if rounded:
                    out[f, dy, dx] = np.rint(v)
                else:
                    out[f, dy, dx] = v
