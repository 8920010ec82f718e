"""The PyTorch renderer (simulate/torch_render.py) against the CPU renderers, on CPU: the same
coverage masks within float32 rounding, the same filled silhouettes exactly."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.ndimage
import torch

from odms_data.errors import InputError
from odms_data.simulate.batch_render import frame_geometry, render_shrunk
from odms_data.simulate.object_model import sample_example
from odms_data.simulate.params import GeneratorParams
from odms_data.simulate.raster import _mark
from odms_data.simulate.render import reference_masks
from odms_data.simulate.shrink import resize_masks
from odms_data.simulate.torch_render import contour_pixels as torch_contour_pixels
from odms_data.simulate.torch_render import fill_enclosed, render_coverage

# objects as large as the image: some boxes leave it; perturbations of up to a few steps
SMALL = GeneratorParams(image_size=(120, 160), sizes=(100, 500), perturb_std=2.0)


def test_fill_matches_scipy_hole_filling_on_random_outlines():
    rng = np.random.default_rng(5)
    canvas = np.zeros((40, 30, 24), np.uint8)
    canvas[:, 1:-1, 1:-1] = rng.random((40, 28, 22)) < 0.35  # pockets, spirals, enclosed islands
    expected = np.stack([scipy.ndimage.binary_fill_holes(c) for c in canvas])
    filled = fill_enclosed(torch.from_numpy(canvas).bool()).numpy()
    assert (filled == expected).all()
    assert (filled != canvas.astype(bool)).any()  # something was enclosed


@pytest.mark.parametrize("size", [(28, 28), (112, 112), (30, 40)])
def test_coverage_equals_the_cpu_renderer_within_float_rounding(size):
    specs = [sample_example(SMALL, 7, i) for i in range(12)]
    frames = np.array([0, 3, 9])
    expected = render_shrunk(specs, SMALL, size, frames, coverage=True)
    got = render_coverage(specs, SMALL, size, frames).numpy()
    assert got.shape == expected.shape == (12, 3, *size)
    np.testing.assert_allclose(got, expected, rtol=0, atol=2e-6)
    slow = resize_masks(reference_masks(specs[0], SMALL)[frames], size, coverage=True)
    np.testing.assert_allclose(got[0], slow, rtol=0, atol=2e-6)
    assert 0 < expected.mean() and (expected == 1).any()  # objects drawn, some pixels covered


def test_a_size_larger_than_the_generators_is_refused():
    with pytest.raises(InputError, match="at most"):
        render_coverage([sample_example(SMALL, 0, 0)], SMALL, (240, 160))


def test_contour_pixels_are_rasters_to_the_pixel():
    g = frame_geometry([sample_example(SMALL, 3, i) for i in range(6)], SMALL, np.arange(10), (120, 160))
    base = np.arange(len(g.k)) * 999
    want = set()
    for f, (w, h) in enumerate(g.hi - g.lo):  # the pixels raster.py marks, frame by frame
        canvas = np.zeros((h, w), np.uint8)
        _mark(canvas, g.poly, g.starts[f], g.starts[f + 1], 0, 0, np.full(h, w), np.full(h, -1))
        ys, xs = np.nonzero(canvas)
        want |= set((ys * 211 + xs + base[f]).tolist())
    poly, starts = torch.from_numpy(g.poly), torch.from_numpy(g.starts)
    got = torch_contour_pixels(poly, starts, 211, torch.from_numpy(base))
    assert set(got.tolist()) == want
