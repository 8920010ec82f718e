"""Importing SYNTHIA-SEQS sequences, on sequences rendered here (synthia_scenes.py) in SYNTHIA's
layout: 760x1280 frames of a camera driving past still, moving, leaving and hidden objects."""

from __future__ import annotations

import dataclasses
import json
import math
import re
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
import synthia_scenes as scenes
from click.testing import CliRunner

from odms_data.cli import main
from odms_data.cli.fixes import with_fix
from odms_data.errors import InputError
from odms_data.evaluation.vosde import vosde
from odms_data.importers import poses
from odms_data.importers.decoding import Workers
from odms_data.importers.poses import MAX_ANGLE_SPREAD, angle_spread
from odms_data.importers.synthia import (
    Sighting,
    Track,
    import_synthia,
    plan_store,
    read_pose,
    scan_sequences,
    select_windows,
)
from odms_data.importers.synthia_protocol import SYNTHIA_POSES, PoseConvention, Selection
from odms_data.store.reader import open_store
from odms_data.store.validate import validate

CAM = scenes.CAMERA
RELEASE_NAME = re.compile(r"(SYNTHIA-SEQS-\d\d-[A-Z]+)_(\d+)_(\d+)_(\d+)")


def backing_up() -> scenes.Scene:
    """12 frames, 1.25 m apart except a 0.5 m step backwards from frame 6 to 7; one still car."""
    steps = [1.25] * 11
    steps[6] = -0.5
    return scenes.Scene("SYNTHIA-SEQS-02-FOG", steps, [
        scenes.Thing(3, scenes.CAR, "box", (0.0, 0.75, -30.0), (0.9, 0.75, 0.05))], yaw_rate=0.0)


@pytest.fixture(scope="session")
def seqs(tmp_path_factory) -> dict:
    root = tmp_path_factory.mktemp("synthia")
    street, fog = scenes.street(), backing_up()
    return {"scenes": {s.name: s for s in (street, fog)},
            "dirs": [scenes.write_sequence(root, street), scenes.write_sequence(root, fog)]}


@pytest.fixture(scope="session")
def scanned(seqs):
    with Workers(1) as pool:
        return scan_sequences(seqs["dirs"], pool)


@pytest.fixture(scope="session")
def store(seqs, tmp_path_factory) -> dict:
    """The paper's rules, but windows starting every 3 frames (a third of the frames to write)."""
    out = tmp_path_factory.mktemp("synthia-store") / "street.zarr"
    r = import_synthia(seqs["dirs"], out, selection=Selection(stride=3), workers=2)
    return {"path": r.path, "attrs": r.attrs, "summary": r.summary.to_json()}


def parse_id(eid: str) -> tuple[str, int, int, int]:
    """(sequence, first frame, frames, instance) of an example id <split>/<release folder name>."""
    m = RELEASE_NAME.fullmatch(eid.split("/", 1)[1])
    assert m, eid
    return m.group(1), int(m.group(2)), int(m.group(3)), int(m.group(4))


def test_masks_z_and_depth_follow_the_scene(seqs, store):
    renders: dict = {}
    with open_store(store["path"]) as s:
        assert (s.attrs.domain, s.attrs.split, s.attrs.image_size) == ("driving", "street", (760, 1280))
        for eid in s.example_ids:
            name, first, n, instance = parse_id(eid)
            scene, ex = seqs["scenes"][name], s.example(eid)
            closest = first + n - 1
            frames = range(closest, first - 1, -1)  # closest first
            assert ex.n == n == 10
            np.testing.assert_allclose(ex.z, [scene.camera_move(closest, f) for f in frames], atol=1e-9)
            for j, f in enumerate(frames):
                if (name, f) not in renders:
                    renders[name, f] = scenes.render(scene, f)
                cls, inst, depth = renders[name, f]
                truth = (inst == instance) & np.isin(cls, (8, 10, 11))
                assert np.array_equal(ex.masks[j], truth), (eid, f)
                if truth.any():  # the depth PNGs hold whole centimetres
                    assert ex.depth[j] == pytest.approx(depth[truth].mean(), abs=0.005)
                else:
                    assert math.isnan(ex.depth[j])
            assert ex.d1 == ex.depth[0]


