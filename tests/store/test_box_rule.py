"""ODMD's box of a mask: the largest 8-connected region, inclusive extremes, normalised."""

from __future__ import annotations

import numpy as np
import pytest
from _stores import SIZE, make_store

from odms_data.errors import InputError
from odms_data.store.box_rule import example_boxes, frame_boxes, largest_region_rect
from odms_data.store.reader import open_store


def _mask(*rects):
    m = np.zeros((SIZE, SIZE), bool)
    for x0, y0, x1, y1 in rects:  # inclusive pixel extremes
        m[y0 : y1 + 1, x0 : x1 + 1] = True
    return m


def _boxes(tmp_path, masks):
    path = make_store(tmp_path / "b.zarr", "boxes", [{"z": list(range(1, len(masks) + 1)), "masks": masks,
                                                       "d1": 1.0}])
    with open_store(path) as s:
        return frame_boxes(s, np.arange(s.n_frames)), s


def test_box_is_centre_and_size_of_the_inclusive_extremes(tmp_path):
    boxes, _ = _boxes(tmp_path, [_mask((3, 2, 7, 4)), _mask((10, 20, 10, 20))])
    assert boxes[0].tolist() == [5 / SIZE, 3 / SIZE, 4 / SIZE, 2 / SIZE]
    assert boxes[1].tolist() == [10 / SIZE, 20 / SIZE, 0.0, 0.0]  # one pixel: zero width, as in ODMD


def test_empty_mask_gives_zeros(tmp_path):
    boxes, _ = _boxes(tmp_path, [np.zeros((SIZE, SIZE), bool), _mask((0, 0, 63, 63))])
    assert boxes[0].tolist() == [0.0, 0.0, 0.0, 0.0]
    assert boxes[1].tolist() == [31.5 / SIZE, 31.5 / SIZE, 63 / SIZE, 63 / SIZE]


def test_only_the_largest_8_connected_region_counts(tmp_path):
    small, big = (1, 1, 3, 3), (20, 30, 40, 35)
    diagonal = _mask((50, 50, 50, 50), (51, 51, 51, 51), (52, 52, 52, 52), (60, 10, 61, 10))
    boxes, s = _boxes(tmp_path, [_mask(small, big), diagonal])
    assert boxes[0].tolist() == [30 / SIZE, 32.5 / SIZE, 20 / SIZE, 5 / SIZE]
    assert boxes[1].tolist() == [51 / SIZE, 51 / SIZE, 2 / SIZE, 2 / SIZE]  # 3 pixels joined by corners
    assert (s.largest_area < s.area).all()  # both frames took the decoding path


def test_ties_go_to_the_first_region_in_raster_order():
    m = _mask((40, 5, 41, 6), (2, 30, 3, 31))
    assert largest_region_rect(m) == (40, 5, 42, 7)
    assert largest_region_rect(np.zeros((4, 4), bool)) == (0, 0, 0, 0)


def test_frame_boxes_of_chosen_rows_match_the_whole_table(tmp_path):
    masks = [_mask((i, i, i + 5, i + 9), (60, 60, 60, 60)) for i in range(6)]
    boxes, s = _boxes(tmp_path, masks)
    rows = np.array([4, 1, 4])
    assert np.array_equal(frame_boxes(s, rows), boxes[rows])


@pytest.mark.parametrize("where", ["x", "y"])
def test_box_lies_in_the_unit_square(tmp_path, where):
    rect = (0, 10, 63, 12) if where == "x" else (10, 0, 12, 63)
    boxes, _ = _boxes(tmp_path, [_mask(rect), _mask(rect)])
    xc, yc, w, h = boxes[0]
    assert 0 <= xc - w / 2 and xc + w / 2 <= 1 and 0 <= yc - h / 2 and yc + h / 2 <= 1


def _sides(tmp_path):
    """Two examples of squares shrinking with z: sides 40, 30, 24, 20 at z 1.0, 1.2, 1.7, 2.0."""
    masks = [_mask((0, 0, s - 1, s - 1)) for s in (40, 30, 24, 20)]
    z = [1.0, 1.2, 1.7, 2.0]
    return make_store(tmp_path / "e.zarr", "ex", [{"z": z, "masks": masks, "d1": 0.5},
                                                   {"z": [v + 1 for v in z], "masks": masks, "d1": 1.5}])


def test_example_boxes_run_far_to_near_with_the_label_at_the_last_frame(tmp_path):
    with open_store(_sides(tmp_path)) as s:
        ex = example_boxes(s, [1, 0], n_obs=4)
        assert ex.frames.tolist() == [[7, 6, 5, 4], [3, 2, 1, 0]]
        assert ex.depth.tolist() == [1.5, 0.5]
        assert (ex.boxes[0, :, 2] * SIZE).tolist() == [19, 23, 29, 39]  # far (small) to near (large)
        np.testing.assert_allclose(ex.move[:, :, 2], [[-1.0, -0.7, -0.2, 0.0]] * 2)
        assert not ex.move[:, :, :2].any() and not ex.move[:, -1].any()
        # the depth of each frame is the label minus its movement, as ODMD's convention has it
        frame_depth = ex.depth[:, None] - ex.move[:, :, 2]
        np.testing.assert_allclose(frame_depth, [[2.5, 2.2, 1.7, 1.5], [1.5, 1.2, 0.7, 0.5]])


def test_example_boxes_with_odmds_conversion_pair_movements_as_odmd_did(tmp_path):
    with open_store(_sides(tmp_path)) as s:
        plain, odmd = example_boxes(s, [0], n_obs=4), example_boxes(s, [0], n_obs=4, odmd_conversion=True)
    np.testing.assert_array_equal(plain.boxes, odmd.boxes)
    np.testing.assert_allclose(odmd.move[0, :, 2], [-1.0, -0.8, -0.3, 0.0])  # z_(n-1-k) - z_0, not z_3 - z_k


def test_example_boxes_choose_n_obs_frames_and_refuse_mixed_lengths(tmp_path):
    masks = [_mask((0, 0, 9, 9))] * 5
    path = make_store(tmp_path / "m.zarr", "mixed", [{"z": [1, 2, 3, 4, 5], "masks": masks, "d1": 1.0},
                                                      {"z": [1, 2, 3], "masks": masks[:3], "d1": 1.0}])
    with open_store(path) as s:
        assert example_boxes(s, [0], n_obs=3).frames.tolist() == [[4, 2, 0]]
        assert example_boxes(s, [0, 1], n_obs=3).boxes.shape == (2, 3, 4)
        with pytest.raises(InputError, match="n_obs=4 for an example of 3 frames"):  # never fewer frames
            example_boxes(s, [0, 1], n_obs=4)
