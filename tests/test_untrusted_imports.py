"""Untrusted input (issue 27): hostile recordings walked through `odms-data import recording` and
the commands that show what was imported, each in its own process under an address-space bound
(RLIMIT_AS), each keeping the promise: exit 2, one line naming the file, nothing written outside
the output and no output left behind.

Classes: images whose header declares too much (or what OpenCV refuses), paths from data that
leave their folder, stores the readers would refuse, text from data with terminal escapes or
Markdown in it, and the user's environment (a Latin-1 terminal, odd option values).
"""

from __future__ import annotations

import os
import re
import resource
import struct
import subprocess
import sys
import zlib
from dataclasses import replace
from pathlib import Path

import cv2
import numpy as np
import pytest

from odms_data.errors import InputError
from odms_data.evaluation.leaderboard import load_entries, render_markdown
from odms_data.shown_text import for_terminal, markdown_link, markdown_text

AS_LIMIT = 1536 << 20  # importing the command line takes about 0.7 GiB of address space
H, W = 48, 64


def _limited() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (AS_LIMIT, AS_LIMIT))


def odms(*args: str | Path, cwd: Path, env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "odms_data.cli", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, preexec_fn=_limited, timeout=600,
                          env={**os.environ, **(env or {})})


def _chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def png(height: int, width: int, depth: int = 1, colour: int = 0, idat: bytes | None = None) -> bytes:
    """A PNG with a sound structure declaring height x width pixels: all zeros (1-bit rows,
    compressed without ever holding the image), or `idat` as its data."""
    if idat is None:
        z = zlib.compressobj(9)
        row = b"\0" * (1 + (width * depth + 7) // 8)
        idat = b"".join(z.compress(row) for _ in range(height)) + z.flush()
    ihdr = struct.pack(">IIBBBBB", width, height, depth, colour, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + _chunk(b"IHDR", ihdr) + _chunk(b"IDAT", idat) + _chunk(b"IEND", b"")


@pytest.fixture(scope="module")
def huge_png() -> bytes:
    return png(30000, 30000)  # 0.1 MB that decodes to 900 MB


def recording(root: Path, n: int = 6) -> Path:
    """masks/f000.png ... and positions.csv (z = 0.2 + 0.02 i, depth = z + 0.1) under root/rec."""
    rec = root / "rec"
    (rec / "masks").mkdir(parents=True)
    lines = ["frame,z,depth"]
    for i in range(n):
        img = np.zeros((H, W), np.uint8)
        cv2.circle(img, (W // 2, H // 2), 5 + i, 255, -1)
        cv2.imwrite(str(rec / "masks" / f"f{i:03d}.png"), img)
        lines.append(f"f{i:03d}.png,{0.2 + 0.02 * i:.2f},{0.3 + 0.02 * i:.2f}")
    (rec / "positions.csv").write_text("\n".join(lines) + "\n")
    return rec


def snapshot(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def _put(name: str, data: bytes):
    return lambda rec: (rec / "masks" / name).write_bytes(data)


def _csv_row(row: str):
    return lambda rec: (rec / "positions.csv").write_text(
        (rec / "positions.csv").read_text().replace("f005.png", row))


def _link_outside(rec: Path) -> None:
    (rec / "masks" / "f005.png").rename(rec.parent / "private.png")
    os.symlink(rec.parent / "private.png", rec / "masks" / "f005.png")


def _jpeg_header(rec: Path, side: int = 60000) -> None:
    """f000 as a JPEG whose frame header declares side x side pixels."""
    ok, buf = cv2.imencode(".jpg", cv2.imread(str(rec / "masks" / "f000.png")))
    data = bytearray(buf.tobytes())
    sof = data.index(b"\xff\xc0")
    data[sof + 5 : sof + 9] = struct.pack(">HH", side, side)
    (rec / "masks" / "f000.png").unlink()
    (rec / "masks" / "f000.jpg").write_bytes(bytes(data))
    (rec / "positions.csv").write_text((rec / "positions.csv").read_text().replace("f000.png", "f000.jpg"))


HOSTILE = {  # name: (what is done to the recording, extra arguments, what the error line says)
    "later masks of 30000x30000": (lambda rec, big: [_put(f"f00{i}.png", big)(rec) for i in (2, 3, 4, 5)],
                                   (), "f002.png: image size 30000x30000 differs from the 48x64"),
    "first mask of 30000x30000": (lambda rec, big: _put("f000.png", big)(rec), (),
                                  "f000.png: image of 30000x30000 pixels"),
    "a 200000x200000 header": (lambda rec, big: _put("f000.png", png(200000, 200000, idat=b"x"))(rec), (),
                               "f000.png: image of 200000x200000 pixels"),
    "an IHDR OpenCV rejects": (lambda rec, big: _put("f003.png", png(H, W, depth=3, idat=b"x"))(rec), (),
                               "f003.png: corrupt PNG (IHDR declares"),
    "a JPEG header of 60000x60000": (lambda rec, big: _jpeg_header(rec), (),
                                     "f000.jpg: image of 60000x60000 pixels"),
    "a JPEG header of 10000x10000": (lambda rec, big: _jpeg_header(rec, 10000), (),
                                     "f000.jpg: image of 10000x10000 pixels"),
    "a row ../private.png": (lambda rec, big: _csv_row("../private.png")(rec), (),
                             "positions.csv line 7, column frame: '../private.png' lies outside"),
    "an absolute row": (lambda rec, big: _csv_row(str(rec / "masks" / "f005.png"))(rec), (),
                        "line 7, column frame: '/"),
    "a link out of the folder": (lambda rec, big: _link_outside(rec), (),
                                 "line 7, column frame: 'f005.png' lies outside"),
    "windows 3,3 (duplicate ids)": (lambda rec, big: None, ("--windows", "3,3", "--n-obs", "2"),
                                    "appears 2 times"),
    "depths overflowing to inf": (lambda rec, big: (rec / "positions.csv").write_text(
        "frame,z\n" + "".join(f"f{i:03d}.png,{i}e307\n" for i in range(6))), ("--d1", "1.5e308"),
        "depth is not a positive distance"),
}


@pytest.mark.parametrize("case", HOSTILE)
def test_hostile_recording_is_refused_in_one_line(case, tmp_path, huge_png):
    spoil, args, says = HOSTILE[case]
    rec = recording(tmp_path)
    spoil(rec, huge_png)
    before = snapshot(tmp_path)
    r = odms("import", "recording", rec / "masks", "--positions", rec / "positions.csv", "-o", "out.zarr",
             "--workers", "1", *args, cwd=tmp_path)
    *progress, line = r.stderr.strip().splitlines()
    assert r.returncode == 2 and line.startswith("odms-data: error: ") and says in line, r.stderr
    assert all(p.startswith("importing ") for p in progress), r.stderr  # only progress before it
    assert snapshot(tmp_path) == before  # no output, nothing else touched


def _npy_declaring(shape: tuple[int, ...], descr: str = "<f8"):
    """Writes, beside the given path, poses.npy: a header declaring `shape` and no data after it."""
    def write(f: Path) -> None:
        with f.with_suffix(".npy").open("wb") as out:
            header = {"descr": descr, "fortran_order": False, "shape": shape}
            np.lib.format.write_array_header_1_0(out, header)
    return write


def _sparse(path: Path, size: int) -> None:
    with path.open("wb") as f:
        f.truncate(size)


_TURN = " ".join(map(str, np.diag([1.0, 1.1, 1.0, 1.0]).ravel()))  # a 4x4 matrix that is not a rotation
HOSTILE_POSES = {  # name: (writes the pose file, what the error line says)
    "a TUM row with NaN": (lambda f: f.write_text("1 0 0 0 0 0 0 1\n2 0 nan 0 0 0 0 1\n"),
                           "poses.txt line 2, field 3: 'nan' is not a finite number"),
    "a non-unit quaternion": (lambda f: f.write_text("1 0 0 0 0 0 0.5 1\n"),
                              "poses.txt line 1: quaternion qx qy qz qw has norm 1.11803"),
    "a matrix that is not a rotation": (lambda f: f.write_text(_TURN + "\n"),
                                        "poses.txt line 1: the rotation part is not orthonormal"),
    "a KITTI row of 11 numbers": (lambda f: f.write_text("1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n"),
                                  "poses.txt line 2: 11 numbers, expected 12 as on line 1"),
    "a line of 10^6 fields": (lambda f: f.write_text("0 " * 10**6 + "\n"),
                              "poses.txt line 1: longer than a pose row can be"),
    "3x10^6 blank lines": (lambda f: f.write_text("\n" * 3 * 10**6), "poses.txt: more than 2000000 lines"),
    "a 2 GB pose file": (lambda f: _sparse(f, 2 << 30), "poses.txt: 2147483648 bytes, more than"),
    "a .npy declaring 10^12 poses": (_npy_declaring((10**12, 4, 4)),
                                     "poses.npy: 1000000000000 poses; expected 1 to 1000000"),
    "a .npy shorter than its header": (_npy_declaring((6, 4, 4)),
                                       "poses.npy: shorter than the 6 poses its header declares"),
    "a .npy of objects (a pickle)": (_npy_declaring((6, 4, 4), "|O"),
                                     "poses.npy: holds a object array of shape (6, 4, 4)"),
}


@pytest.mark.parametrize("case", HOSTILE_POSES)
def test_hostile_pose_file_is_refused_in_one_line(case, tmp_path):
    write, says = HOSTILE_POSES[case]
    rec = recording(tmp_path)
    write(rec / "poses.txt")
    poses = next(rec.glob("poses.*"))
    before = snapshot(tmp_path)
    r = odms("import", "recording", rec / "masks", "--poses", poses, "-o", "out.zarr", "--workers", "1",
             cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.startswith("odms-data: error: ") and says in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert snapshot(tmp_path) == before


def release(root: Path) -> Path:
    """A data/ folder of the release's layout: val/normal/synthetic_1 with 10 numbered masks."""
    folder = root / "data" / "val" / "normal" / "synthetic_1"
    folder.mkdir(parents=True)
    for i in range(10):
        img = np.zeros((H, W), np.uint8)
        cv2.circle(img, (W // 2, H // 2), 20 - i, 255, -1)
        cv2.imwrite(str(folder / f"{300000 + 20000 * i}.png"), img)
    return folder


def _release_link_outside(folder: Path) -> None:
    outside = folder.parents[3] / "private.png"
    (folder / "320000.png").rename(outside)
    os.symlink(outside, folder / "320000.png")


HOSTILE_RELEASES = {
    "a mask linked out of its folder": (_release_link_outside, "'320000.png' lies outside"),
    "a 200000x200000 header": (lambda f: (f / "340000.png").write_bytes(png(200000, 200000, idat=b"x")),
                               "340000.png: image size 200000x200000 differs from the 48x64"),
}


@pytest.mark.parametrize("case", HOSTILE_RELEASES)
def test_hostile_release_is_refused_in_one_line(case, tmp_path):
    spoil, says = HOSTILE_RELEASES[case]
    folder = release(tmp_path)
    spoil(folder)
    before = snapshot(tmp_path)
    r = odms("import", "odms", tmp_path / "data", "-o", "stores", "--split", "normal-val", "--workers", "1",
             cwd=tmp_path)
    *progress, line = r.stderr.strip().splitlines()
    assert r.returncode == 2 and line.startswith("odms-data: error: ") and says in line, r.stderr
    assert snapshot(tmp_path) == before


def synthia_with_huge_labels(root: Path) -> Path:
    """A two-frame SYNTHIA sequence under `root` whose label PNGs declare 200000x200000 pixels."""
    seq = root / "SYNTHIA-SEQS-01-DAWN"
    for k in ("GT/LABELS", "Depth", "CameraParams"):
        (seq / k / "Stereo_Left" / "Omni_F").mkdir(parents=True)
    for f in range(2):
        name = f"{f:06d}"
        (seq / "GT/LABELS/Stereo_Left/Omni_F" / f"{name}.png").write_bytes(
            png(200000, 200000, depth=16, colour=2, idat=b"x"))
        cv2.imwrite(str(seq / "Depth/Stereo_Left/Omni_F" / f"{name}.png"), np.full((H, W), 1000, np.uint16))
        (seq / "CameraParams/Stereo_Left/Omni_F" / f"{name}.txt").write_text(
            " ".join(map(str, np.eye(4).flatten())) + "\n")
    return seq


def test_a_synthia_label_image_declaring_too_much_is_refused(tmp_path):
    seq = synthia_with_huge_labels(tmp_path)
    before = snapshot(tmp_path)
    r = odms("import", "synthia", seq, "-o", "s.zarr", "--workers", "1", cwd=tmp_path)
    *progress, line = r.stderr.strip().splitlines()
    assert r.returncode == 2 and "000000.png: image of 200000x200000 pixels" in line, r.stderr
    assert snapshot(tmp_path) == before


def test_terminal_escapes_in_a_source_are_shown_inert(tmp_path):
    rec = recording(tmp_path)
    evil = tmp_path / "rec" / "cup\x1b]0;owned\x07\x1b[2J"
    (rec / "masks").rename(evil)
    r = odms("import", "recording", evil, "--positions", rec / "positions.csv", "-o", "cup.zarr",
             "--workers", "1", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    info = odms("info", "cup.zarr", cwd=tmp_path)
    assert info.returncode == 0 and "\x1b" not in info.stdout and "\x07" not in info.stdout, info.stdout
    assert "cup\\x1b]0;owned\\x07" in info.stdout


def test_for_terminal_escapes_controls_and_keeps_text():
    assert for_terminal("Zürich/w10-03") == "Zürich/w10-03"
    assert for_terminal("a\x1b[31m\u202eb\nc") == "a\\x1b[31m\\u202eb\\x0ac"


def test_markdown_cannot_add_rows_html_or_script_links():
    assert markdown_text("x | y\n| 1 |") == "x \\| y \\| 1 \\|"
    assert markdown_text("<img src=x onerror=alert(1)>") == "&lt;img src=x onerror=alert(1)&gt;"
    assert markdown_link("n](javascript:alert(1))", "javascript:alert(1)") == "n\\]\\(javascript:alert(1))"
    assert markdown_link("ODN", "https://e.org/a (b)|c") == "[ODN](https://e.org/a%20%28b%29%7Cc)"


def test_a_hostile_leaderboard_entry_stays_in_its_row():
    first = load_entries()[0]
    with pytest.raises(InputError, match="link"):  # an entry is checked when made: no script link
        replace(first, link="javascript:alert(1)")
    with pytest.raises(InputError, match="name .*white space"):  # a name is one line
        replace(first, name="Evil | 0.1 |\n| 1 | x")
    entry = replace(first, name="Evil | 0.1 | | 1 | <script>x</script>",
                    link="https://e.org/x) [y](javascript:alert(1)", training_data="[a](javascript:b)",
                    citation="<b>me</b>")
    board = render_markdown([entry], "test")
    row = next(line for line in board.splitlines() if line.startswith("| 1 |"))
    assert row.count(" | ") == board.splitlines()[2].count(" | ")  # the header's cells, no more
    assert "<script>" not in board and "<b>" not in board
    assert not re.search(r"(?<!\\)\]\(javascript:", board) and "\\]\\(javascript:b)" in board


def test_leaderboard_on_a_latin1_terminal(tmp_path):
    r = odms("leaderboard", cwd=tmp_path, env={"PYTHONIOENCODING": "latin-1"})
    assert r.returncode == 0 and "\\u2013" in r.stdout, r.stderr


@pytest.mark.parametrize("value", ["70000", "²"])
def test_classes_out_of_range_are_input_errors(value, tmp_path):
    (tmp_path / "seq").mkdir()
    r = odms("import", "synthia", tmp_path / "seq", "-o", "s.zarr", "--classes", value, cwd=tmp_path)
    assert r.returncode == 2 and f"--classes '{value}': not a class" in r.stderr, r.stderr


def test_meta_device_is_an_input_error():
    from odms_data.errors import InputError
    from odms_data.network.prediction import pick_device

    with pytest.raises(InputError, match="device meta: not a device"):
        pick_device("meta")
