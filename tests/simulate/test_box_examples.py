"""The seeded ODMD box generator (simulate/box_examples.py)."""

from __future__ import annotations

import numpy as np
import pytest

from odms_data.errors import InputError
from odms_data.simulate.box_examples import BOX_PRESETS, BoxParams, sample_box_examples

ODMD = BOX_PRESETS["odmd"]


def test_an_example_depends_only_on_seed_and_index():
    whole = sample_box_examples(ODMD, 3, range(40))
    parts = [sample_box_examples(ODMD, 3, [i]) for i in (39, 0, 17)]
    mixed = sample_box_examples(ODMD, 3, [17, 100, 0, 39, 5, 6, 7, 8, 9])
    for key in whole:
        np.testing.assert_array_equal(parts[0][key][0], whole[key][39])
        np.testing.assert_array_equal(parts[1][key][0], whole[key][0])
        np.testing.assert_array_equal(mixed[key][[0, 2, 3]], whole[key][[17, 0, 39]])
    other = sample_box_examples(ODMD, 4, range(40))
    assert not np.array_equal(other["boxes"], whole["boxes"])


def test_examples_across_chunks_are_those_made_alone(monkeypatch):
    import odms_data.simulate.box_examples as box_examples

    whole = sample_box_examples(ODMD, 5, range(50))
    monkeypatch.setattr(box_examples, "CHUNK", 7)  # 50 examples in 8 chunks, the last short
    for key, value in sample_box_examples(ODMD, 5, range(50)).items():
        np.testing.assert_array_equal(value, whole[key])


def test_unperturbed_boxes_are_the_projection():
    p = BOX_PRESETS["odmd-normal"]
    g = sample_box_examples(p, 0, range(500))
    boxes, move, depth = g["boxes"], g["move"], g["depth"]
    assert not move[:, -1].any()
    z = depth[:, None] - move[:, :, 2]  # each frame's depth from the last and the movement
    width_m = boxes[:, :, 2] * z / (p.fx / p.image_dim[1])
    assert width_m.min() >= p.size_lim[0] and width_m.max() <= p.size_lim[1]
    np.testing.assert_allclose(width_m, np.repeat(width_m[:, :1], 10, 1), rtol=1e-12)  # one size
    assert np.all(np.diff(np.sign(np.diff(z, axis=1)), axis=1) == 0)  # depth moves one way
    step = np.abs(move[:, 0])
    assert np.all(step <= np.array(p.move_max) + 1e-12) and np.all(step[:, 2] >= p.move_min[2] - 1e-12)
    assert depth.min() > 0.2 and depth.max() < 1.35
    # the object stays in view: the box centre within the image at every frame
    assert boxes[:, :, :2].min() > 0 and boxes[:, :, :2].max() < 1


def test_perturbations_move_boxes_and_camera():
    base = sample_box_examples(BOX_PRESETS["odmd-normal"], 0, range(200))
    cam = sample_box_examples(BOX_PRESETS["odmd-perturb-motion"], 0, range(200))
    det = sample_box_examples(BOX_PRESETS["odmd-perturb-detection"], 0, range(200))
    assert not np.array_equal(cam["move"], base["move"]) and not cam["move"][:, -1].any()
    widths = det["boxes"][:, :, 2] * (det["depth"][:, None] - det["move"][:, :, 2])
    spread = np.ptp(widths, axis=1) / widths.mean(axis=1)
    assert 0.01 < np.mean(spread > 0.3) < 0.3  # a tenth of the examples carry a stranger's box


def test_odms_preset_moves_along_z_only():
    g = sample_box_examples(BOX_PRESETS["odms"], 1, range(100))
    assert np.abs(g["move"][:, :, :2]).max() < 0.1  # camera noise only
    assert np.abs(g["move"][:, 0, 2]).max() > 0.3


def test_impossible_configurations_refused():
    with pytest.raises(InputError, match="raise z_lim"):
        BoxParams(z_lim=(0.05, 1.0))
    with pytest.raises(InputError, match="num_pos"):
        BoxParams(num_pos=1)
    with pytest.raises(InputError, match="shuffle"):
        BoxParams(shuffle=2.0)
