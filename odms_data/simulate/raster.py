"""How a contour becomes a silhouette (generator v2): the rule of the authors' released generator,
computed exactly.

Pixel (x, y) is the half-open square [x, x + 1) x [y, y + 1) of contour coordinates. A pixel is
object when the closed contour passes through it, or when it is enclosed by such pixels: not
4-connected to the canvas border through pixels the contour misses. So a silhouette has no holes,
even where the contour crosses itself. The released generator marks the pixel of each of 2,000
points per Bezier segment and fills the holes; this marks every pixel each straight edge of the
contour polygon passes through, computed in float64 (where an edge runs exactly through a pixel
corner, its direction decides which of the pixels meeting there it marks).
"""

from __future__ import annotations

import cv2
import numpy as np

from ..errors import InputError

cv2.setNumThreads(1)
MAX_FILL_ROWS = 65536  # cv2.floodFill stops there


def contour_pixels(
    poly: np.ndarray, starts: np.ndarray, width: int, base: np.ndarray | None = None
) -> np.ndarray:
    """Flat indices `y * width + x + base[j]` of the pixels (x, y) that closed polygon j passes
    through, for an image `width` pixels wide; a pixel may appear more than once.

    `poly` (P, 2) holds the vertices x, y of every polygon, polygon j being rows starts[j] to
    starts[j + 1] - 1, closed by an edge from its last vertex back to its first. Going round a
    polygon from its first vertex, each grid line an edge crosses leads into the next pixel.
    """
    P = len(poly)
    succ = np.arange(1, P + 1)
    succ[starts[1:] - 1] = starts[:-1]
    nxt = poly[succ]
    # edges 0..P-1 cross the lines x = X, edges P..2P-1 (the same ones) the lines y = Y
    a0, a1 = poly.T.ravel(), nxt.T.ravel()  # from, to along the crossed axis
    b0 = poly[:, ::-1].T.ravel()  # from along the other axis
    first = np.floor(np.minimum(a0, a1)) + 1
    count = np.floor(np.maximum(a0, a1)) - first + 1
    crossing = np.flatnonzero(count > 0)  # the edges that cross a grid line
    count = count[crossing].astype(np.int64)
    edge = np.repeat(crossing, count)
    line = np.arange(len(edge)) + np.repeat(first[crossing] - (np.cumsum(count) - count), count)
    slope = (nxt[:, ::-1].T.ravel()[crossing] - b0[crossing]) / (a1[crossing] - a0[crossing])
    across = np.floor(b0[edge] + (line - a0[edge]) * np.repeat(slope, count))
    line -= (a1 < a0)[edge]  # moving down the axis, the pixel beyond line X is X - 1
    nx = int(count[: np.searchsorted(crossing, P)].sum())
    index = np.concatenate((across[:nx] * width + line[:nx], line[nx:] * width + across[nx:]))
    start = np.floor(poly[starts[:-1]])  # every other pixel is entered across a grid line
    index = np.concatenate((start[:, 1] * width + start[:, 0], index))
    if base is not None:
        index += np.concatenate((base, np.tile(np.repeat(base, np.diff(starts)), 2)[edge]))
    return index.astype(np.int64)


def fill_enclosed(canvas: np.ndarray, parts: np.ndarray | None = None) -> None:
    """In place on a uint8 0/1 image: every pixel not 4-connected through background to pixel
    (0, 0) of its part becomes 1.

    `parts` (ascending, from 0): the first rows of images stacked top to bottom, each with an
    empty border (default: one image). cv2.floodFill reaches at most 65,536 rows, so parts are
    filled a block at a time.
    """
    bounds = np.append([0] if parts is None else parts, len(canvas))
    start = 0
    while start < len(canvas):
        stop = bounds[np.searchsorted(bounds, start + MAX_FILL_ROWS, side="right") - 1]
        if stop <= start:
            raise InputError(f"cannot fill an image of more than {MAX_FILL_ROWS} rows; draw smaller objects")
        cv2.floodFill(canvas[start:stop], None, (0, 0), 2)
        start = stop
    cv2.threshold(canvas, 1, 1, cv2.THRESH_BINARY_INV, dst=canvas)


def draw_silhouette(canvas: np.ndarray, poly: np.ndarray) -> None:
    """Draw the silhouette of the closed polygon `poly` (m, 2; x, y in pixels) onto `canvas`
    (zeros, with at least one empty pixel between the polygon and every edge)."""
    canvas.ravel()[contour_pixels(poly, np.array([0, len(poly)]), canvas.shape[1])] = 1
    fill_enclosed(canvas)