def test_d1_of_a_car_back_is_its_distance(seqs, store):
    """Still car 12 shows the camera its back, a plane 0.05 m nearer than its centre."""
    scene = seqs["scenes"]["SYNTHIA-SEQS-01-DAWN"]
    back = np.add(scene.things[0].centre, (0, 0, 0.05))
    with open_store(store["path"]) as s:
        ids = [e for e in s.example_ids if parse_id(e)[::3] == ("SYNTHIA-SEQS-01-DAWN", 12)]
        assert len(ids) == 5
        for eid in ids:
            _, first, n, _ = parse_id(eid)
            M = scene.pose(first + n - 1)
            distance = np.dot(back - M[:3, 3], -M[:3, 2])
            assert s.example(eid, masks=False).d1 == pytest.approx(distance, rel=0.005)


def test_vosde_recovers_the_depth_of_still_objects(store):
    with open_store(store["path"]) as s:
        result = vosde(s)
        keep = [i for i, e in enumerate(s.example_ids) if parse_id(e)[3] in scenes.STILL_AND_CLEAR]
        errors = np.abs(result.d1[keep] - s.d1[keep]) / s.d1[keep]
    assert len(keep) == 15
    assert errors.mean() < 0.03 and errors.max() < 0.08


def test_store_is_valid_and_records_the_oddities(store):
    report = validate(store["path"])
    assert report.ok, report.problems
    kinds: dict[str, set] = {}
    for o in store["attrs"].oddities:
        kinds.setdefault(o.problem, set()).add(parse_id(o.subject)[::3])
    assert kinds.pop("z-not-increasing") == {("SYNTHIA-SEQS-02-FOG", 3)}  # the camera backing up
    hidden = {("SYNTHIA-SEQS-01-DAWN", 22)}  # behind the kiosk in frames 3 to 5
    assert kinds.pop("empty-mask") == kinds.pop("depth-not-finite") == hidden
    assert not kinds
    counts = {s["name"]: s for s in store["summary"]["sequences"]}
    assert counts["SYNTHIA-SEQS-01-DAWN"] == {
        "name": "SYNTHIA-SEQS-01-DAWN", "frames": 24, "tracks": {"car": 3, "pedestrian": 3, "bicycle": 1},
        "examples": {"car": 12, "pedestrian": 15, "bicycle": 5}}  # the bicycle is hidden in frames 0 and 1
    assert counts["SYNTHIA-SEQS-02-FOG"]["examples"] == {"car": 1}


def ids_of(plan) -> set[tuple[int, int, int]]:
    return {parse_id(e)[1:] for e in plan.ids if "DAWN" in e}


def instances(ids: set[tuple[int, int, int]]) -> set[int]:
    return {i for _, _, i in ids}


def test_selection_rules_keep_and_drop_what_they_should(seqs, scanned):
    paper = ids_of(plan_store(scanned, Selection(), "s")[0])
    assert instances(paper) == {12, 7, 30, 5, 9, 41, 22}
    assert {first for first, _, i in paper if i == 5} == set(range(6))  # car 5 is gone after frame 14
    no_border = ids_of(plan_store(scanned, Selection(border=False), "s")[0])
    assert paper - no_border == {(first, 10, 5) for first in range(2, 6)}  # at the border in frames 11..14
    no_hidden = ids_of(plan_store(scanned, Selection(occluded=False), "s")[0])
    # 9 is always partly behind car 41; 22 passes behind the kiosk; the bicycle comes out behind car 12
    assert instances(paper - no_hidden) == {9, 22, 30} and 9 not in instances(no_hidden)
    assert instances(ids_of(plan_store(scanned, Selection(classes=(11,)), "s")[0])) == {30}
    plan, _ = plan_store(scanned, Selection(d1=(10.0, 20.0)), "s")
    base, _ = plan_store(scanned, Selection(), "s")
    assert ((plan.d1 >= 10) & (plan.d1 <= 20)).all()
    assert len(plan.d1) == ((base.d1 >= 10) & (base.d1 <= 20)).sum()
    # the turning camera moves 11.24 m in 10 frames, the backing-up one 8.25 to 10.75 m
    assert not plan_store(scanned, Selection(move=(11.3, 68.5)), "s")[0].ids
    street = seqs["scenes"]["SYNTHIA-SEQS-01-DAWN"]
    area = {f: np.bincount(scenes.render(street, f)[1].ravel()) for f in range(street.n_frames)}
    large = ids_of(plan_store(scanned, Selection(min_area=5000), "s")[0])
    assert large == {(first, n, i) for first, n, i in paper if area[first + n - 1][i] >= 5000}
    assert 0 < len(large) < len(paper)


