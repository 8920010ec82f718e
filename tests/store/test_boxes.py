"""ODMD's box of a mask: the largest 8-connected region, inclusive extremes, normalised."""

from __future__ import annotations

import numpy as np
import pytest
from _stores import SIZE, make_store

from odms_data.store.boxes import frame_boxes, largest_region_rect
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
