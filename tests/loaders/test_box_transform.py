"""DBox's inputs from one box example (loaders/box_transform.py)."""

from __future__ import annotations

import numpy as np
import pytest

from odms_data.errors import InputError
from odms_data.loaders.box_transform import BoxTransform, fill_missed


def _example(n=10, seed=0):
    rng = np.random.default_rng(seed)
    boxes = rng.uniform(0.1, 0.9, (n, 4))
    move = np.zeros((n, 3))
    move[:-1] = rng.uniform(-0.3, 0.3, (n - 1, 3))
    return boxes, move, 0.7


def test_normalized_inputs():
    boxes, move, depth = _example()
    out = BoxTransform()(boxes, move, depth)
    x = out["inputs"]
    assert x.shape == (10, 7) and x.dtype == np.float32
    np.testing.assert_array_equal(x[:, :4], boxes.astype(np.float32))
    norm = np.linalg.norm(move[0])
    assert out["norm"] == pytest.approx(norm, rel=1e-6)
    assert out["depth_norm"] == pytest.approx(depth / norm, rel=1e-6)
    assert not x[0, 4:].any()  # movement as a change from the previous observation
    np.testing.assert_allclose(np.cumsum(x[:, 4:], 0), (move - move[0]) / norm, atol=1e-6)


def test_absolute_inputs_keep_metres():
    boxes, move, depth = _example()
    out = BoxTransform(normalized=False)(boxes, move, depth)
    assert out["norm"] == 1 and out["depth_norm"] == np.float32(depth)
    np.testing.assert_allclose(out["inputs"][1:, 4:], np.diff(move, axis=0), atol=1e-6)


def test_dbox_abs_inputs_keep_each_movement_whole():
    """DBox_Abs (config/model/DBox_absolute.yaml: sequence_dist False): metres, and each
    observation's own movement to the last frame rather than its change."""
    boxes, move, depth = _example()
    out = BoxTransform(normalized=False, relative=False)(boxes, move, depth)
    np.testing.assert_array_equal(out["inputs"][:, 4:], move.astype(np.float32))
    assert out["depth_norm"] == np.float32(depth)


def test_fewer_observations_take_evenly_spaced_frames():
    boxes, move, depth = _example(n=19)
    x = BoxTransform(n_obs=10)(boxes, move, depth)["inputs"]
    np.testing.assert_array_equal(x[:, :4], boxes[np.arange(0, 19, 2)].astype(np.float32))
    np.testing.assert_allclose(np.cumsum(x[:, 4:], 0)[-1], -move[0] / np.linalg.norm(move[0]), atol=1e-6)


def test_missed_detections_take_the_nearest_box():
    boxes = np.arange(20, dtype=float).reshape(5, 4) + 1
    boxes[[1, 2, 4], 2] = 0
    out = fill_missed(boxes, np.arange(5))
    np.testing.assert_array_equal(out[[0, 1, 2, 3, 4]], boxes[[0, 0, 3, 3, 3]])  # tie at 2: the earlier
    none = np.zeros((3, 4))
    none[:, 0] = [5, 6, 7]
    np.testing.assert_array_equal(fill_missed(none, np.arange(3)), none[[0, 0, 0]])


def test_bad_examples_refused():
    boxes, move, depth = _example()
    with pytest.raises(InputError, match="n_obs=10 for an example of 5"):
        BoxTransform()(boxes[:5], move[:5], depth)
    with pytest.raises(InputError, match=r"boxes \(n, 4\)"):
        BoxTransform()(boxes[:, :3], move, depth)
    with pytest.raises(InputError, match="no camera movement"):
        BoxTransform()(boxes, np.zeros_like(move), depth)


def test_a_batch_is_its_examples_alone():
    examples = [_example(seed=s) for s in range(6)]
    boxes = np.stack([e[0] for e in examples])
    move = np.stack([e[1] for e in examples])
    boxes[2, [0, 5], 2] = 0  # missed detections in one example
    out = BoxTransform().batch(boxes, move, np.array([e[2] for e in examples]))
    for k, (_, _, depth) in enumerate(examples):
        alone = BoxTransform()(boxes[k], move[k], depth)
        assert all(np.array_equal(out[key][k], alone[key]) for key in alone)
    np.testing.assert_array_equal(out["inputs"][2, 0, :4], boxes[2, 1].astype(np.float32))
