"""How a contour becomes a silhouette (generator v2): the rule of the authors' released generator,
computed exactly, compiled with Numba.

Pixel (x, y) is the half-open square [x, x + 1) x [y, y + 1) of contour coordinates. A pixel is
object when the closed contour passes through it, or when it is enclosed by such pixels: not
4-connected to the canvas border through pixels the contour misses. So a silhouette has no holes,
even where the contour crosses itself. The released generator marks the pixel of each of 2,000
points per Bezier segment and fills the holes; this marks every pixel each straight edge of the
contour polygon passes through, computed in float64 (where an edge runs exactly through a pixel
corner, its direction decides which of the pixels meeting there it marks).

The fill needs no flood over the whole canvas. In each row, the pixels left of the leftmost and
right of the rightmost contour pixel are outside. A pixel between them lies outside exactly when
it is 4-connected, through pixels the contour misses and without leaving the rows' spans, to such
a pixel of the row above or below: a path to the border leaves the spans vertically, since it
cannot step past a span's end pixel, which the contour marks.
"""

from __future__ import annotations

import math

import numpy as np

from .kernel import kernel

OUTSIDE = 2  # a pixel between a row's ends found to lie outside, while filling


@kernel
def _mark(img, poly, s, e, cx, cy, left, right):
    """Mark the pixels closed polygon poly[s:e] passes through, its canvas corner at column cx,
    row cy of img; left/right[y]: the leftmost and rightmost marked column of canvas row y."""
    x, y = int(math.floor(poly[s, 0])), int(math.floor(poly[s, 1]))
    img[cy + y, cx + x] = 1  # every other pixel is entered across a grid line
    left[y], right[y] = min(left[y], x), max(right[y], x)
    for v in range(s, e):
        w = v + 1 if v + 1 < e else s
        x0, y0, x1, y1 = poly[v, 0], poly[v, 1], poly[w, 0], poly[w, 1]
        line, last = math.floor(min(x0, x1)) + 1.0, math.floor(max(x0, x1))
        if line <= last:  # the lines x = X the edge crosses, each into the next pixel
            slope, back = (y1 - y0) / (x1 - x0), 1 if x1 < x0 else 0
            while line <= last:
                x, y = int(line) - back, int(math.floor(y0 + (line - x0) * slope))
                img[cy + y, cx + x] = 1
                left[y], right[y] = min(left[y], x), max(right[y], x)
                line += 1.0
        line, last = math.floor(min(y0, y1)) + 1.0, math.floor(max(y0, y1))
        if line <= last:  # the lines y = Y
            slope, back = (x1 - x0) / (y1 - y0), 1 if y1 < y0 else 0
            while line <= last:
                x, y = int(math.floor(x0 + (line - y0) * slope)), int(line) - back
                img[cy + y, cx + x] = 1
                left[y], right[y] = min(left[y], x), max(right[y], x)
                line += 1.0


@kernel
def _fill(img, cx, cy, left, right, stack):
    """Fill what the marked contour encloses (module docstring); stack: room for every pixel."""
    n = _seed_outside(img, cx, cy, left, right, stack)
    _flood_outside(img, cx, cy, left, right, stack, n)
    _settle(img, cx, cy, left, right)


@kernel
def _seed_outside(img, cx, cy, left, right, stack):
    """Mark OUTSIDE the empty pixels of each span that a neighbouring span does not cover, and
    stack them; returns how many."""
    h, n = len(left), 0
    for y in range(h):
        row, a, b = img[cy + y], left[y] + 1, right[y]  # the span's inside: a .. b - 1
        inner, outer = b, b - 1  # the pixels both neighbouring spans cover: inner .. outer
        if 0 < y < h - 1:
            inner, outer = max(left[y - 1], left[y + 1]), min(right[y - 1], right[y + 1])
        for start, stop in ((a, min(b, inner)), (max(a, outer + 1), b)):
            for x in range(start, stop):
                if row[cx + x] == 0:
                    row[cx + x] = OUTSIDE
                    stack[n, 0], stack[n, 1] = y, x
                    n += 1
    return n


@kernel
def _flood_outside(img, cx, cy, left, right, stack, n):
    """Mark OUTSIDE every empty pixel inside the spans that the n stacked ones reach."""
    h = len(left)
    while n > 0:
        n -= 1
        y0, x0 = stack[n, 0], stack[n, 1]
        for d in range(4):
            y, x = y0 + (d == 1) - (d == 0), x0 + (d == 3) - (d == 2)
            if 0 <= y < h and left[y] < x < right[y] and img[cy + y, cx + x] == 0:
                img[cy + y, cx + x] = OUTSIDE
                stack[n, 0], stack[n, 1] = y, x
                n += 1


@kernel
def _settle(img, cx, cy, left, right):
    """Inside the spans: 1 for what is not OUTSIDE, 0 for what is."""
    for y in range(len(left)):
        row = img[cy + y, cx + left[y] + 1 : cx + max(right[y], left[y] + 1)]
        for x in range(len(row)):
            row[x] = row[x] != OUTSIDE


@kernel
def draw_silhouettes(img, poly, starts, frames, corners):
    """Draw the silhouette of polygon f = frames[t] onto the uint8 image img (zero where drawn),
    its canvas corner at corners[t] (x, y). Polygon f is rows starts[f] .. starts[f + 1] - 1 of
    poly (vertices x, y relative to its canvas corner, at least one pixel from the canvas' top and
    left); its pixels must lie inside img, with an empty pixel beyond them below and right."""
    if len(frames) == 0:
        return
    extent = np.empty((len(frames), 2), np.int64)  # each canvas's rows and columns holding pixels
    for t in range(len(frames)):  # check every polygon first: the kernel writes unchecked
        p = poly[starts[frames[t]] : starts[frames[t] + 1]]
        cx, cy = corners[t, 0], corners[t, 1]
        x1, y1 = p[:, 0].max(), p[:, 1].max()
        inside = p.min() >= 1 and x1 < img.shape[1] - 1 - cx and y1 < img.shape[0] - 1 - cy
        if not (inside and cx >= 0 and cy >= 0):  # NaN compares false: refused too
            raise ValueError("a polygon leaves its canvas or the image")
        extent[t, 0], extent[t, 1] = int(y1) + 1, int(x1) + 1
    stack = np.empty(((extent[:, 0] * extent[:, 1]).max(), 2), np.int64)
    for t in range(len(frames)):
        s, e = starts[frames[t]], starts[frames[t] + 1]
        cx, cy = corners[t, 0], corners[t, 1]
        h, w = extent[t, 0], extent[t, 1]
        left, right = np.full(h, w, np.int64), np.full(h, -1, np.int64)
        _mark(img, poly, s, e, cx, cy, left, right)
        _fill(img, cx, cy, left, right, stack)


def draw_silhouette(canvas: np.ndarray, poly: np.ndarray) -> None:
    """Draw the silhouette of the closed polygon `poly` (m, 2; x, y in pixels) onto `canvas`
    (zeros, with at least one empty pixel between the polygon and every edge)."""
    poly = np.ascontiguousarray(poly, np.float64)
    draw_silhouettes(canvas, poly, np.array([0, len(poly)]), np.array([0]), np.zeros((1, 2), np.int64))