def test_windows_share_rows_only_with_the_same_closest_frame(scanned):
    one, _ = plan_store(scanned, Selection(frames=(10,)), "s")
    two, _ = plan_store(scanned, Selection(frames=(10, 12)), "s")
    added = len(two.ids) - len(one.ids)
    assert added > 0 and len(two.masks) == len(one.masks) + 2 * added  # 12-frame windows add two rows
    rows: dict[tuple, list[np.ndarray]] = {}
    for eid, row in zip(two.ids, two.frame_index, strict=True):
        name, first, n, instance = parse_id(eid)
        rows.setdefault((name, instance, first + n - 1), []).append(row[row >= 0])
    for shared in rows.values():
        longest = max(shared, key=len)
        assert all(np.array_equal(r, longest[: len(r)]) for r in shared)
    strided = ids_of(plan_store(scanned, Selection(stride=3), "s")[0])
    assert {first % 3 for first, _, i in strided if i == 7} == {0} and strided <= ids_of(one)


def numbers(values: np.ndarray) -> str:
    return " ".join(repr(float(v)) for v in values)


def test_read_pose_conventions(tmp_path):
    """A camera at (1, 2, 3) turned 30 degrees left, looking along -z of its pose."""
    t = math.radians(30)
    M = np.eye(4)
    M[:3, 0], M[:3, 2], M[:3, 3] = (math.cos(t), 0, -math.sin(t)), (math.sin(t), 0, math.cos(t)), (1, 2, 3)
    axis = -M[:3, 2]
    f = tmp_path / "000000.txt"
    f.write_text(numbers(M.ravel(order="F")))
    centre, forward = read_pose(f, PoseConvention())
    np.testing.assert_allclose(centre, (1, 2, 3))
    np.testing.assert_allclose(forward, axis)
    np.testing.assert_allclose(read_pose(f, PoseConvention(forward="+z"))[1], -axis)
    last_row = r"000000.txt: the matrix's last row is 1 2 3 1, not 0 0 0 1$"
    with pytest.raises(InputError, match=last_row) as refused:
        read_pose(f, PoseConvention(order="row-major"))
    assert with_fix(refused.value).endswith("; if the numbers are column-major, say --matrix-order "
                                            "column-major")
    f.write_text(numbers(np.linalg.inv(M).ravel(order="C")))
    centre, forward = read_pose(f, PoseConvention(order="row-major", direction="world-to-camera"))
    np.testing.assert_allclose(centre, (1, 2, 3), atol=1e-12)
    np.testing.assert_allclose(forward, axis, atol=1e-12)
    M[:3, :3] *= 2
    f.write_text(numbers(M.ravel(order="F")))
    with pytest.raises(InputError, match="000000.txt: the rotation part is not orthonormal"):
        read_pose(f, PoseConvention())


def run_cli(*args):
    return CliRunner().invoke(main, ["import", "synthia", *map(str, args)])


def error_line(r) -> str:
    """The one line of a refused import; progress bars on stderr may precede it, nothing else."""
    assert r.exit_code == 2 and not r.stdout, r.output
    *bars, error = r.stderr.splitlines()
    assert all(b.startswith("importing SYNTHIA-SEQS-") for b in bars), r.stderr
    return error


@pytest.fixture(scope="session")
def small(tmp_path_factory) -> Path:
    """6 frames of the street."""
    return scenes.write_sequence(tmp_path_factory.mktemp("small"), scenes.street(6))


def spoiled(small: Path, tmp_path: Path, spoil) -> Path:
    seq = tmp_path / small.name
    shutil.copytree(small, seq)
    spoil(seq)
    return seq


def truncate(path: Path) -> None:
    path.write_bytes(path.read_bytes()[:3000])


def eight_bit(path: Path) -> None:
    cv2.imwrite(str(path), np.zeros((760, 1280, 3), np.uint8))


def one_channel(path: Path) -> None:
    cv2.imwrite(str(path), cv2.imread(str(path), cv2.IMREAD_UNCHANGED)[..., 2])


def smaller(path: Path) -> None:
    cv2.imwrite(str(path), cv2.imread(str(path), cv2.IMREAD_UNCHANGED)[:380])


