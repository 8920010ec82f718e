"""Importing a recording whose camera is given by poses (4x4 matrices, .npy, KITTI, TUM) instead of
positions.csv: the same examples as the CSV would give (on generated recordings and on official
robot-test ones), and windows that turn too much refused and listed."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from click.testing import CliRunner
from scipy.spatial.transform import Rotation

from odms_data.cli import main
from odms_data.errors import InputError
from odms_data.importers.poses import read_poses
from odms_data.importers.recording import import_recording
from odms_data.store.reader import open_store

H, W, N = 48, 64, 12
TIMES = 1305031102.0 + 0.1 * np.arange(N)


def write_masks(root: Path) -> list[str]:
    """N masks named by their time, a disk shrinking frame by frame."""
    masks = root / "masks"
    masks.mkdir()
    names = [f"{t:.6f}.png" for t in TIMES]
    for i, name in enumerate(names):
        img = np.zeros((H, W), np.uint8)
        cv2.circle(img, (W // 2, H // 2), 20 - i, 255, -1)
        cv2.imwrite(str(masks / name), img)
    return names


def c2w_poses(z: np.ndarray, turn_deg: np.ndarray) -> np.ndarray:
    """(N, 4, 4) camera-to-world poses of a camera in an arbitrary orientation turned by turn_deg
    about its own y axis, its centre moved by -z along its first optical axis (+z)."""
    R0 = Rotation.from_euler("xyz", [20, -35, 50], degrees=True).as_matrix()
    out = np.tile(np.eye(4), (len(z), 1, 1))
    for i in range(len(z)):
        out[i, :3, :3] = R0 @ Rotation.from_euler("y", turn_deg[i], degrees=True).as_matrix()
        out[i, :3, 3] = np.array([1.0, -2.0, 3.0]) - z[i] * R0[:, 2]
    return out


def write_formats(root: Path, c2w: np.ndarray) -> dict[str, tuple[Path, str]]:
    """The poses as every format: name -> (file, --pose direction)."""
    w2c = np.linalg.inv(c2w)
    files = {"4x4": (root / "poses.txt", "camera-to-world"), "npy": (root / "w2c.npy", "world-to-camera"),
             "kitti": (root / "kitti.txt", "camera-to-world"), "tum": (root / "tum.txt", "camera-to-world")}
    files["4x4"][0].write_text("".join(" ".join(f"{v:.17g}" for v in M.ravel()) + "\n" for M in c2w))
    np.save(files["npy"][0], w2c)
    files["kitti"][0].write_text("".join(" ".join(f"{v:.17g}" for v in M[:3].ravel()) + "\n" for M in c2w))
    quats = Rotation.from_matrix(c2w[:, :3, :3]).as_quat()  # qx qy qz qw
    files["tum"][0].write_text("# timestamp tx ty tz qx qy qz qw\n" + "".join(
        f"{t + 0.004:.6f} " + " ".join(f"{v:.17g}" for v in (*M[:3, 3], *q)) + "\n"
        for t, M, q in zip(TIMES, c2w, quats, strict=True)))
    return files


def examples(path: str) -> dict[str, tuple[np.ndarray, float]]:
    with open_store(path) as s:
        return {i: (s.example(i).z, s.example(i).d1) for i in s.example_ids}


@pytest.mark.parametrize("fmt", ["4x4", "npy", "kitti", "tum"])
def test_poses_give_the_examples_positions_give(tmp_path, fmt):
    names = write_masks(tmp_path)
    z = 0.02 * np.arange(N) + np.random.default_rng(1).uniform(0, 0.005, N)
    z -= z[0]  # poses give z from the first frame's position
    rows = "".join(f"{n},{v:.17g}\n" for n, v in zip(names, z, strict=True))
    (tmp_path / "positions.csv").write_text("frame,z\n" + rows)
    poses, direction = write_formats(tmp_path, c2w_poses(z, np.zeros(N)))[fmt]
    common = {"windows": [5, 8], "n_obs": 3, "d1": 0.3, "workers": 1, "name": "rec"}
    want = examples(import_recording(tmp_path / "masks", tmp_path / "positions.csv", tmp_path / "csv.zarr",
                                     **common).path)
    got = examples(import_recording(tmp_path / "masks", None, tmp_path / "poses.zarr", poses=poses,
                                    pose=direction, **common).path)
    assert list(got) == list(want) and len(want) == 5 + 8
    for i in want:
        np.testing.assert_allclose(got[i][0], want[i][0], atol=1e-9)
        assert got[i][1] == pytest.approx(want[i][1], abs=1e-9)


def test_the_wrong_direction_gives_other_positions(tmp_path):
    """world-to-camera matrices read as camera-to-world put the camera elsewhere: the z differ."""
    write_masks(tmp_path)
    z = 0.02 * np.arange(N)
    poses, _ = write_formats(tmp_path, c2w_poses(z, np.zeros(N)))["npy"]
    r = import_recording(tmp_path / "masks", None, tmp_path / "a.zarr", poses=poses, pose="camera-to-world",
                         d1=0.3, workers=1)
    (zs, _), = examples(r.path).values()
    assert not np.allclose(zs - zs[0], z)


def test_windows_turning_past_max_rotation_are_refused_and_listed(tmp_path):
    """The camera turns 0.5 degrees a frame, then 1.5: a 5-frame window turns 2 to 6 degrees."""
    write_masks(tmp_path)
    steps = np.where(np.arange(N) < 6, 0.5, 1.5)
    turn = np.concatenate([[0], np.cumsum(steps[1:])])
    poses, _ = write_formats(tmp_path, c2w_poses(0.02 * np.arange(N), turn))["tum"]
    turned = {f"rec/w5-{s:02d}": turn[s + 4] - turn[s] for s in range(N - 4)}
    refused = sorted(i for i, t in turned.items() if t > 3)
    assert 0 < len(refused) < len(turned)
    r = CliRunner().invoke(main, ["import", "recording", str(tmp_path / "masks"), "--poses", str(poses),
                                  "--windows", "5", "--n-obs", "3", "-o", str(tmp_path / "rec.zarr"),
                                  "--workers", "1"])
    assert r.exit_code == 0, r.output
    assert f"{len(turned) - len(refused)} example(s)" in r.output
    assert f"skipped {len(refused)} file(s) or turning example(s)" in r.output
    said = [line for line in r.output.splitlines() if "degrees, more than" in line]
    listed = sorted(line.split(":")[0].strip() for line in said)
    assert listed == refused
    for line in said:
        angle = float(line.split("turn by ")[1].split()[0])
        assert angle == pytest.approx(turned[line.split(":")[0].strip()], abs=0.01)
    assert sorted(examples(str(tmp_path / "rec.zarr"))) == sorted(set(turned) - set(refused))
    r = CliRunner().invoke(main, ["import", "recording", str(tmp_path / "masks"), "--poses", str(poses),
                                  "--windows", "5", "--n-obs", "3", "-o", str(tmp_path / "all.zarr"),
                                  "--max-rotation", "10", "--workers", "1"])
    assert r.exit_code == 0 and f"{len(turned)} example(s)" in r.output, r.output


def test_tum_frames_without_a_pose_in_time_are_refused(tmp_path):
    write_masks(tmp_path)
    poses, _ = write_formats(tmp_path, c2w_poses(0.02 * np.arange(N), np.zeros(N)))["tum"]
    with pytest.raises(InputError, match=r"\.png: no pose in .*tum.txt within 0.001 s of its time"):
        import_recording(tmp_path / "masks", None, tmp_path / "a.zarr", poses=poses, time_tolerance=0.001)


BAD_ROWS = {  # name: (file name, its text, what the error says)
    "NaN in TUM": ("t.txt", "1 0 0 0 0 0 0 1\n2 nan 0 0 0 0 0 1\n",
                   "t.txt line 2, field 2: 'nan' is not a finite"),
    "a non-unit quaternion": ("t.txt", "1 0 0 0 0 0 0 1.01\n",
                              "t.txt line 1: quaternion qx qy qz qw has norm 1.01"),
    "a scaled matrix": ("m.txt", " ".join(map(str, np.diag([2, 1, 1, 1]).ravel())) + "\n",
                        "m.txt line 1: the rotation part is not orthonormal"),
    "a reflection": ("k.txt", " ".join(map(str, np.diag([-1, 1, 1, 1])[:3].ravel())) + "\n",
                     "k.txt line 1: the rotation part is a reflection (det -1)"),
    "a short row": ("k.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n",
                    "k.txt line 2: 11 numbers, expected 12 as on line 1"),
    "an unknown row": ("x.txt", "1 2 3\n", "x.txt line 1: 3 numbers; a pose row has 16"),
    "timestamps going back": ("t.txt", "2 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n",
                              "t.txt line 2: timestamp 1 is not after"),
}


@pytest.mark.parametrize("case", BAD_ROWS)
def test_each_bad_row_is_named(tmp_path, case):
    name, text, says = BAD_ROWS[case]
    (tmp_path / name).write_text(text)
    with pytest.raises(InputError) as e:
        read_poses(tmp_path / name)
    assert says in str(e.value) and "\n" not in str(e.value)


def _robot_recordings(archive: Path, root: Path, count: int) -> list[Path]:
    """The first `count` robot-test folders of the official archive, extracted under root."""
    import tarfile

    prefix = "data/test/robot/"
    with tarfile.open(archive) as tar:
        members = [m for m in tar.getmembers() if m.name.startswith(prefix) and m.name.count("/") == 4]
        folders = sorted({m.name.split("/")[3] for m in members})[:count]
        tar.extractall(root, [m for m in members if m.name.split("/")[3] in folders], filter="data")
    return [root / prefix / f for f in folders]


def _rows(matrices: np.ndarray, first: list[str] | None = None) -> str:
    """Text rows of the matrices' numbers (4x4), or (TUM) of `first` + centre + quaternion."""
    if first is None:
        return "".join(" ".join(f"{v:.17g}" for v in M.ravel()) + "\n" for M in matrices)
    quats = Rotation.from_matrix(matrices[:, :3, :3]).as_quat()
    return "".join(" ".join([t, *(f"{v:.17g}" for v in (*M[:3, 3], *q))]) + "\n"
                   for t, M, q in zip(first, matrices, quats, strict=True))


