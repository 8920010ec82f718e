"""`show --crop`: a small object fills the contact sheet's thumbnails."""

from __future__ import annotations

import numpy as np
from click.testing import CliRunner
from PIL import Image

from odms_data.cli import main
from odms_data.publish.contact_sheet import CROP_LEAST, THUMB_WIDTH, contact_sheet, object_box
from odms_data.simulate.generate_store import generate
from odms_data.simulate.params import GeneratorParams
from odms_data.store.box_store import BoxRows, write_box_store
from odms_data.store.format import StoreAttrs
from odms_data.store.reader import Example, open_store


def _example(masks: np.ndarray) -> Example:
    n = len(masks)
    return Example("x/000000", "generated", 1.0, np.arange(n), np.linspace(0, 0.1, n), np.ones(n), masks)


def _first_thumbnail_bright(sheet: Image.Image, height: int, width: int) -> float:
    """The fraction of bright pixels in the sheet's first thumbnail, of a height x width mask."""
    th = round(height * THUMB_WIDTH / width)
    return float((np.asarray(sheet)[24:24 + th, 4:4 + THUMB_WIDTH] > 128).mean())


def test_the_crop_boxes_the_object_in_every_mask_with_a_margin():
    masks = np.zeros((3, 120, 160), bool)
    masks[0, 50:60, 70:80] = True  # 10 pixels a side, moving right
    masks[2, 52:62, 90:100] = True
    assert object_box(masks) == (47, 65, 63, 107)  # rows 50..61, columns 70..99, margins 25 %
    tiny = np.zeros((2, 120, 160), bool)
    tiny[1, 0, 159] = True  # one pixel in a corner: at least CROP_LEAST a side, inside the image
    top, bottom, left, right = object_box(tiny)
    assert (top, right) == (0, 160) and bottom - top >= CROP_LEAST // 2 and right - left >= CROP_LEAST // 2
    assert object_box(np.zeros((2, 8, 8), bool)) is None

    whole, cropped = contact_sheet(_example(masks)), contact_sheet(_example(masks), crop=True)
    assert _first_thumbnail_bright(whole, 120, 160) < 0.01
    assert _first_thumbnail_bright(cropped, 65 - 47, 107 - 63) > 0.1
    assert contact_sheet(_example(np.zeros((2, 8, 8), bool)), crop=True).size  # nothing to crop: drawn whole


def test_show_crop(tmp_path):
    store = tmp_path / "small.zarr"
    generate(str(store), 1, GeneratorParams(image_size=(240, 320), sizes=(10,)), seed=4, split="small",
             workers=1)
    for crop in ([], ["--crop"]):
        r = CliRunner().invoke(main, ["show", str(store), "small/000000", *crop, "-o",
                                      str(tmp_path / f"s{len(crop)}.png")])
        assert r.exit_code == 0, r.output
    whole, cropped = Image.open(tmp_path / "s0.png"), Image.open(tmp_path / "s1.png")
    with open_store(str(store)) as s:
        masks = s.example(0).masks
    top, bottom, left, right = object_box(masks)
    assert masks.mean() < 0.001 and _first_thumbnail_bright(whole, 240, 320) < 0.001
    assert _first_thumbnail_bright(cropped, bottom - top, right - left) > 0.01  # 2x2 pixels of 16x16


def test_show_draws_a_negative_width_marked_and_far_corners_clipped(tmp_path):
    """A box of negative width (in ODMD's released perturb-detection-val) made show exit 3."""
    boxes = np.tile([[0.5, 0.5, 0.2, 0.2]], (1, 3, 1))
    rows = BoxRows(boxes, np.zeros((1, 3, 3)), np.ones((1, 3)), np.ones(1), ["neg/0"], ["hand-built"])
    rows.move[0, :2, 2] = [-0.2, -0.1]
    rows.boxes[0, 1, 2] = -0.1  # negative width
    rows.boxes[0, 2, 2] = 1e160  # far past the image
    path = str(tmp_path / "neg.zarr")
    write_box_store(path, rows, StoreAttrs(split="neg", domain="odmd", image_size=(48, 64), counts={}))
    out = tmp_path / "sheet.png"
    r = CliRunner().invoke(main, ["show", path, "neg/0", "-o", str(out)])
    assert r.exit_code == 0 and r.stderr == "", r.output
    sheet = np.asarray(Image.open(out))
    assert (sheet == 128).any()  # the negative box, in grey


def test_show_draws_odmds_own_negative_width_example(tmp_path, odmd_data):
    r = CliRunner().invoke(main, ["import", "odmd", str(odmd_data), "--set", "odmd-perturb-detection-val",
                                  "-o", str(tmp_path)])
    assert r.exit_code == 0, r.output
    store = str(tmp_path / "odmd-perturb-detection-val.zarr")
    with open_store(store) as s:
        ids = [i for i in s.example_ids if i.endswith("02335")]
    out = tmp_path / "02335.png"
    r = CliRunner().invoke(main, ["show", store, ids[0], "-o", str(out)])
    assert r.exit_code == 0 and r.stderr == "", r.output
    assert (np.asarray(Image.open(out)) == 128).any()