def transposed(path: Path) -> None:
    path.write_text(" ".join(np.array(path.read_text().split()).reshape(4, 4).T.ravel()))


SHORT = ("--frames", 3, "--move", 1, 60, "--workers", 1)
BAD_INPUTS = {
    "missing folder": (lambda s: shutil.rmtree(s / "Depth" / CAM), f"Depth/{CAM}: no such folder"),
    "frame counts differ": (lambda s: (s / "Depth" / CAM / "000002.png").unlink(),
                            f"Depth/{CAM}/000002.png: missing, but GT/LABELS has frame 2"),
    "unreadable label": (lambda s: truncate(s / "GT/LABELS" / CAM / "000002.png"),
                         f"GT/LABELS/{CAM}/000002.png: truncated PNG"),
    "8-bit label": (lambda s: eight_bit(s / "GT/LABELS" / CAM / "000002.png"),
                    "000002.png: 8-bit PNG; SYNTHIA label images are 16-bit"),
    "camera file too short": (lambda s: (s / "CameraParams" / CAM / "000002.txt").write_text("1 0 0 0 " * 3),
                              "000002.txt: expected 16 numbers (a 4x4 matrix), found 12"),
    "camera file not numbers": (lambda s: (s / "CameraParams" / CAM / "000002.txt").write_text(
        "1 0 0 0 0 1 0 0 0 0 one 0 0 0 0 1"), "000002.txt: 'one' is not a number"),
    "camera file in the other order": (lambda s: transposed(s / "CameraParams" / CAM / "000002.txt"),
                                       "000002.txt: the matrix's last row is -0.00499999 1.5 -2.49999 1"),
    "empty camera file": (lambda s: (s / "CameraParams" / CAM / "000002.txt").write_text(""),
                          "000002.txt: expected 16 numbers (a 4x4 matrix), found 0"),
    "zero-byte depth PNG": (lambda s: (s / "Depth" / CAM / "000002.png").write_bytes(b""),
                            f"Depth/{CAM}/000002.png: not a PNG file"),
    "1-channel label": (lambda s: one_channel(s / "GT/LABELS" / CAM / "000002.png"),
                        "000002.png: 1 channel(s); SYNTHIA label images have 3"),
    "depth of another size": (lambda s: smaller(s / "Depth" / CAM / "000002.png"),
                              "000002.png: image size 380x1280 differs from the 760x1280"),
}


@pytest.mark.parametrize("case", BAD_INPUTS)
def test_bad_input_is_one_line_naming_the_file(small, tmp_path, case):
    spoil, expect = BAD_INPUTS[case]
    seq = spoiled(small, tmp_path, spoil)
    out = tmp_path / "out.zarr"
    error = error_line(run_cli(seq, "-o", out, *SHORT))
    assert error.startswith(f"odms-data: error: {seq}/") and expect in error, error
    assert not out.exists() and not list(tmp_path.glob("out.zarr*"))


def test_cli_options_reach_the_protocol(small, tmp_path):
    out = tmp_path / "cars.h5"
    options = ("--classes", "car,pedestrian", "--frames", "3,4", "--stride", 2, "--min-area", 300,
               "--no-border", "--no-occluded", "--d1-range", 5, 40, "--max-gap", 0)
    r = run_cli(small, "-o", out, "--json", *options, "--move", 1, 60, "--workers", 1)
    assert r.exit_code == 0, r.output
    summary = json.loads(r.output)
    rules = Selection(classes=(8, 10), frames=(3, 4), stride=2, min_area=300, border=False, occluded=False,
                      move=(1, 60), d1=(5, 40), max_gap=0)
    with Workers(1) as pool:
        scanned = scan_sequences([small], pool)
    plan, _ = plan_store(scanned, rules, "cars")
    everything, _ = plan_store(scanned, Selection(frames=(3, 4), move=(1, 60)), "cars")
    assert 0 < len(plan.ids) < len(everything.ids)
    with open_store(out) as s:
        assert s.example_ids == plan.ids
    assert (summary["split"], summary["examples"]) == ("cars", len(plan.ids))
    r = run_cli(small, "-o", tmp_path / "all.zarr", "--frames", 3, "--move", 1, 60, "--workers", 1)
    assert r.exit_code == 0, r.output
    head = "SYNTHIA-SEQS-01-DAWN: 6 frames; tracks: 3 car, 3 pedestrian, 1 bicycle; examples: "
    assert r.stdout.startswith(head), r.output
    assert "wrote " in r.stdout and " frames, 0 oddities recorded, digest " in r.stdout
    progress = r.stderr.splitlines()  # stderr is no terminal here: progress comes as lines
    assert {line.split(": ")[0] for line in progress} == {"importing SYNTHIA-SEQS-01-DAWN",
                                                           "importing all.zarr (writing)"}
    assert progress[-1].startswith("importing all.zarr (writing): ") and "(100%)" in progress[-1]