def test_official_robot_positions_as_tum_and_matrices_give_the_same_z(official_archive, tmp_path):
    """Three of the official robot-test recordings (masks named by z in micrometres): their
    positions as positions.csv, as a TUM trajectory and as 4x4 matrices import to the same z."""
    for masks in _robot_recordings(official_archive, tmp_path, 3):
        names = sorted(p.name for p in masks.iterdir())
        z = np.array([int(n.split(".")[0]) / 1e6 for n in names])
        out = tmp_path / masks.name
        out.mkdir()
        rows = "".join(f"{n},{v!s}\n" for n, v in zip(names, z.tolist(), strict=True))
        (out / "positions.csv").write_text("frame,z\n" + rows)
        c2w = c2w_poses(z - z[0], np.zeros(len(z)))
        (out / "poses.txt").write_text(_rows(c2w))
        order = np.argsort(z)  # TUM: rows in time order; a mask's time is its name
        (out / "tum.txt").write_text(_rows(c2w[order], [names[i].split(".")[0] for i in order]))
        (want, _), = examples(import_recording(masks, out / "positions.csv", out / "csv.zarr", workers=1,
                                               name="r").path).values()
        for poses in ("poses.txt", "tum.txt"):
            (got, _), = examples(import_recording(masks, None, out / f"{poses}.zarr", poses=out / poses,
                                                  workers=1, name="r").path).values()
            np.testing.assert_allclose(got - got[0], want - want[0], atol=1e-9, err_msg=f"{masks} {poses}")
