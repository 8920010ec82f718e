"""Stores of boxes (FORMAT.md version 2): written, read, validated, converted and used by Box_LS
through the same code as stores of masks; stores of masks keep version 1 as it was."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

from odms_data.cli import main
from odms_data.errors import InputError, StoreError
from odms_data.evaluation.box_ls import box_ls
from odms_data.store.box_rule import example_boxes
from odms_data.store.box_store import BoxRows, write_box_store
from odms_data.store.format import StoreAttrs, arrays_of
from odms_data.store.reader import open_store
from odms_data.store.validate import validate


def ideal_rows(E: int = 3, n: int = 6, split: str = "boxy") -> BoxRows:
    """Examples whose box size is c / depth exactly, the camera moving in x, y and z."""
    rng = np.random.default_rng(0)
    d_last = rng.uniform(0.5, 2.0, E)
    move = np.zeros((E, n, 3))
    move[:, :-1] = rng.uniform(-0.3, 0.3, (E, n - 1, 3))
    move[:, :-1, 2] = -np.linspace(1.0, 0.1, n - 1)  # frames farther than the last
    depth = d_last[:, None] - move[:, :, 2]
    boxes = np.zeros((E, n, 4))
    boxes[..., 0] = boxes[..., 1] = 0.5
    boxes[..., 2], boxes[..., 3] = 0.1 / depth, 0.08 / depth
    ids = [f"{split}/{e}" for e in range(E)]
    return BoxRows(boxes, move, depth, d_last.copy(), ids, ["hand-built"] * E)


def _attrs(split: str = "boxy") -> StoreAttrs:
    return StoreAttrs(split=split, domain="odmd", image_size=(480, 640), counts={})


def test_a_box_store_holds_its_arrays_and_no_masks_and_says_so(tmp_path):
    path = str(tmp_path / "b.zarr")
    rows = ideal_rows()
    digest = write_box_store(path, rows, _attrs())
    with open_store(path) as s:
        assert s.kind == "boxes" and s.attrs.format_version == 2 and s.attrs.digest == digest
        assert s.backend.names() == set(arrays_of("boxes"))
        assert "masks" not in s.backend.names() and "z" not in s.backend.names()
        np.testing.assert_array_equal(s.box, rows.boxes.reshape(-1, 4))
        with pytest.raises(StoreError, match="a store of boxes has no array 'area'"):
            _ = s.area
        with pytest.raises(StoreError, match="has no masks"):
            s.read_masks(np.array([0]))
        ex = example_boxes(s, [0, 1, 2], n_obs=6)
        np.testing.assert_array_equal(ex.boxes, rows.boxes)
        np.testing.assert_array_equal(ex.move, rows.move)
        assert box_ls(s, n_obs=6).d1 == pytest.approx(rows.d1, rel=1e-9)  # ideal boxes: exact
        with pytest.raises(InputError, match="reads stores of masks"):
            example_boxes(s, [0], n_obs=6, odmd_conversion=True)
    report = validate(path)
    assert report.ok, report.problems
    assert report.digest == digest


def test_a_box_store_converts_losslessly_and_info_names_missed_boxes(tmp_path):
    rows = ideal_rows()
    rows.boxes[1, 2] = 0  # a missed detection
    src, dst = str(tmp_path / "b.zarr"), str(tmp_path / "b.h5")
    digest = write_box_store(src, rows, _attrs())
    res = CliRunner().invoke(main, ["convert", src, dst, "--json"])
    assert res.exit_code == 0, res.output
    assert f'"digest": "{digest}"' in res.output
    res = CliRunner().invoke(main, ["info", dst, "--json"])
    assert res.exit_code == 0 and '"missed_detections": 1' in res.output and '"kind": "boxes"' in res.output


def test_a_mask_store_keeps_format_version_1_without_a_kind():
    d = StoreAttrs(split="s", domain="normal", image_size=(4, 4), counts={}).to_json()
    assert d["format_version"] == 1 and "kind" not in d
    assert StoreAttrs(split="s", domain="odmd", image_size=(4, 4), counts={}, kind="boxes").to_json()[
        "format_version"] == 2


def test_a_non_finite_box_is_refused_before_anything_is_written(tmp_path):
    rows = ideal_rows()
    rows.boxes[2, 1, 3] = np.nan
    with pytest.raises(InputError, match=r"box is not finite at frame\(s\) 13"):
        write_box_store(str(tmp_path / "b.zarr"), rows, _attrs())
    assert not (tmp_path / "b.zarr").exists()


@pytest.mark.parametrize("examples, frames", [(slice(0), slice(None)), (slice(None), slice(0))])
def test_rows_with_no_example_or_no_frame_are_refused_in_one_line(tmp_path, examples, frames):
    r = ideal_rows()
    rows = BoxRows(r.boxes[examples, frames], r.move[examples, frames], r.depth[examples, frames],
                   r.d1[examples], r.ids[examples], r.sources[examples])
    with pytest.raises(InputError, match="nothing to write"):
        write_box_store(str(tmp_path / "b.zarr"), rows, _attrs())
    assert not (tmp_path / "b.zarr").exists()


def test_validate_finds_a_label_that_is_not_the_last_frames_depth(tmp_path):
    rows = ideal_rows()
    rows.depth[0, -1] += 0.5
    path = str(tmp_path / "b.zarr")
    write_box_store(path, rows, _attrs())
    report = validate(path)
    assert any("but the depth at its last frame is" in p for p in report.problems), report.problems


def test_show_draws_each_box_of_an_example_of_boxes(tmp_path):
    from PIL import Image

    rows = ideal_rows(E=1, n=2)
    rows.boxes[0, 1] = 0  # the last frame's detection is missed: nothing drawn there
    path = str(tmp_path / "b.zarr")
    write_box_store(path, rows, _attrs())
    out = tmp_path / "sheet.png"
    res = CliRunner().invoke(main, ["show", path, "boxy/0", "-o", str(out)])
    assert res.exit_code == 0, res.output
    sheet = np.asarray(Image.open(out))
    first, second = sheet[24:204, 4:244], sheet[24:204, 248:488]  # the two thumbnails (240 wide)
    assert (first == 255).sum() > 20 and (second == 255).sum() == 0
