"""The paper's network inputs against hand-computed values, and the fast renderer against the
generator."""

from __future__ import annotations

import hashlib

import cv2
import numpy as np
import pytest
from _stores import stats_of

from odms_data.errors import InputError
from odms_data.loaders.targets import labels
from odms_data.loaders.transforms import (
    Transform,
    distances,
    radial_image,
    radial_template,
    resize_masks,
)
from odms_data.protocol import observation_indices
from odms_data.simulate.batch_render import render_boxes, render_masks, render_shrunk
from odms_data.simulate.object_model import sample_example
from odms_data.simulate.params import GeneratorParams, preset
from odms_data.simulate.render import reference_masks as generator_render
from odms_data.simulate.render import render_frame
from odms_data.simulate.shrink import shrink_packed
from odms_data.store.masks import pack


def test_observation_indices_are_linspace_truncated():
    assert observation_indices(10, 4).tolist() == [0, 3, 6, 9]
    assert observation_indices(10, 3).tolist() == [0, 4, 9]  # 4.5 truncated
    assert observation_indices(7, 7).tolist() == list(range(7))
    with pytest.raises(InputError, match="n_obs=11"):
        observation_indices(10, 11)


def test_distances_and_labels():
    z = np.array([0.2, 0.3, 0.5, 0.6])
    dz, zbar = distances(z)
    np.testing.assert_allclose(dz, [0.1, 0.3, 0.4], atol=1e-7)  # dz_2 .. dz_n: no constant dz_1 = 0
    np.testing.assert_allclose(zbar, [0.25, 0.75], atol=1e-7)
    assert dz.dtype == zbar.dtype == np.float32
    got = labels(0.2, z)
    np.testing.assert_allclose([got["d1"], got["d1_norm"], got["scale"]], [0.2, 0.5, 1 / 3], rtol=1e-6)


# SHA-256 of the pixels of the authors' data/misc/radial2D.png (griffbr/ODMS, commit b6147f2),
# 224x224 8-bit, decoded with cv2.imread(path, cv2.IMREAD_GRAYSCALE)
RELEASED_TEMPLATE_SHA256 = "134343cc12d79cf1f58694aeda99e1b83707047c6822cc1afa907075df7b0ebd"


def test_radial_template_is_the_released_one():
    t = radial_template()
    assert t.shape == (224, 224) and t.dtype == np.uint8
    assert t[112, 112] == 255 and t[0, 0] == 0 and t[112, 0] == round(255 * (1 - 1 / np.sqrt(2)))
    assert hashlib.sha256(t.tobytes()).hexdigest() == RELEASED_TEMPLATE_SHA256


def test_radial_image_is_the_template_resized_linearly():
    r = radial_image((112, 112))
    assert r.shape == (112, 112) and r.dtype == np.float32
    np.testing.assert_array_equal(r, (cv2.resize(radial_template(), (112, 112)) / 255).astype(np.float32))
    # what the authors' code feeds the network: 254/255 next to the centre, 1/255 in the corner
    assert r[56, 56] == np.float32(254 / 255) and r[0, 0] == np.float32(1 / 255)
    assert radial_image((50, 90)).shape == (50, 90)


def test_resize_masks_area():
    m = np.zeros((1, 4, 4), np.uint8)
    m[0, :2, :2] = [[1, 1], [1, 0]]  # 3/4 of the top-left output pixel
    m[0, 2, 3] = 1  # 1/4 of the bottom-right one
    binary = resize_masks(m, (2, 2))
    assert binary.dtype == np.uint8 and binary.tolist() == [[[1, 0], [0, 0]]]
    frac = resize_masks(m, (2, 2), coverage=True)
    assert frac.dtype == np.float32 and frac.tolist() == [[[0.75, 0], [0, 0.25]]]


def test_transform_outputs():
    masks = np.zeros((4, 8, 8), bool)
    masks[:, 2:6, 2:6] = True
    masks[:, 1, 1] = True  # a quarter of output pixel (0, 0)
    z = np.array([0.2, 0.3, 0.5, 0.6])
    out = Transform(size=(4, 4), radial=True)(masks, z, 0.2)
    assert out["masks"].shape == (4, 4, 4) and out["masks"].dtype == np.float32
    assert out["masks"][:, 1:3, 1:3].all() and out["masks"][0, 0, 0] == 0.25 and out["masks"].sum() == 17
    assert out["radial"].shape == (1, 4, 4) and out["dz"].shape == (3,) and out["zbar"].shape == (2,)
    assert out["scale"] == np.float32(1 / 3)
    rounded = Transform(size=(4, 4), rounded=True)(masks, z, 0.2)["masks"]
    assert rounded.dtype == np.uint8 and rounded.sum() == 16 and rounded[0, 0, 0] == 0
    with pytest.raises(InputError, match="size"):
        Transform(size=(0, 4))


