"""The silhouette rule (raster.py): every pixel the contour passes through and everything it
encloses, against brute force, scipy, and the authors' released way of drawing."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.ndimage

from odms_data.simulate.object_model import sample_example
from odms_data.simulate.params import GeneratorParams, preset
from odms_data.simulate.raster import OUTSIDE, _fill, _mark, draw_silhouette, draw_silhouettes
from odms_data.simulate.render import reference_masks


def _touches(p: np.ndarray, q: np.ndarray, x: int, y: int) -> bool:
    """Whether segment pq meets the closed square [x, x+1] x [y, y+1] (Liang-Barsky)."""
    t0, t1 = 0.0, 1.0
    d = q - p
    for a, lo in ((0, x), (1, y)):
        for edge, sign in ((lo, -1.0), (lo + 1, 1.0)):
            num, den = sign * (edge - p[a]), sign * d[a]
            if den == 0:
                if num < 0:
                    return False
            elif den > 0:
                t1 = min(t1, num / den)
            else:
                t0 = max(t0, num / den)
    return t0 <= t1


def _pixels(poly: np.ndarray) -> set[tuple[int, int]]:
    """The pixels raster.py marks for the closed polygon `poly`."""
    image = np.zeros((100, 100), np.uint8)
    left, right = np.full(100, 100), np.full(100, -1)
    _mark(image, poly, 0, len(poly), 0, 0, left, right)
    ys, xs = np.nonzero(image)
    assert np.array_equal(left[ys], [xs[ys == y].min() for y in ys])  # the spans the fill uses
    assert np.array_equal(right[ys], [xs[ys == y].max() for y in ys])
    return set(zip(xs.tolist(), ys.tolist(), strict=True))


def test_contour_pixels_are_the_pixels_the_edges_pass_through():
    rng = np.random.default_rng(3)
    polys = [rng.random((m, 2)) * 12 + 1 for m in (3, 5, 8, 8)]
    polys.append(np.array([[2.25, 2.5], [9.5, 2.5], [9.5, 7.25]]))  # edges along the axes
    polys.append(np.array([[3.2, 3.3], [3.7, 3.4], [3.5, 3.9]]))  # inside one pixel
    for poly in polys:
        edges = list(zip(poly, np.roll(poly, -1, axis=0), strict=True))
        want = {(x, y) for x in range(15) for y in range(15) if any(_touches(p, q, x, y) for p, q in edges)}
        assert _pixels(poly) == want
    # on a grid line, an edge is in the pixels right of and below it: pixels are half-open
    assert _pixels(np.array([[9.0, 2.5], [9.0, 6.5], [9.0, 4.0]])) == {(9, y) for y in range(2, 7)}


def test_several_silhouettes_are_drawn_each_at_its_corner():
    rng = np.random.default_rng(4)
    polys = [rng.random((m, 2)) * 12 + 1 for m in (3, 5, 8)]
    starts = np.cumsum([0, *map(len, polys)])
    corners = np.array([[20, 0], [0, 20], [3, 4]])
    image = np.zeros((40, 40), np.uint8)
    draw_silhouettes(image, np.concatenate(polys), starts, np.array([2, 0, 1]), corners)
    want = np.zeros_like(image)
    for poly, (x, y) in zip([polys[2], polys[0], polys[1]], corners, strict=True):
        one = np.zeros((16, 16), np.uint8)
        draw_silhouette(one, poly)
        want[y : y + 16, x : x + 16] |= one
    assert np.array_equal(image, want) and image.sum() > 30


def test_a_polygon_that_leaves_its_canvas_is_refused():
    for poly in ([[0.5, 3], [8, 3], [4, 9]], [[2, 3], [8, 3], [4, 15.5]], [[2, 3], [8, np.nan], [4, 9]],
                 [[2, 3], [np.inf, 3], [4, 9]]):
        with pytest.raises(ValueError, match="leaves its canvas"):
            draw_silhouette(np.zeros((16, 16), np.uint8), np.array(poly, float))


def test_a_self_crossing_contour_gives_a_silhouette_without_holes():
    bow = np.array([[2, 2], [30, 30], [30, 2], [2, 30]], float) + 0.25  # two triangles meeting in the middle
    loop = np.array([[2, 2], [40, 2], [40, 20], [10, 20], [10, 10], [30, 10], [30, 30], [2, 30]], float) + 0.5
    for poly in (bow, loop):
        canvas = np.zeros((45, 45), np.uint8)
        draw_silhouette(canvas, poly)
        assert np.array_equal(canvas, scipy.ndimage.binary_fill_holes(canvas))
    assert canvas[12:18, 12:28].all()  # the loop's inner square, enclosed twice, is filled


def test_the_fill_is_scipys_hole_filling_on_random_outlines():
    rng = np.random.default_rng(5)
    for density in (0.2, 0.35, 0.5):  # pockets, spirals, islands enclosed in enclosed regions
        for _ in range(40):
            image = np.zeros((30, 24), np.uint8)
            image[1:-1, 1:-1] = rng.random((28, 22)) < density
            marked = np.nonzero(image.any(axis=1))[0]
            left, right = np.full(30, 24), np.full(30, -1)
            left[marked] = image[marked].argmax(axis=1)
            right[marked] = 23 - image[marked, ::-1].argmax(axis=1)
            want = scipy.ndimage.binary_fill_holes(image)
            _fill(image, 0, 0, left, right, np.empty((30 * 24, 2), np.int64))
            assert np.array_equal(image, want) and OUTSIDE not in image


def _released_generator_masks(params: GeneratorParams, seed: int, index: int) -> np.ndarray:
    """The authors' way: mark the pixel of each of 2,000 points per Bezier segment, fill holes."""
    dense = replace(params, curve_samples=2000)
    spec = sample_example(dense, seed, index)
    H, W = params.image_size
    out = np.zeros((len(spec.z), H, W), bool)
    for i, z in enumerate(spec.z):
        scale = params.d_min / z
        pts = spec.contour * scale + [W / 2 - scale * spec.size / 2, H / 2 - scale * spec.size / 2]
        x, y = np.floor(pts).astype(int).T
        out[i, y, x] = True
        out[i] = scipy.ndimage.binary_fill_holes(out[i])
    return out


def test_silhouettes_match_the_released_generators_drawing():
    params = GeneratorParams()
    differ = total = 0
    for index in range(12):
        ours = reference_masks(sample_example(params, 21, index), params).astype(bool)
        theirs = _released_generator_masks(params, 21, index)
        differ += int((ours != theirs).sum())
        total += int(theirs.sum())
    # 32 points a segment and exact pixels against 2,000 points a segment: a few pixels in 10,000
    assert differ / total < 1e-3, differ / total


def test_no_holes_in_the_standard_preset():
    params = preset("standard")
    for index in range(40):
        masks = reference_masks(sample_example(params, 22, index), params)
        for m in masks:
            ys, xs = np.nonzero(m)
            box = m[ys.min() : ys.max() + 1, xs.min() : xs.max() + 1]
            assert np.array_equal(box, scipy.ndimage.binary_fill_holes(box))
