"""The seeded ODMD box generator (simulate/box_examples.py)."""

from __future__ import annotations

from dataclasses import replace

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


def test_a_turning_camera_sees_the_same_object_turned_and_keeps_the_last_frame_and_movements():
    """With `rotation` the boxes are the object's projection in cameras turned about one axis, the
    first frame by the whole angle, the last not: each frame's box, read back through the pinhole
    model, is a point at the object's distance from the camera, at an angle of at most that
    frame's turn from where the unturned camera sees it, and every frame's point is the unturned
    one turned back about one axis (found from two frames) by that frame's share of the angle."""
    p = BOX_PRESETS["odmd-normal"]
    degrees = 10.0
    straight = sample_box_examples(p, 2, range(300))
    turned = sample_box_examples(replace(p, rotation=degrees), 2, range(300))
    for key in ("move", "depth"):
        np.testing.assert_array_equal(turned[key], straight[key])
    np.testing.assert_array_equal(turned["boxes"][:, -1], straight["boxes"][:, -1])
    h, w = p.image_dim
    fxn, fyn, cxn, cyn = p.fx / w, p.fy / h, p.cx / w, p.cy / h

    def rays(g):  # (E, n, 3) the object's centre in each frame's camera, from its box and size
        b = g["boxes"]
        size = straight["boxes"][:, -1:, 2] * straight["depth"][:, None] / fxn  # m, the object's width
        z = size * fxn / b[..., 2]
        return np.stack([(b[..., 0] - cxn) * z / fxn, (b[..., 1] - cyn) * z / fyn, z], -1), z

    seen, z = rays(turned)
    unturned, _ = rays(straight)
    np.testing.assert_allclose(z, turned["frame_depth"], rtol=1e-9)  # the depth along the turned axis
    np.testing.assert_allclose(np.linalg.norm(seen, axis=-1), np.linalg.norm(unturned, axis=-1), rtol=1e-9)
    sine = np.linalg.norm(np.cross(seen, unturned), axis=-1)
    angle = np.degrees(np.arctan2(sine, (seen * unturned).sum(-1)))
    turn = degrees * np.arange(9, -1, -1) / 9
    assert np.all(angle <= turn + 1e-6)
    assert np.median(angle[:, 0]) > 0.5 * degrees  # a random axis: most of the turn shows
    moved = seen - unturned  # a turn keeps the part along its axis: the axis is normal to these
    axis = np.cross(moved[:, 0], moved[:, 4])
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    k = np.zeros((300, 3, 3))
    k[:, [2, 0, 1], [1, 2, 0]], k[:, [1, 2, 0], [2, 0, 1]] = axis, -axis  # k x = axis x x
    fitted = np.zeros(300, bool)
    for sign in (1, -1):  # the axis' direction is the one that fits
        r = np.eye(3) + np.sin(-sign * np.radians(turn))[:, None, None, None] * k + (
            1 - np.cos(np.radians(turn)))[:, None, None, None] * (k @ k)  # (n, E, 3, 3) Rodrigues
        back = np.einsum("neij,enj->eni", r, unturned)
        fitted |= np.abs(back - seen).max(axis=(1, 2)) < 1e-9
    assert fitted.all()


def test_rotation_is_bounded_by_the_camera():
    assert BOX_PRESETS["odmd"].max_rotation() == 27.1  # the HSR camera's corner is 62.8 degrees off axis
    assert BOX_PRESETS["odms"].max_rotation() == 30.0
    with pytest.raises(InputError, match="rotation must be from 0 to 27.1 degrees"):
        replace(ODMD, rotation=27.2)
    with pytest.raises(InputError, match="rotation must be a number"):
        replace(ODMD, rotation=float("inf"))


def test_a_turning_example_with_perturbations_depends_only_on_seed_and_index():
    """Shuffled examples' donors turn about their own axes: still nothing of the batch counts."""
    p = replace(ODMD, rotation=5.0, shuffle=0.5)
    whole = sample_box_examples(p, 3, range(60))
    alone = [sample_box_examples(p, 3, [i]) for i in range(60)]
    for key in whole:
        np.testing.assert_array_equal(np.concatenate([a[key] for a in alone]), whole[key])
    straight = sample_box_examples(replace(p, rotation=0.0), 3, range(60))
    np.testing.assert_array_equal(whole["move"], straight["move"])
    assert not np.allclose(whole["boxes"][:, 0], straight["boxes"][:, 0])