# objects larger than the image: many frames' boxes leave it
CLIPPED = GeneratorParams(image_size=(300, 500), sizes=(380, 900), perturb_std=2.0, n_obs=7)


@pytest.mark.parametrize("params", [GeneratorParams(), preset("perturb", perturb_std=3.0), CLIPPED])
def test_fast_render_matches_generator(params):
    specs = [sample_example(params, 11, index) for index in range(60)]
    for size in (None, (112, 112), (50, 90)):
        fast = render_masks(specs, params, size)
        for spec, masks in zip(specs, fast, strict=True):
            assert np.array_equal(masks, generator_render(spec, params, size))
    frames = np.array([0, 4, 6])
    out = np.full((2, 3, 112, 112), 7, np.uint8)  # a reused buffer: whatever it held is cleared
    render_masks(specs[:2], params, (112, 112), frames, out)
    for spec, masks in zip(specs[:2], out, strict=True):
        assert np.array_equal(masks, generator_render(spec, params, (112, 112))[frames])


@pytest.mark.parametrize("params", [GeneratorParams(), preset("perturb", perturb_std=3.0), CLIPPED])
def test_boxes_are_what_render_frame_draws(params):
    specs = [sample_example(params, 14, index) for index in range(30)]
    boxes = render_boxes(specs, params)
    n, split = params.n_obs, 0
    assert len(boxes.drawn) == len(specs) * n
    for f, drawn in enumerate(boxes.drawn):
        want = np.zeros(params.image_size, np.uint8)
        box = render_frame(specs[f // n], params, f % n, want)
        assert drawn == (box is not None)
        if box is None:
            continue
        got = np.zeros_like(want)
        (x0, y0), (x1, y1) = boxes.lo[f], boxes.hi[f]
        got[y0:y1, x0:x1] = boxes.pixels(f)
        assert (x0, y0, x1, y1) == box and np.array_equal(got, want)
        stats = stats_of(want[None])
        if boxes.one_region[f]:  # the generator then skips counting regions
            assert stats.largest_area[0] == stats.area[0]
        split += stats.largest_area[0] < stats.area[0]
    assert split or params.perturb_std == 0  # eroded or cut frames in several regions exist


@pytest.mark.parametrize("params", [GeneratorParams(), preset("perturb", perturb_std=3.0), CLIPPED])
def test_shrunk_render_matches_full_size_shrunk(params):
    frames = np.array([0, 3, 6])
    specs = [sample_example(params, 12, index) for index in range(40)]
    full = [generator_render(spec, params)[frames] for spec in specs]
    sizes = (((112, 112), False), ((112, 112), True), ((37, 53), False), ((37, 53), True), ((120, 160), True))
    for size, coverage in (*sizes, ((60, 80), False)):  # cv2's fast path: whole-number scales
        fast = render_shrunk(specs, params, size, frames, coverage)
        for want, masks in zip(full, fast, strict=True):
            assert np.array_equal(masks, resize_masks(want, size, coverage))
    out = np.ones((3, 3, 112, 112), np.float32)
    render_shrunk(specs[:3], params, (112, 112), frames, True, out)
    for want, masks in zip(full, out, strict=False):
        assert np.array_equal(masks, resize_masks(want, (112, 112), True))
    with pytest.raises(InputError, match=r"out has shape \(3, 3, 112, 112\)"):
        render_shrunk(specs[:2], params, (112, 112), frames, True, out)
    strided = np.ones((3, 3, 112, 224), np.float32)[..., ::2]
    with pytest.raises(InputError, match="C-contiguous"):  # drawing would go into a copy
        render_shrunk(specs[:3], params, (112, 112), frames, True, strided)
    with pytest.raises(InputError, match="no examples"):
        render_masks([], params)


def test_shrink_packed_matches_resize():
    params = preset("perturb")
    masks = np.concatenate([generator_render(sample_example(params, 13, i), params) for i in range(20)])
    boxes = stats_of(masks).bbox
    packed = pack(masks)
    sizes = ((112, 112), False), ((112, 112), True), ((37, 53), False), ((240, 160), True), ((120, 160), True)
    for size, coverage in (*sizes, ((120, 160), False)):
        want = resize_masks(masks, size, coverage)
        assert np.array_equal(shrink_packed(packed, masks.shape[2], boxes, size, coverage), want)
    out = np.ones((len(masks), 112, 112), np.float32)
    shrink_packed(packed, masks.shape[2], boxes, (112, 112), True, out)
    assert np.array_equal(out, resize_masks(masks, (112, 112), True))
    boxes[3] = [600, 10, 641, 20]
    with pytest.raises(InputError, match=r"frame 3: box \(600, 10, 641, 20\) is not inside its 640x480"):
        shrink_packed(packed, masks.shape[2], boxes, (112, 112), True)
