"""Binary masks: bit packing and the per-frame statistics stored beside them."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from types import ModuleType

import numpy as np


@cache
def _opencv() -> ModuleType:
    """OpenCV, loaded when the first statistics are computed: reading a store never needs it."""
    import cv2

    return cv2


def packed_width(width: int) -> int:
    """Bytes per packed row of a mask `width` pixels wide."""
    return (width + 7) // 8


def pack(masks: np.ndarray) -> np.ndarray:
    """Pack (..., H, W) binary masks into (..., H, ceil(W/8)) uint8, most significant bit first."""
    return np.packbits(masks.astype(bool, copy=False), axis=-1, bitorder="big")


def unpack(packed: np.ndarray, width: int) -> np.ndarray:
    """Inverse of `pack`: (..., H, ceil(W/8)) uint8 to (..., H, W) bool."""
    return np.unpackbits(packed, axis=-1, count=width, bitorder="big").view(bool)


@dataclass
class FrameStats:
    """Per-frame statistics of a block of k masks."""

    area: np.ndarray  # (k,) int32, object pixels
    largest_area: np.ndarray  # (k,) int32, pixels of the largest 8-connected region
    bbox: np.ndarray  # (k, 4) int32, x0, y0, x1, y1 half-open; zeros when empty

    @classmethod
    def empty(cls, k: int) -> FrameStats:
        return cls(
            np.zeros(k, np.int32), np.zeros(k, np.int32), np.zeros((k, 4), np.int32)
        )

    def set(self, i: int, mask: np.ndarray) -> None:
        """Record the statistics of `mask` as frame i."""
        self.area[i], self.largest_area[i], self.bbox[i] = mask_stats(mask)

    def copy(self, src: int, dst: int) -> None:
        """Frame dst has the statistics of frame src."""
        for a in (self.area, self.largest_area, self.bbox):
            a[dst] = a[src]


def largest_region(mask: np.ndarray, area: int) -> int:
    """Pixels of the largest 8-connected region of a 0/1 uint8 mask with `area` object pixels
    (cropped to its object, the labelling is cheaper)."""
    cv2 = _opencv()
    n_labels, labels = cv2.connectedComponents(np.ascontiguousarray(mask), connectivity=8, ltype=cv2.CV_32S)
    return area if n_labels == 2 else int(np.bincount(labels.ravel())[1:].max())


def mask_stats(mask: np.ndarray) -> tuple[int, int, tuple]:
    """Area, area of the largest 8-connected region and bounding box of one binary mask."""
    cv2 = _opencv()
    m = mask.view(np.uint8) if mask.dtype == bool else (mask != 0).view(np.uint8)
    area = cv2.countNonZero(m)
    if area == 0:
        return 0, 0, (0, 0, 0, 0)
    x, y, w, h = cv2.boundingRect(m)
    return area, largest_region(m[y : y + h, x : x + w], area), (x, y, x + w, y + h)


def packed_stats(packed: np.ndarray, width: int) -> FrameStats:
    """`mask_stats` of each of k packed masks (k, H, ceil(width/8)), unpacking only the rows and
    bytes that hold set bits: `unpack` of a whole block of large masks costs more than the rest
    of validating them. Bits past `width` (the padding) are not pixels, as in `unpack`."""
    stats = FrameStats.empty(len(packed))
    rows, cols = np.any(packed, axis=2), np.any(packed, axis=1)
    for i in range(len(packed)):
        ys, bs = np.flatnonzero(rows[i]), np.flatnonzero(cols[i])
        if len(ys) == 0:
            continue
        y0, b0 = int(ys[0]), int(bs[0])
        crop = packed[i, y0 : int(ys[-1]) + 1, b0 : int(bs[-1]) + 1]
        bits = min(crop.shape[1] * 8, width - 8 * b0)
        area, largest, (x0, y, x1, y1) = mask_stats(unpack(crop, bits))
        if area:
            stats.area[i], stats.largest_area[i] = area, largest
            stats.bbox[i] = (x0 + 8 * b0, y + y0, x1 + 8 * b0, y1 + y0)
    return stats
