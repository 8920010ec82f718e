"""The shrink kernels against cv2.resize with INTER_AREA: the same float32 values, bit for bit, on
random canvases anywhere in (or partly out of) the frame, at scales cv2 treats each way; and the
same frames read from their packed bits (shrink_packed)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from odms_data.simulate.shrink import shrink_canvases, shrink_packed, shrink_tables
from odms_data.store.masks import pack

FULL = (480, 640)


SIZES = [(112, 112), (28, 28), (100, 90), (479, 640), (112, 160), (120, 160), (7, 9)]
WHOLE = [(120, 160)]  # cv2's fast path; render_shrunk leaves its uint8 masks to cv2
CASES = [(s, False) for s in SIZES] + [(s, True) for s in SIZES if s not in WHOLE]


@pytest.mark.parametrize(("size", "rounded"), CASES)
def test_kernels_shrink_as_cv2_shrinks_the_whole_frame(size, rounded):
    rng = np.random.default_rng(sum(size))
    F, (H, W) = 24, FULL
    extent = rng.integers(5, 300, (F, 2))
    lo = np.stack([rng.integers(-50, W - 10, F), rng.integers(-50, H - 10, F)], axis=1)
    tops = np.concatenate([[0], np.cumsum(extent[:, 1])])
    canvases = np.zeros((tops[-1], extent[:, 0].max()), np.uint8)
    for f, (w, h) in enumerate(extent):
        canvases[tops[f] : tops[f + 1], :w] = rng.random((h, w)) < rng.random()
    out = np.zeros((F, *size), np.uint8 if rounded else np.float32)
    shrink_canvases(canvases, tops[:-1], lo, lo + extent, out, rounded, *shrink_tables(FULL, size))
    frames = np.zeros((F, H + 600, W + 600), np.uint8)  # room for each canvas beyond the frame
    for f, ((x0, y0), (w, h)) in enumerate(zip(lo, extent, strict=True)):
        frames[f, y0 + 300 : y0 + 300 + h, x0 + 300 : x0 + 300 + w] = canvases[tops[f] : tops[f + 1], :w]
    frames = frames[:, 300 : 300 + H, 300 : 300 + W]
    values = frames if rounded else frames.astype(np.float32)
    want = np.stack([cv2.resize(m, size[::-1], interpolation=cv2.INTER_AREA) for m in values])
    assert np.array_equal(out, want)
    assert out.any() and (out < 1).any()
    boxes = np.concatenate([np.maximum(lo, 0), np.minimum(lo + extent, [W, H])], axis=1)
    assert np.array_equal(shrink_packed(pack(frames), W, boxes, size, not rounded), want)
