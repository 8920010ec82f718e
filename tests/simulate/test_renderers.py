"""Every renderer of simulate/ against the reference (render.reference_masks, then shrink's
resize_masks for a smaller size): one list, RENDERERS, names them all, so a new renderer joins it
and meets the same examples, sizes and frames."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from odms_data.simulate.batch_render import render_masks, render_shrunk
from odms_data.simulate.object_model import sample_example
from odms_data.simulate.params import GeneratorParams
from odms_data.simulate.render import reference_masks
from odms_data.simulate.shrink import resize_masks
from odms_data.simulate.torch_render import render_coverage

SMALL = GeneratorParams(image_size=(120, 160), sizes=(100, 500), perturb_std=2.0)
FRAMES = np.array([0, 4, 9])


def _torch_coverage(specs, params, size, frames):
    return render_coverage(specs, params, size, frames).numpy()


# name: (draw(specs, params, size, frames) -> (examples, k, h, w), what it draws, tolerance)
# "masks": the contour drawn at that size; "coverage": the full-size masks' INTER_AREA coverage;
# "shrunk": the same as uint8 0/1 masks
RENDERERS: dict[str, tuple[Callable, str, float]] = {
    "batch_render.render_masks": (render_masks, "masks", 0),
    "batch_render.render_shrunk": (lambda s, p, size, f: render_shrunk(s, p, size, f), "shrunk", 0),
    "batch_render.render_shrunk coverage": (
        lambda s, p, size, f: render_shrunk(s, p, size, f, coverage=True), "coverage", 0),
    "torch_render.render_coverage": (_torch_coverage, "coverage", 2e-6),  # float32 sums
}


def _reference(spec, params, size, kind: str) -> np.ndarray:
    if kind == "masks":
        return reference_masks(spec, params, size)[FRAMES]
    return resize_masks(reference_masks(spec, params)[FRAMES], size, coverage=kind == "coverage")


@pytest.mark.parametrize("name", sorted(RENDERERS))
@pytest.mark.parametrize("size", [(120, 160), (112, 112), (30, 40)])
def test_every_renderer_draws_what_the_reference_draws(name, size):
    draw, kind, tolerance = RENDERERS[name]
    specs = [sample_example(SMALL, 13, i) for i in range(6)]
    got = np.asarray(draw(specs, SMALL, size, FRAMES))
    assert got.shape == (len(specs), len(FRAMES), *size)
    for spec, drawn in zip(specs, got, strict=True):
        np.testing.assert_allclose(drawn, _reference(spec, SMALL, size, kind), rtol=0, atol=tolerance)
    assert got.any()  # objects drawn
