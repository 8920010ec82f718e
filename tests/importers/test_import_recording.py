"""Importing a user's own recording: a small recording written here (masks + positions CSV)."""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from odms_data.cli import main
from odms_data.importers.mask_files import image_size
from odms_data.importers.recording import import_recording
from odms_data.store.reader import open_store
from odms_data.store.validate import validate

H, W = 48, 64


def disk(z: float) -> np.ndarray:
    """A 0/255 mask of a disk whose radius shrinks with z."""
    img = np.zeros((H, W), np.uint8)
    cv2.circle(img, (W // 2, H // 2), max(1, int(4 / z)), 255, -1)
    return img


def write_recording(root: Path, n: int = 12, depth: bool = True, shuffle: bool = True) -> dict:
    """n masks f000.png... at z = 0.2 + 0.02 i, listed in the CSV in a shuffled order."""
    masks = root / "masks"
    masks.mkdir(parents=True)
    z = 0.2 + 0.02 * np.arange(n)
    truth = {}
    for i in range(n):
        truth[f"f{i:03d}.png"] = disk(z[i])
        cv2.imwrite(str(masks / f"f{i:03d}.png"), truth[f"f{i:03d}.png"])
    order = np.random.default_rng(0).permutation(n) if shuffle else range(n)
    lines = ["frame,z,depth" if depth else "frame,z"]
    lines += [f"f{i:03d}.png,{z[i]:.3f}" + (f",{z[i] + 0.1:.3f}" if depth else "") for i in order]
    (root / "positions.csv").write_text("\n".join(lines) + "\n")
    return {"masks": masks, "csv": root / "positions.csv", "z": z, "truth": truth}


def run_cli(*args: str):
    return CliRunner().invoke(main, ["import", "recording", *args])


def test_single_example_round_trip(tmp_path):
    rec = write_recording(tmp_path)
    r = import_recording(rec["masks"], rec["csv"], tmp_path / "cup.zarr", workers=1)
    path, attrs = r.path, r.attrs
    assert attrs.domain == "recording" and attrs.split == "cup"
    assert attrs.counts == {"examples": 1, "frames": 12, "labelled": 1}
    with open_store(path) as s:
        ex = s.example("cup/all")
        assert ex.n == 12 and ex.source == "masks"
        np.testing.assert_allclose(ex.z, rec["z"])  # ordered closest first whatever the CSV order
        np.testing.assert_allclose(ex.depth, rec["z"] + 0.1)
        assert ex.d1 == pytest.approx(0.3)
        for i, m in enumerate(ex.masks):
            np.testing.assert_array_equal(m, rec["truth"][f"f{i:03d}.png"] > 0)
    assert validate(path).ok


def test_windows_follow_the_robot_protocol(tmp_path):
    rec = write_recording(tmp_path)
    result = run_cli(str(rec["masks"]), "--positions", str(rec["csv"]), "-o", str(tmp_path / "w.h5"),
                     "--windows", "5,10", "--n-obs", "5", "--workers", "2")
    assert result.exit_code == 0, result.output
    with open_store(str(tmp_path / "w.h5")) as s:
        assert s.format == "hdf5" and len(s) == (12 - 5 + 1) + (12 - 10 + 1)
        ex = s.example("w/w10-02")
        np.testing.assert_array_equal(ex.frames, np.linspace(2, 11, 5).astype(int))
        assert ex.d1 == pytest.approx(rec["z"][2] + 0.1)
    assert validate(str(tmp_path / "w.h5")).ok


def test_unlabelled_and_known_d1(tmp_path):
    rec = write_recording(tmp_path, depth=False)
    r = import_recording(rec["masks"], rec["csv"], tmp_path / "u.zarr", workers=1)
    path, attrs = r.path, r.attrs
    assert attrs.counts["labelled"] == 0
    with open_store(path) as s:
        assert math.isnan(s.d1[0]) and np.isnan(s.depth).all()
    assert validate(path).ok
    path = import_recording(rec["masks"], rec["csv"], tmp_path / "k.zarr", d1=0.5,
                            windows=[10], workers=1).path
    with open_store(path) as s:
        np.testing.assert_allclose(s.depth, 0.5 + rec["z"] - rec["z"][0])
        np.testing.assert_allclose(s.d1, 0.5 + rec["z"][:3] - rec["z"][0])


def test_mask_encodings(tmp_path):
    """1-bit PNG, 0/1 8-bit and 16-bit label images, and a thresholded JPEG all read right."""
    rec = write_recording(tmp_path, n=4, shuffle=False)
    truth = rec["truth"]
    Image.fromarray(truth["f000.png"] > 0).convert("1").save(rec["masks"] / "f000.png")
    cv2.imwrite(str(rec["masks"] / "f001.png"), (truth["f001.png"] > 0).astype(np.uint8))
    cv2.imwrite(str(rec["masks"] / "f002.png"), (truth["f002.png"] > 0).astype(np.uint16))
    jpeg = np.zeros((H, W), np.uint8)
    jpeg[10:30, 20:40] = 255
    (rec["masks"] / "f003.png").unlink()
    cv2.imwrite(str(rec["masks"] / "f003.jpg"), jpeg, [cv2.IMWRITE_JPEG_QUALITY, 60])
    rec["csv"].write_text(rec["csv"].read_text().replace("f003.png", "f003.jpg"))
    path = import_recording(rec["masks"], rec["csv"], tmp_path / "e.zarr", workers=1).path
    with open_store(path) as s:
        m = s.example(0).masks
    for i in range(3):
        np.testing.assert_array_equal(m[i], truth[f"f00{i}.png"] > 0)
    assert abs(int(m[3].sum()) - 400) < 40 and m[3][15:25, 25:35].all()


def test_reading_a_jpeg_header_leaves_the_users_warnings_alone(tmp_path):
    """A JPEG mask's header is read without touching the process's warning filters (Pillow's own
    size bound warns; ours, MAX_PIXELS, is checked instead)."""
    from users_warnings import assert_warning_filters_untouched

    path = tmp_path / "m.jpg"
    cv2.imwrite(str(path), np.zeros((H, W), np.uint8))
    assert image_size(path) == (H, W)
    assert_warning_filters_untouched(lambda: image_size(path))


def _one_line_error(result, name: str) -> str:
    assert result.exit_code == 2, result.output
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("odms-data: error: "), result.output
    assert name in lines[0], lines[0]
    assert "Traceback" not in result.output
    return lines[0]


def _truncate(p: Path) -> None:
    p.write_bytes(p.read_bytes()[:40])


BAD_CASES = {
    "truncated PNG": (lambda r: _truncate(r["masks"] / "f004.png"), "f004.png", "truncated PNG"),
    "not an image": (lambda r: (r["masks"] / "f004.png").write_bytes(b"hello"), "f004.png", "not a PNG"),
    "size differs": (lambda r: cv2.imwrite(str(r["masks"] / "f005.png"), np.zeros((10, 10), np.uint8)),
                     "f005.png", "image size 10x10"),
    "mask without row": (lambda r: cv2.imwrite(str(r["masks"] / "extra.png"), disk(1.0)), "extra.png",
                         "no row"),
    "row without mask": (lambda r: (r["masks"] / "f006.png").unlink(), "positions.csv line", "not found"),
    "duplicate position": (lambda r: r["csv"].write_text(r["csv"].read_text().replace("0.260", "0.240")),
                           "positions.csv line", "duplicate position"),
    "duplicate frame": (lambda r: r["csv"].write_text(r["csv"].read_text() + "f001.png,0.9,1.0\n"),
                        "positions.csv line 14", "listed twice"),
    "non-numeric z": (lambda r: r["csv"].write_text(r["csv"].read_text().replace("0.260", "0.2x")),
                      "positions.csv line", "'0.2x' is not a number"),
    "non-numeric depth": (lambda r: r["csv"].write_text(r["csv"].read_text().replace("0.360", "far")),
                          "positions.csv line", "depth 'far'"),
    "unknown column": (lambda r: r["csv"].write_text(r["csv"].read_text().replace("depth", "Depth", 1)),
                       "positions.csv", "unknown column 'Depth'"),
}


@pytest.mark.parametrize("case", sorted(BAD_CASES))
def test_bad_input_is_one_line_and_writes_nothing(tmp_path, case):
    rec = write_recording(tmp_path)
    spoil, name, what = BAD_CASES[case]
    spoil(rec)
    out = tmp_path / "bad.zarr"
    line = _one_line_error(run_cli(str(rec["masks"]), "--positions", str(rec["csv"]), "-o", str(out),
                                   "--workers", "1"), name)
    assert what in line
    assert not any(p.name.startswith("bad.zarr") for p in tmp_path.iterdir())


def test_fewer_than_two_frames(tmp_path):
    rec = write_recording(tmp_path, n=1)
    _one_line_error(run_cli(str(rec["masks"]), "--positions", str(rec["csv"]), "-o",
                            str(tmp_path / "one.zarr")), "masks")


def test_skip_bad_imports_the_rest_and_reports(tmp_path):
    rec = write_recording(tmp_path)
    _truncate(rec["masks"] / "f004.png")
    cv2.imwrite(str(rec["masks"] / "extra.png"), disk(1.0))
    rec["csv"].write_text(rec["csv"].read_text().replace("0.260", "0.2x"))
    out = tmp_path / "rest.zarr"
    result = run_cli(str(rec["masks"]), "--positions", str(rec["csv"]), "-o", str(out), "--skip-bad",
                     "--workers", "2")
    assert result.exit_code == 0, result.output
    assert "skipped 3 row(s) or file(s):" in result.output
    for name in ("f004.png", "extra.png", "'0.2x'"):
        assert name in result.output
    with open_store(str(out)) as s:
        assert s.n_frames == 10 and len([o for o in s.attrs.oddities if o.problem == "skipped"]) == 3
    assert validate(str(out)).ok
