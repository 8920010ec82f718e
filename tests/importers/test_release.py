"""Importing the official ODMS release: the real archive (via the fixtures) and small fake releases
written here for each kind of bad input."""

from __future__ import annotations

import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
from click.testing import CliRunner

from odms_data.cli import main
from odms_data.protocol import OFFICIAL_SPLITS as SPLITS
from odms_data.store.manifests import load_manifest
from odms_data.store.reader import open_store
from odms_data.store.validate import validate

COUNTS = {"robot-val": 1760, "driving-val": 500, "normal-val": 2000, "perturb-val": 2000,
          "robot-test": 2640, "driving-test": 750, "normal-test": 3000, "perturb-test": 3000}


# --- the real release ------------------------------------------------------------------------

def test_counts_and_digests_match_the_manifests(official_stores):
    assert sorted(official_stores) == sorted(SPLITS)
    for name, path in official_stores.items():
        manifest = load_manifest(name)
        assert manifest.origin == "imported" and manifest.count == COUNTS[name]
        with open_store(str(path)) as s:
            assert s.attrs.split == name and s.attrs.domain == name.split("-")[0]
            assert len(s) == COUNTS[name] and s.attrs.digest == manifest.digest


def test_every_store_validates(official_stores):
    for name in ("robot-val", "driving-test", "perturb-val"):
        result = CliRunner().invoke(main, ["validate", str(official_stores[name])])
        assert result.exit_code == 0, result.output
    for name in ("robot-test", "driving-val", "normal-val", "normal-test", "perturb-test"):
        report = validate(str(official_stores[name]))
        assert report.ok, report.problems


def _pngs(folder: Path) -> list[Path]:
    return sorted(folder.glob("*.png"), key=lambda p: int(p.stem))


def test_robot_windows(official_stores, official_data_dir):
    pngs = _pngs(official_data_dir / "test" / "robot" / "banana_0")
    z = np.array([int(p.stem) for p in pngs]) / 1e6
    with open_store(str(official_stores["robot-test"])) as s:
        ids = [i for i in s.example_ids if i.startswith("robot-test/banana_0/")]
        assert len(ids) == 55 and ids[0] == "robot-test/banana_0/w10-00" and ids[-1].endswith("/w30-00")
        for w, start in ((10, 0), (15, 3), (20, 10), (30, 0)):
            ex = s.example(f"robot-test/banana_0/w{w}-{start:02d}")
            idx = np.linspace(start, start + w - 1, 10).astype(int)
            np.testing.assert_array_equal(ex.z, z[idx])
            np.testing.assert_array_equal(ex.depth, z[idx])
            assert ex.d1 == z[idx[0]] and ex.source == "test/robot/banana_0"
        assert s.n_frames == 48 * 30  # each folder's frames are stored once


def test_driving_order_depth_and_oddities(official_stores, official_data_dir):
    folder = official_data_dir / "val" / "driving" / "SYNTHIA-SEQS-01-DAWN_1029_10_13"
    info = np.loadtxt(folder / "info.txt", skiprows=1)
    with open_store(str(official_stores["driving-val"])) as s:
        ex = s.example("driving-val/SYNTHIA-SEQS-01-DAWN_1029_10_13")
        np.testing.assert_array_equal(ex.z, info[::-1, 0])
        np.testing.assert_array_equal(ex.depth, info[::-1, 1])
        assert ex.d1 == info[-1, 1] and ex.source == "val/driving/SYNTHIA-SEQS-01-DAWN_1029_10_13"
        assert np.all(np.diff(ex.z) > 0)
        assert s.n_obs.min() >= 10
        # NaN depths are kept, exactly at empty masks, never at the label
        nan = np.isnan(s.depth)
        assert nan.sum() == 7 and np.all(s.area[nan] == 0) and not np.isnan(s.d1).any()
    with open_store(str(official_stores["driving-test"])) as s:
        odd = {(o.subject, o.problem) for o in s.attrs.oddities}
        for seq in ("SYNTHIA-SEQS-02-FOG_196_20_328", "SYNTHIA-SEQS-02-FOG_196_30_328"):
            assert (f"driving-test/{seq}", "z-not-increasing") in odd
        assert sum(k == "z-not-increasing" for _, k in odd) == 2
        assert np.isnan(s.depth).sum() == 22
    with open_store(str(official_stores["perturb-val"])) as s:
        assert int((s.area == 0).sum()) == 10
        assert len([o for o in s.attrs.oddities if o.problem == "empty-mask"]) == 7