def test_the_folder_above_the_sequences_gets_a_hint(small, tmp_path):
    error = error_line(run_cli(small.parent, "-o", tmp_path / "out.zarr"))
    above = small.parent
    assert error == (f"odms-data: error: {above}/GT/LABELS/{CAM}: no such folder ({above} holds "
                     f"sequence folders; give those, e.g. {small})")


def test_a_class_absent_from_every_sequence_is_an_error(small, tmp_path):
    error = error_line(run_cli(small, "-o", tmp_path / "out.zarr", "--classes", "car,15", *SHORT))
    assert error == (f"odms-data: error: {small}/GT/LABELS/{CAM}: no instance of class 15 "
                     "(schemas/SYNTHIA.md) in any label image")
    error = error_line(run_cli(small, "-o", tmp_path / "out.zarr", "--classes", "lorry", *SHORT))
    assert error.startswith("odms-data: error: --classes 'lorry': not a class; use car, pedestrian, bicycle")
    assert not list(tmp_path.iterdir())


def test_skip_bad_leaves_out_a_frame_and_splits_its_tracks(small, tmp_path):
    seq = spoiled(small, tmp_path, lambda s: truncate(s / "GT/LABELS" / CAM / "000002.png"))
    out = tmp_path / "out.zarr"
    r = run_cli(seq, "-o", out, "--skip-bad", "--json", *SHORT)
    assert r.exit_code == 0, r.output
    summary = json.loads(r.output)
    assert len(summary["skipped"]) == 1 and "000002.png: truncated PNG" in summary["skipped"][0]
    with open_store(out) as s:  # windows of 3 frames: only frames 3 to 5 remain together
        assert {parse_id(e)[1:3] for e in s.example_ids} == {(3, 3)}
        assert [o.problem for o in s.attrs.oddities] == ["skipped"]


def test_release_folder_names_and_camera_moves_follow_the_same_rules(official_data_dir):
    """The release's driving folders: <sequence>_<first>_<frames>_<instance>, consecutive SYNTHIA
    frame numbers from <first>, and camera_move 0 at the last (closest) frame, as imported here."""
    folders = [f for fold in ("val", "test") for f in (official_data_dir / fold / "driving").iterdir()]
    assert len(folders) == 1250
    for folder in folders:
        _, first, n, _ = parse_id(f"x/{folder.name}")
        pngs = sorted(int(p.stem) for p in folder.glob("*.png"))
        assert pngs == list(range(first, first + n)), folder
        moves = [float(line.split()[0]) for line in (folder / "info.txt").read_text().splitlines()[1:]]
        assert abs(moves[-1]) < 1e-12 and min(moves[:-1]) > -0.01, folder


def _pose_file(path, M):
    path.write_text(" ".join(repr(float(v)) for v in M.flatten(order="F")) + "\n")
    return path


def test_an_improper_pose_reads_as_its_proper_twin(tmp_path):
    """SYNTHIA's poses are probably improper (determinant -1, a mirrored axis): the centre and the
    optical axis read from one are those of the same camera with its x axis unmirrored."""
    a, mirror = 0.3, np.diag([-1.0, 1, 1, 1])  # the camera's x axis mirrored
    proper = np.eye(4)
    proper[:3, :3] = [[np.cos(a), 0, np.sin(a)], [0, 1, 0], [-np.sin(a), 0, np.cos(a)]]
    proper[:3, 3] = (1.0, 2.0, 3.0)
    for direction, improper in (("camera-to-world", proper @ mirror), ("world-to-camera", mirror @ proper)):
        assert np.linalg.det(improper[:3, :3]) == pytest.approx(-1)
        conv = dataclasses.replace(SYNTHIA_POSES, direction=direction)
        c0, f0 = read_pose(_pose_file(tmp_path / "p.txt", proper), conv)
        c1, f1 = read_pose(_pose_file(tmp_path / "i.txt", improper), conv)
        np.testing.assert_allclose(c1, c0, atol=1e-12)
        np.testing.assert_allclose(f1, f0, atol=1e-12)


