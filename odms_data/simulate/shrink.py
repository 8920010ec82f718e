"""Shrinking binary masks with cv2 INTER_AREA, and doing it for the object's pixels alone.

`resize_masks` calls cv2. `shrink_canvases` computes cv2's result itself, in cv2's own float32
operations and order, from the pixels of each object's region only: for generated masks
(batch_render.render_shrunk), and for stored ones (`shrink_packed`, each stored box's bits
unpacked first). tests/simulate/test_shrink.py checks both against cv2.resize bit for bit.

When the scale is not a whole number on both axes, cv2 sums each source row's pixels times their
column weights into each output column, then each output pixel is the sum, in row order, of its
rows' sums times their row weights, the weights from cv2's table (`area_weights`); a zero pixel
adds nothing, so only the object's region needs visiting. On whole-number scales (cv2's fast
path) an output pixel is the count of its source pixels set times 1 / area: the same loop with
other tables.
"""

from __future__ import annotations

import math
from functools import lru_cache

import cv2
import numpy as np

from ..errors import InputError
from ..store.masks import unpack
from .kernel import kernel


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


def computes_like_cv2(full: tuple[int, int], size: tuple[int, int], coverage: bool) -> bool:
    """Whether the kernels give cv2's result: cv2 shrinks both axes (no axis grows), and uint8
    masks are not at whole-number scales (cv2's fast path rounds those its own way)."""
    (H, W), (h, w) = full, size
    return h <= H and w <= W and (coverage or H % h != 0 or W % w != 0)


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
    """The kernels' tables and final factor for frames of `full` (H, W) shrunk to `size`."""
    (H, W), (h, w) = full, size
    whole = H % h == 0 and W % w == 0
    factor = np.float32(1) / np.float32(H // h * (W // w)) if whole else np.float32(1)
    return (*area_weights(H, h, whole), *area_weights(W, w, whole), factor)


def stacked_canvases(extent: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A zero uint8 image holding canvases of `extent` (k, 2: width, height) top to bottom, as
    wide as the widest, and the row where each begins."""
    ends = np.cumsum(extent[:, 1])
    image = np.zeros((int(ends[-1]) if len(ends) else 0, int(extent[:, 0].max(initial=1))), np.uint8)
    return image, ends - extent[:, 1]


@kernel
def shrink_canvases(canvases, tops, lo, hi, out, rounded, ydest, yweight, xdest, xweight, factor):
    """out[f] (zeros; float32 coverage, or with `rounded` the uint8 coverage rounded to nearest,
    ties to even, as cv2 rounds outside its fast path) = cv2 INTER_AREA of a full frame that is
    zero but for canvas f: rows tops[f] .. of `canvases`, columns 0 .., placed at lo[f] (x, y)
    of the frame (hi[f]: its far corner, exclusive; the frame clips it). Tables: shrink_tables."""
    H0, W0, w = len(ydest), len(xdest), out.shape[2]
    buf, acc = np.zeros(w, np.float32), np.zeros((out.shape[1], w), np.float32)
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
            if _shrink_row(row, cx0, buf, xdest, xweight):
                _spread_row(acc, buf, ydest[sy], yweight[sy], dx0, dx1)
        _store(acc, out[f], dy0, dy1, dx0, dx1, factor, rounded)


@kernel
def _shrink_row(row, cx0, buf, xdest, xweight):
    """Add the source row's pixels (columns cx0 ..) into `buf` by their destination columns;
    whether any was drawn."""
    drawn = False
    for i in range(len(row)):
        if row[i]:  # cv2 adds pixel * weight; a zero pixel adds nothing
            drawn = True
            for j in range(2):
                if xdest[cx0 + i, j] >= 0:
                    buf[xdest[cx0 + i, j]] += xweight[cx0 + i, j]
    return drawn


@kernel
def _spread_row(acc, buf, ydest, yweight, dx0, dx1):
    """Add the shrunk row `buf` into its (up to two) destination rows with their weights."""
    for j in range(2):
        dy, beta = ydest[j], yweight[j]
        if dy >= 0:
            for dx in range(dx0, dx1):
                acc[dy, dx] += beta * buf[dx]


@kernel
def _store(acc, out, dy0, dy1, dx0, dx1, factor, rounded):
    """out (one frame) = the accumulated coverage times `factor`, rounded to uint8 with `rounded`."""
    for dy in range(dy0, dy1):
        for dx in range(dx0, dx1):
            v = acc[dy, dx] * factor
            if rounded:
                out[dy, dx] = np.rint(v)
            else:
                out[dy, dx] = v


@kernel
def _unpack_boxes(packed, boxes, canvases, tops):
    """Box f of packed frame f (big-endian bits) as 0/1 bytes at rows tops[f] .., columns 0 .. of
    `canvases` (zeros); whole zero bytes are skipped."""
    for f in range(len(packed)):
        x0, y0, x1, y1 = boxes[f, 0], boxes[f, 1], boxes[f, 2], boxes[f, 3]
        for sy in range(y0, y1):
            bits, row = packed[f, sy], canvases[tops[f] + sy - y0]
            for b in range(x0 >> 3, (x1 + 7) >> 3):
                if bits[b]:  # mostly whole bytes of background or of object
                    for x in range(max(8 * b, x0), min(8 * b + 8, x1)):
                        row[x - x0] = (bits[b] >> (7 - (x & 7))) & 1


def shrink_packed(
    packed: np.ndarray,
    width: int,
    boxes: np.ndarray,
    size: tuple[int, int],
    coverage: bool = False,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """`resize_masks(unpack(packed, width), size, coverage)` for (k, H, ceil(W/8)) packed masks
    (store.masks.pack) whose objects lie inside `boxes` (k, 4: x0, y0, x1, y1 half-open, as
    stored), reading only each box's bits; written into `out` (k, h, w) when given."""
    k, H0, _ = packed.shape
    dtype = np.float32 if coverage else np.uint8
    if not computes_like_cv2((H0, width), size, coverage):
        shrunk = resize_masks(unpack(packed, width), size, coverage)
        if out is None:
            return shrunk
        out[...] = shrunk
        return out
    if out is None:
        out = np.zeros((k, *size), dtype)
    else:
        out[...] = 0
    boxes = np.asarray(boxes, np.int64).reshape(k, 4)
    outside = (boxes[:, :2] < 0).any(axis=1) | (boxes[:, 2] > width) | (boxes[:, 3] > H0)
    if outside.any() or packed.shape[2] * 8 < width:
        j = int(np.argmax(outside))
        raise InputError(f"frame {j}: box {tuple(boxes[j].tolist())} is not inside its {width}x{H0} "
                         f"frame of {packed.shape[2]} bytes a row")
    canvases, tops = stacked_canvases(np.maximum(boxes[:, 2:] - boxes[:, :2], 0))  # an empty box: no rows
    _unpack_boxes(packed, boxes, canvases, tops)
    tables = shrink_tables((H0, width), size)
    shrink_canvases(canvases, tops, boxes[:, :2], boxes[:, 2:], out, not coverage, *tables)
    return out