@pytest.mark.parametrize("split, example, rel", [
    ("robot-val", "robot-val/blue_block_0/w25-04", "val/robot/blue_block_0"),
    ("driving-test", "driving-test/SYNTHIA-SEQS-02-FOG_196_30_328",
     "test/driving/SYNTHIA-SEQS-02-FOG_196_30_328"),
    ("normal-test", "normal-test/synthetic_2999", "test/normal/synthetic_2999"),
    ("perturb-val", "perturb-val/synthetic_1", "val/perturb/synthetic_1"),
])
def test_masks_round_trip_pixel_for_pixel(official_stores, official_data_dir, split, example, rel):
    pngs = _pngs(official_data_dir / rel)
    with open_store(str(official_stores[split])) as s:
        ex = s.example(example)
        assert ex.source == rel
        if split.startswith("driving"):
            files = pngs[::-1]
        elif split.startswith("robot"):
            files = [pngs[i] for i in np.linspace(4, 28, 10).astype(int)]
        else:
            files = pngs
        assert ex.n == len(files)
        for m, f in zip(ex.masks, files, strict=True):
            np.testing.assert_array_equal(m, cv2.imread(str(f), cv2.IMREAD_GRAYSCALE) > 0)


def _stamps(folder: Path) -> dict[str, int]:
    return {str(p.relative_to(folder)): p.stat().st_mtime_ns for p in folder.rglob("*")}


def test_an_import_run_again_keeps_the_complete_stores_and_imports_the_rest(
        tmp_path, official_stores, official_data_dir):
    """An import stopped after robot-val: run again, it keeps that store untouched and imports
    robot-test, instead of refusing robot-val as existing."""
    out = tmp_path / "stores"
    out.mkdir()
    shutil.copytree(official_stores["robot-val"], out / "robot-val.zarr")
    before = _stamps(out / "robot-val.zarr")
    r = CliRunner().invoke(main, ["import", "odms", str(official_data_dir), "-o", str(out), "--split",
                                  "robot-val", "--split", "robot-test", "--workers", "1"])
    assert r.exit_code == 0, r.output
    assert f"kept {out / 'robot-val.zarr'}: already complete, matches splits/robot-val.json" in r.stdout
    assert f"wrote {out / 'robot-test.zarr'}: 2640 examples" in r.stdout
    assert _stamps(out / "robot-val.zarr") == before
    with open_store(str(out / "robot-test.zarr")) as s:
        assert s.attrs.digest == load_manifest("robot-test").digest


# --- small fake releases: bad input ------------------------------------------------------------

def _mask(i: int, shape=(16, 20)) -> np.ndarray:
    img = np.zeros(shape, np.uint8)
    img[4:12, 3 + i % 5 : 15] = 255
    return img


def fake_release(root: Path, domain: str = "normal", folders: int = 3, n: int = 10) -> Path:
    """A data/ folder with `folders` folders of n masks in val/<domain>."""
    data = root / "data"
    for k in range(folders):
        d = data / "val" / domain / f"synthetic_{k + 1}"
        d.mkdir(parents=True)
        names = [f"{300000 + 20000 * i + k:06d}.png" for i in range(n)]
        for i, name in enumerate(names):
            cv2.imwrite(str(d / name), _mask(i))
        if domain == "driving":
            lines = ["camera_move(m) depth(m) "] + [f"{(n - 1 - i) * 1.5} {9.0 + (n - 1 - i) * 1.5} "
                                                    for i in range(n)]
            (d / "info.txt").write_text("\n".join(lines))
    return data


def run_import(data: Path, out: Path, domain: str = "normal", *extra: str):
    return CliRunner().invoke(main, ["import", "odms", str(data), "-o", str(out), "--split",
                                     f"{domain}-val", "--workers", "1", *extra])


def _one_line_error(result, name: str) -> str:
    assert result.exit_code == 2, result.output
    lines = [x for x in result.output.strip().splitlines() if not x.startswith("importing ")]
    assert len(lines) == 1 and lines[0].startswith("odms-data: error: "), result.output
    assert name in lines[0] and "Traceback" not in result.output
    return lines[0]


def _info(data: Path) -> Path:
    return data / "val" / "driving" / "synthetic_2" / "info.txt"