def test_the_gap_rule_bounds_a_windows_empty_masks_in_all():
    """Three absences of 3 frames each are each within --max-gap 5, but a 10-frame window with 6
    empty masks is not kept; one with 3 is."""
    present = [0, 4, 8, 9, 13, 14, 15, 16, 17, 18, 19]
    sightings = {f: Sighting(1, 8, 500, 10.0, False, False, None) for f in present}  # type: ignore[arg-type]
    track = Track(None, 1, list(range(20)), sightings)  # type: ignore[arg-type]
    poses = {f: (np.array([0.0, 0.0, 0.5 * f]), np.array([0.0, 0.0, 1.0])) for f in range(20)}
    kept = select_windows(track, poses, Selection(move=(0.1, 100)))
    assert sorted(kept) == [15, 16, 17, 18, 19]  # 5, 4, 3, 3, 3 empty masks
    # left out: closest frames 14, 13 and 9, whose windows have 6 empty masks each


# --- the pose direction: a camera fixed to a car keeps its angle to its movement ---------------
def rot_y(t: float) -> np.ndarray:
    return np.array([[np.cos(t), 0, np.sin(t)], [0, 1, 0], [-np.sin(t), 0, np.cos(t)]])


def driven(steps, turns, *, ahead=0.0, mount=0.0, mirrored=False, jitter=0.0) -> list[np.ndarray]:
    """Camera-to-world matrices, one per frame, of a camera `ahead` m in front of a car's rear axle
    looking `mount` rad left of the car's heading (x axis mirrored, determinant -1, if `mirrored`),
    the axle driving steps[k] m from frame k to k + 1 along an arc that turns turns[k] rad (to the
    left), far from the world's origin; each centre off by `jitter` m at random."""
    rng = np.random.default_rng(0)
    axle, yaw, out = np.array([120.0, 1.5, -80.0]), 0.3, []
    for k in range(len(steps) + 1):
        for _ in range(20 if k else 0):  # the arc, in small pieces
            yaw += turns[k - 1] / 20
            axle = axle + steps[k - 1] / 20 * scenes.heading(yaw)
        M = np.eye(4)
        M[:3, :3] = rot_y(yaw + mount) @ np.diag([-1.0 if mirrored else 1.0, 1, 1])
        M[:3, 3] = axle + ahead * scenes.heading(yaw) + jitter * rng.standard_normal(3)
        out.append(M)
    return out


def spreads(tmp_path: Path, matrices: list[np.ndarray]) -> dict[str, float]:
    """angle_spread of the poses read from the files of `matrices` in each direction."""
    out = {}
    for direction in ("camera-to-world", "world-to-camera"):
        conv = dataclasses.replace(SYNTHIA_POSES, direction=direction)
        out[direction] = angle_spread({k: read_pose(_pose_file(tmp_path / f"{k:06d}.txt", M), conv)
                                       for k, M in enumerate(matrices)})
    return out


QUARTER = [math.pi / 20] * 10  # a junction: 90 degrees over 10 frames (9 degrees, 1.5 m each)
JUNCTION = ([2.0] * 10 + [1.5] * 10 + [2.0] * 10, [0.0] * 10 + QUARTER + [0.0] * 10)
TIGHT = 4.5  # m, a car's tightest turn (at the rear axle), driven at 1 m per frame (18 km/h at 5 fps)
LEFT_AND_RIGHT = ([2.0] * 5 + [1.0] * 14 + [2.0] * 5 + [1.0] * 14 + [2.0] * 5,
                  [0.0] * 5 + [1 / TIGHT] * 14 + [0.0] * 5 + [-1 / TIGHT] * 14 + [0.0] * 5)
STOP_AND_GO = ([2.0] * 8 + [0.0] * 10 + [1.5] * 10 + [0.0] * 6 + [2.0] * 8,
               [0.0] * 18 + QUARTER + [0.0] * 14)
BACKING_UP = ([2.0] * 8 + [0.3, 0.0, -0.4, -0.8, -0.8, -0.4, 0.0, 0.5] + [2.0] * 8,  # into a parking bay
              [0.0] * 10 + [0.1, 0.15, 0.15, 0.1] + [0.0] * 10)


