"""More malformed recordings users really produce (issue 6's catalogue, with the BAD_CASES of
test_import_recording and BAD_RELEASES of test_release): bad ones get one line naming the
file (and line), exit 2 and no output; harmless variants import as intended."""

from __future__ import annotations

import os
import shutil

import cv2
import numpy as np
import pytest
from test_import_recording import BAD_CASES, run_cli, write_recording
from test_release import BAD_RELEASES

from odms_data.store.reader import open_store


def _replace_csv(old: str, new: str):
    return lambda r: r["csv"].write_text(r["csv"].read_text().replace(old, new))


def _jpeg_as_png(r):
    img = cv2.imread(str(r["masks"] / "f003.png"))
    ok, buf = cv2.imencode(".jpg", img)
    (r["masks"] / "f003.png").write_bytes(buf.tobytes())


BAD = {
    "a JPEG named .png": (_jpeg_as_png, "f003.png: not a PNG file"),
    "zero-byte PNG": (lambda r: (r["masks"] / "f003.png").write_bytes(b""), "f003.png: not a PNG file"),
    "symlink loop": (lambda r: os.symlink(r["masks"] / "loop.png", r["masks"] / "loop.png"),
                     "loop.png: no row in"),
    "file name not UTF-8": (lambda r: os.rename(r["masks"] / "f003.png",
                                                os.path.join(bytes(r["masks"]), b"f\xff03.png")),
                            "positions.csv line"),
    "semicolon CSV": (lambda r: r["csv"].write_text(r["csv"].read_text().replace(",", ";")),
                      "positions.csv: unknown column 'frame;z;depth'"),
    "empty CSV": (lambda r: r["csv"].write_text(""), "positions.csv: is empty"),
    "CSV with a header only": (lambda r: r["csv"].write_text("frame,z,depth\n"), "f000.png: no row in"),
    "z of 1e400": (_replace_csv("0.260", "1e400"), "'1e400' is not a finite number"),
    "z of nan": (_replace_csv("0.260", "nan"), "z 'nan' is not a finite number"),
    "negative depth": (_replace_csv("0.360", "-0.3"), "depth -0.3 is not a positive distance"),
    "positions path is a folder": (lambda r: (r["csv"].unlink(), r["csv"].mkdir()), "positions.csv"),
    "mask folder missing": (lambda r: shutil.rmtree(r["masks"]), "masks: no such folder"),
    "no z column": (_replace_csv("frame,z,depth", "frame,depth"), "no 'z' column"),
    "UTF-16 CSV": (lambda r: r["csv"].write_bytes(r["csv"].read_text().encode("utf-16")),
                   "positions.csv: not a readable CSV"),
}


def _rgba(r):
    m = cv2.imread(str(r["masks"] / "f003.png"), cv2.IMREAD_GRAYSCALE)
    cv2.imwrite(str(r["masks"] / "f003.png"), np.dstack([m, m, m, np.full_like(m, 255)]))


def _sixteen_bit(r):
    m = cv2.imread(str(r["masks"] / "f003.png"), cv2.IMREAD_GRAYSCALE).astype(np.uint16) * 257
    cv2.imwrite(str(r["masks"] / "f003.png"), m)


HARMLESS = {
    "RGBA mask": _rgba,
    "16-bit mask": _sixteen_bit,
    "CSV with a UTF-8 BOM": lambda r: r["csv"].write_bytes(b"\xef\xbb\xbf" + r["csv"].read_bytes()),
    "Windows line endings": lambda r: r["csv"].write_bytes(r["csv"].read_bytes().replace(b"\n", b"\r\n")),
    "columns in another order": lambda r: r["csv"].write_text("z,frame,depth\n" + "\n".join(
        ",".join([(f := line.split(","))[1], f[0], f[2]]) for line in r["csv"].read_text().splitlines()[1:])),
    "a symlinked subfolder loop (ignored)": lambda r: os.symlink(r["masks"], r["masks"] / "sub"),
}


def test_catalogue_has_at_least_20_cases():
    assert len(BAD) + len(BAD_CASES) + len(BAD_RELEASES) >= 20


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_recordings_exit_2_with_one_line(tmp_path, case):
    rec = write_recording(tmp_path)
    spoil, expected = BAD[case]
    spoil(rec)
    out = tmp_path / "out.zarr"
    r = run_cli(str(rec["masks"]), "--positions", str(rec["csv"]), "-o", str(out), "--workers", "1")
    assert r.exit_code == 2, (case, r.output)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("odms-data: error: "), r.stderr
    assert expected in lines[0], lines[0]
    assert not any(p.name.startswith("out.zarr") for p in tmp_path.iterdir())


@pytest.mark.parametrize("case", sorted(HARMLESS))
def test_harmless_variants_import_as_intended(tmp_path, case):
    rec = write_recording(tmp_path)
    HARMLESS[case](rec)
    out = tmp_path / "out.zarr"
    r = run_cli(str(rec["masks"]), "--positions", str(rec["csv"]), "-o", str(out), "--workers", "1")
    assert r.exit_code == 0, (case, r.output)
    with open_store(str(out)) as s:
        ex = s.example(0)
        np.testing.assert_allclose(ex.z, rec["z"])
        for i, name in enumerate(sorted(rec["truth"])):
            np.testing.assert_array_equal(ex.masks[i], rec["truth"][name] > 0)