BAD_RELEASES = {
    "non-numeric name": ("normal", lambda d: cv2.imwrite(str(d / "val/normal/synthetic_2/abc.png"), _mask(0)),
                         "synthetic_2/abc.png", "not a number"),
    "one frame": ("normal", lambda d: [p.unlink() for p in _files(d, "normal", 3)[1:]], "synthetic_3",
                  "at least 2"),
    "truncated png": ("normal", lambda d: _spoil(sorted((d / "val/normal/synthetic_2").glob("*"))[3]),
                      "synthetic_2/", "truncated PNG"),
    "size differs": ("normal", lambda d: cv2.imwrite(str(sorted((d / "val/normal/synthetic_2").glob("*"))[5]),
                                                     _mask(0, (30, 20))), "synthetic_2/", "image size 30x20"),
    "info line missing": ("driving", lambda d: _info(d).write_text(_info(d).read_text().rsplit("\n", 1)[0]),
                          "synthetic_2/info.txt", "9 data lines for 10 PNGs (missing lines)"),
    "info line extra": ("driving", lambda d: _info(d).write_text(_info(d).read_text() + "\n0.5 3.0"),
                        "synthetic_2/info.txt", "11 data lines for 10 PNGs (extra lines)"),
    "info not numeric": ("driving", lambda d: _replace(_info(d), "4.5 ", "4.5x "),
                         "synthetic_2/info.txt line", "'4.5x' is not a number"),
    "info missing": ("driving", lambda d: _info(d).unlink(), "synthetic_2/info.txt", "missing"),
}


def _files(data: Path, domain: str, k: int) -> list[Path]:
    return sorted((data / "val" / domain / f"synthetic_{k}").glob("*"))


def _replace(p: Path, old: str, new: str) -> None:
    p.write_text(p.read_text().replace(old, new))


def _spoil(p: Path) -> None:
    p.write_bytes(p.read_bytes()[:-20])


@pytest.mark.parametrize("case", sorted(BAD_RELEASES))
def test_bad_release_is_one_line_and_writes_nothing(tmp_path, case):
    domain, spoil, name, what = BAD_RELEASES[case]
    data = fake_release(tmp_path, domain)
    spoil(data)
    out = tmp_path / "stores"
    line = _one_line_error(run_import(data, out, domain), name)
    assert what in line, line
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.parametrize("overwrite", [(), ("--overwrite",)])
def test_an_output_that_is_a_file_is_named_and_kept(tmp_path, overwrite):
    data = fake_release(tmp_path)
    out = tmp_path / "thesis.pdf"
    out.write_bytes(b"my thesis")
    result = run_import(data, out, "normal", "--no-verify", *overwrite)
    line = _one_line_error(result, "thesis.pdf: is a file")
    assert "give a folder" in line and out.read_bytes() == b"my thesis"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["data", "thesis.pdf"]


def test_content_differing_from_the_manifest_is_refused(tmp_path):
    data = fake_release(tmp_path)
    out = tmp_path / "stores"
    line = _one_line_error(run_import(data, out), "normal-val.zarr")
    assert "does not match split 'normal-val': 3 examples, manifest says 2000; digest sha256:" in line
    assert not out.exists()  # nothing written, not even the folder made for it
    result = run_import(data, out, "normal", "--no-verify")
    assert result.exit_code == 0, result.output
    assert "stored as split normal-val-modified" in result.output
    assert validate(str(out / "normal-val.zarr")).ok
    line = _one_line_error(run_import(data, out, "normal", "--no-verify"), "normal-val.zarr")
    assert "already exists" in line  # complete, but not the manifest's: not kept as a finished split


def test_skip_bad_imports_the_rest_and_reports(tmp_path):
    data = fake_release(tmp_path, "driving", folders=4)
    _spoil(sorted((data / "val/driving/synthetic_1").glob("*.png"))[2])
    _info(data).write_text(_info(data).read_text() + "\n0.5 3.0")
    out = tmp_path / "stores"
    result = run_import(data, out, "driving", "--skip-bad", "--format", "hdf5")
    assert result.exit_code == 0, result.output
    assert "skipped 2 folder(s) of driving-val:" in result.output
    assert "synthetic_1/" in result.output and "synthetic_2/info.txt" in result.output
    with open_store(str(out / "driving-val.h5")) as s:
        assert s.attrs.split == "driving-val-modified"
        assert s.example_ids == ["driving-val-modified/synthetic_3", "driving-val-modified/synthetic_4"]
        ex = s.example(0)
        assert ex.z[0] == 0.0 and ex.d1 == 9.0 and np.all(np.diff(ex.z) > 0)
        skipped = [o.subject for o in s.attrs.oddities if o.problem == "skipped"]
        assert sorted(skipped) == ["driving-val/synthetic_1", "driving-val/synthetic_2"]
    assert validate(str(out / "driving-val.h5")).ok
