"""The depth per frame from the windows ending there (frame_depths.py), against the same aggregate
computed by hand, window by window, on tiny stores of masks and of boxes."""

from __future__ import annotations

import statistics

import numpy as np
import pytest
from importers.test_import_recording import write_recording

from odms_data.evaluation.frame_depths import by_frame, frame_depths, label_frames
from odms_data.importers.recording import import_recording
from odms_data.simulate.generate_box_store import generate_box_store
from odms_data.store.reader import open_store


def hand_aggregate(ending: dict[int, list[float]], frames: int) -> list[tuple]:
    """(solved windows, median, min, max) per frame from {frame: estimates of the windows ending there}."""
    out = []
    for f in range(frames):
        v = ending.get(f, [])
        out.append((len(v), statistics.median(v), min(v), max(v)) if v else (0, None, None, None))
    return out


def same(depths, want: list[tuple], unsolvable: list[int]) -> None:
    assert depths.windows.tolist() == [w[0] for w in want]
    assert depths.unsolvable.tolist() == unsolvable
    for got, k in ((depths.median, 1), (depths.low, 2), (depths.high, 3)):
        for f, w in enumerate(want):
            assert (np.isnan(got[f]) if w[k] is None else got[f] == pytest.approx(w[k], rel=1e-15)), (f, k)


def test_a_recordings_frames_take_the_windows_ending_there(tmp_path):
    """12 frames, windows of 3 and 5 (ids rec/w<length>-<start>: a window ends at its start, the
    closest frame): per frame the median, min and max of its solved windows, unsolvable ones counted."""
    rec = write_recording(tmp_path / "rec", n=12)
    r = import_recording(rec["masks"], rec["csv"], tmp_path / "rec.zarr", windows=[3, 5], n_obs=3,
                         name="rec", workers=1)
    with open_store(r.path) as s:
        ids = s.example_ids
        rng = np.random.default_rng(3)
        d1 = rng.uniform(0.1, 1.0, len(ids))
        unsolvable = np.zeros(len(ids), bool)
        unsolvable[[0, 5, 11]] = True
        depths = frame_depths(s, d1, unsolvable)
        np.testing.assert_array_equal(depths.z, s.z)
        np.testing.assert_array_equal(depths.truth, s.depth)
    ending: dict[int, list[float]] = {}
    failed = [0] * 12
    for i, (e, d) in enumerate(zip(ids, d1.tolist(), strict=True)):
        start = int(e.rsplit("-", 1)[1])
        if unsolvable[i]:
            failed[start] += 1
        else:
            ending.setdefault(start, []).append(d)
    want = hand_aggregate(ending, 12)
    assert len(ids) == 10 + 8 and sum(failed) == 3
    assert want[10][0] == 0 and want[11][0] == 0  # no window of 3 starts past frame 9
    same(depths, want, failed)


def test_a_store_of_boxes_labels_each_examples_last_frame(tmp_path):
    path = tmp_path / "boxes.zarr"
    generate_box_store(str(path), 5, "odmd", 1, split="boxes")
    with open_store(str(path)) as s:
        last = [int(s.frames_of(e)[-1]) for e in range(s.n_examples)]
        assert label_frames(s, s.frame_index).tolist() == last
        d1 = np.arange(1.0, 6.0)
        depths = frame_depths(s, d1, np.zeros(5, bool))
        assert np.isnan(depths.z).all() and len(depths.z) == s.n_frames
    want = hand_aggregate({f: [d] for f, d in zip(last, d1.tolist(), strict=True)}, len(depths.z))
    same(depths, want, [0] * len(depths.z))


def test_an_even_count_takes_the_mean_of_the_middle_two():
    count, median, low, high = by_frame(np.array([2, 0, 2, 2, 2]), np.array([4.0, 9.0, 1.0, 3.0, 2.0]), 4)
    assert count.tolist() == [1, 0, 4, 0]
    assert median[[0, 2]].tolist() == [9.0, 2.5] and np.isnan(median[[1, 3]]).all()
    assert (low[2], high[2]) == (1.0, 4.0)