@pytest.mark.parametrize("mirrored", [False, True], ids=["proper", "improper"])
def test_the_pose_direction_shows_in_the_angle_of_the_movement(tmp_path, mirrored):
    """Right (camera-to-world), the angle between a camera's movement and its axis holds along a
    turning drive; wrong, it follows the heading and swings past MAX_ANGLE_SPREAD. The same with
    SYNTHIA's probably improper matrices (determinant -1)."""
    junction = spreads(tmp_path, driven(*JUNCTION, mirrored=mirrored))
    assert junction["camera-to-world"] < 1 and junction["world-to-camera"] > MAX_ANGLE_SPREAD
    for ahead, mount, most in ((3.0, math.pi / 2, 70), (3.0, 0.0, 35), (0.0, math.pi, 1)):
        worst = spreads(tmp_path, driven(*LEFT_AND_RIGHT, ahead=ahead, mount=mount, mirrored=mirrored))
        assert most - 5 < worst["camera-to-world"] < most < MAX_ANGLE_SPREAD, (ahead, mount, worst)
        assert worst["world-to-camera"] > MAX_ANGLE_SPREAD, (ahead, mount, worst)


def test_halts_and_backing_up_are_not_taken_for_a_wrong_direction(tmp_path, monkeypatch):
    """Stops (the centre still but for 1 mm of noise) give the movement no direction: they are left
    out, and a stop-and-go drive reads as it is; counting them would refuse it. A car that halts
    and backs up moves against its axis: that reversal is undone, not refused."""
    stop_and_go = driven(*STOP_AND_GO, jitter=0.001)
    got = spreads(tmp_path, stop_and_go)
    assert got["camera-to-world"] < 1 and got["world-to-camera"] > MAX_ANGLE_SPREAD
    assert spreads(tmp_path, driven(*BACKING_UP))["camera-to-world"] < 1
    monkeypatch.setattr(poses, "NEAR_HALT", 0.0)  # no reversal recognised
    assert spreads(tmp_path, driven(*BACKING_UP))["camera-to-world"] > MAX_ANGLE_SPREAD
    monkeypatch.setattr(poses, "MIN_MOVE", 0.0)
    assert spreads(tmp_path, stop_and_go)["camera-to-world"] > MAX_ANGLE_SPREAD


@pytest.fixture(scope="module")
def junction(tmp_path_factory) -> Path:
    """A camera turning left at a junction (90 degrees over 10 frames) towards a car parked on the
    road it turns into, rendered in SYNTHIA's layout. Its headings, 70 to 160 degrees left of the
    world's -z, make the wrong direction's z grow too on the road it turns into (its movement 20
    degrees off its axis there): the windows pass the selection rules either way."""
    steps, turns = [2.0] * 3 + [1.5] * 10 + [2.0] * 3, [0.0] * 3 + QUARTER + [0.0] * 3
    scene = scenes.Scene("SYNTHIA-SEQS-04-SPRING", steps, turns=turns, start_yaw=math.radians(70))
    end = scene.pose(len(steps))[:3, 3] + 22 * scenes.heading(scene.yaw(len(steps)))
    scene.things.append(scenes.Thing(3, scenes.CAR, "box", (end[0], 0.75, end[2]), (0.9, 0.75, 0.9)))
    return scenes.write_sequence(tmp_path_factory.mktemp("junction"), scene)


def test_a_wrong_pose_direction_is_refused_where_the_camera_turns(junction, tmp_path):
    r = run_cli(junction, "-o", tmp_path / "right.zarr", *SHORT)
    assert r.exit_code == 0 and "examples: " in r.stdout, r.output
    error = error_line(run_cli(junction, "-o", tmp_path / "wrong.zarr", *SHORT, "--pose", "world-to-camera"))
    assert re.fullmatch(r"odms-data: error: SYNTHIA-SEQS-04-SPRING: the angle between the camera's "
                        r"movement and its optical axis varies by (\d+) degrees along the sequence, more "
                        r"than the 80 a camera fixed to a car can: its poses are probably not "
                        r"world-to-camera matrices; --pose is probably wrong: SYNTHIA's matrices map the "
                        r"camera to the world, so say --pose camera-to-world \(the default\)", error), error
    assert not list(tmp_path.glob("wrong.zarr*"))
