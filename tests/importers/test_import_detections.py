"""`import detections`: boxes of a track or of a category's detections, with the camera's poses, into
a store of boxes with ODMD's movement (checked against ODMD's own sets, whose camera_movement is
p[-1] - p, p the object in the camera's axes), missed detections, the association rule and its
close choices, and bad rows named in one line."""

from __future__ import annotations

import warnings

import cv2
import numpy as np
import pytest
from click.testing import CliRunner
from detection_formats import H, Scene, W, scene, write_coco, write_matrices, write_mot, write_tum, write_yolo

from odms_data.cli import main
from odms_data.errors import InputError
from odms_data.evaluation.box_ls import box_ls
from odms_data.importers.detections import Camera, RleMask, Which, checked_rle, import_detections
from odms_data.pickles import load_pickle
from odms_data.store.reader import open_store

N = 24
TIMES = 1305031102.0 + np.arange(N) / 30


def stored(path: str) -> dict[str, tuple[np.ndarray, np.ndarray, np.ndarray, float]]:
    """Each example's boxes, movements, depths and label."""
    with open_store(path) as s:
        out = {}
        for e, i in enumerate(s.example_ids):
            f = s.frames_of(e)
            out[i] = (s.box[f], s.move[f], s.depth[f], float(s.d1[e]))
        return out


def track_rows(sc: Scene, missing: tuple[int, ...] = ()) -> list:
    """The object as track 7 and a second object, track 2, beside it in every frame."""
    rows = []
    for k, b in enumerate(sc.boxes):
        rows.append((k + 1, 2, b + np.array([0.3, 0.1, 0, 0]), 0.9))
        if k not in missing:
            rows.append((k + 1, 7, b, 0.8))
    return rows


@pytest.mark.parametrize("poses", ["4x4", "tum", "npy-world-to-camera"])
def test_a_track_gives_odmd_examples(tmp_path, poses):
    """One example over all frames, far to near: the boxes as projected, ODMD's movement p[-1] - p,
    the depths from --d1; Box_LS recovers the depth at the closest frame."""
    sc = scene(N)
    mot = write_mot(tmp_path / "gt.txt", track_rows(sc))
    if poses == "4x4":
        camera = Camera(write_matrices(tmp_path / "c2w.txt", sc.c2w))
    elif poses == "tum":
        camera = Camera(write_tum(tmp_path / "tum.txt", TIMES + 0.003, sc.c2w), fps=30, start_time=TIMES[0])
    else:
        np.save(tmp_path / "w2c.npy", np.linalg.inv(sc.c2w))
        camera = Camera(tmp_path / "w2c.npy", "world-to-camera")
    done = import_detections("mot", mot, camera, tmp_path / "out.zarr", which=Which(track=7),
                             image_size=(H, W), d1=0.5, name="cup")
    assert done.frames == N and done.missed == [] and done.close == []
    (i, (box, move, depth, d1)), = stored(done.result.path).items()
    assert i == "cup/all"
    np.testing.assert_allclose(box, sc.boxes, atol=1e-12)  # approaching: far to near is time order
    np.testing.assert_allclose(move, sc.p[-1] - sc.p, atol=1e-9)
    np.testing.assert_allclose(depth, sc.p[:, 2], atol=1e-9)  # the camera moves along z as it turns not
    assert d1 == pytest.approx(0.5)
    with open_store(done.result.path) as s:
        assert box_ls(s).d1[0] == pytest.approx(0.5, rel=1e-6)


def test_the_movement_is_odmds_on_odmds_own_sets(tmp_path, odmd_data):
    """ODMD's normal-val examples where the camera approaches: a camera at -R p_k (the object at the
    origin, p_k its position in the camera's axes from the pickle), the boxes as a track; the store
    has ODMD's boxes and camera_movement."""
    d = load_pickle(odmd_data / "odmd" / "val" / "val_normal.pk")
    p, bb, cm = d["bb_3D"]["positions"], d["bb"]["bboxes"], d["bb_3D"]["camera_movement"]
    approaching = np.flatnonzero(p[-1, 2] < p[0, 2])[:5]
    R = scene(2).c2w[0, :3, :3]
    for e in approaching:
        c2w = np.tile(np.eye(4), (10, 1, 1))
        c2w[:, :3, :3], c2w[:, :3, 3] = R, -(R @ p[:, :, e].T).T
        mot = write_mot(tmp_path / f"{e}.txt", [(k + 1, 1, bb[k, :4, e], 1.0) for k in range(10)])
        done = import_detections("mot", mot, Camera(write_matrices(tmp_path / f"{e}.pose", c2w)),
                                 tmp_path / f"{e}.zarr", which=Which(track=1), image_size=(480, 640))
        (box, move, _, _), = stored(done.result.path).values()
        np.testing.assert_allclose(box, bb[:, :4, e], atol=1e-12)
        np.testing.assert_allclose(move[:-1], cm[:, :, e], atol=1e-9)
        assert not move[-1].any()


def test_missed_frames_are_stored_as_odmd_stores_them(tmp_path):
    sc = scene(N)
    missing = (0, 5, 6, 23)
    mot = write_mot(tmp_path / "gt.txt", track_rows(sc, missing))
    camera = Camera(write_matrices(tmp_path / "c2w.txt", sc.c2w))
    done = import_detections("mot", mot, camera, tmp_path / "out.zarr", which=Which(track=7),
                             image_size=(H, W), d1=0.5)
    assert done.missed == [str(k + 1) for k in missing]
    (box, _, _, _), = stored(done.result.path).values()
    assert not box[list(missing)].any()  # [0, 0, 0, 0]: zero width, a missed detection to Box_LS
    np.testing.assert_allclose(np.delete(box, missing, axis=0), np.delete(sc.boxes, missing, axis=0),
                               atol=1e-12)
    with open_store(done.result.path) as s:
        result = box_ls(s, n_obs=N)
        assert result.flagged[0] and not result.unsolvable[0]


def test_windows_follow_the_robot_protocol(tmp_path):
    sc = scene(N)
    mot = write_mot(tmp_path / "gt.txt", track_rows(sc))
    camera = Camera(write_matrices(tmp_path / "c2w.txt", sc.c2w))
    done = import_detections("mot", mot, camera, tmp_path / "out.zarr", which=Which(track=7),
                             image_size=(H, W), windows=[10, 15], n_obs=5, d1=0.5, name="w")
    got = stored(done.result.path)
    assert len(got) == (N - 9) + (N - 14)
    box, move, depth, d1 = got["w/w10-00"]  # the closest ten frames, n_obs=5 of them, far to near
    frames = (N - 1) - np.linspace(0, 9, 5).astype(int)[::-1]
    np.testing.assert_allclose(box, sc.boxes[frames], atol=1e-12)
    np.testing.assert_allclose(move, sc.p[frames[-1]] - sc.p[frames], atol=1e-9)
    assert d1 == pytest.approx(sc.p[-1, 2], abs=1e-9)


def test_turning_windows_are_refused_and_listed(tmp_path):
    turn = np.concatenate([np.zeros(12), np.arange(1, 13) * 1.0])
    sc = scene(N, turn_deg=turn)
    mot = write_mot(tmp_path / "gt.txt", track_rows(sc))
    r = CliRunner().invoke(main, ["import", "detections", str(mot), "--track", "7", "--image-size", "640x480",
                                  "--poses", str(write_matrices(tmp_path / "c2w.txt", sc.c2w)),
                                  "--windows", "5", "--n-obs", "3", "-o", str(tmp_path / "t.zarr")])
    assert r.exit_code == 0, r.output
    refused = [line for line in r.output.splitlines() if "degrees, more than max_rotation 3" in line]
    assert refused and len(refused) < N - 4
    assert len(stored(str(tmp_path / "t.zarr"))) == N - 4 - len(refused)


def test_the_association_rule_and_its_close_choices(tmp_path):
    """Per-frame detections (MOT's det.txt, id -1): the best score first, then the best overlap with
    the box chosen last; a distractor scoring higher later is not taken; close choices listed."""
    sc = scene(N)
    rows = []
    for k, b in enumerate(sc.boxes):
        if k == 0:
            rows.append((1, -1, b + np.array([0.4, 0, 0, 0]), 0.87))  # close to the object's 0.9
        rows.append((k + 1, -1, b, 0.9 if k == 0 else 0.5))
        if k > 0:
            rows.append((k + 1, -1, b + np.array([0.3, 0.2, 0, 0]), 0.99))  # a distractor, elsewhere
        if k == 8:
            rows.append((k + 1, -1, b * [1, 1, 1.04, 1.04], 0.4))  # nearly the object's box
    rows = [r for r in rows if not (r[0] == 13 and r[3] == 0.5)]  # frame 13: the object missed
    mot = write_mot(tmp_path / "det.txt", rows)
    done = import_detections("mot", mot, Camera(write_matrices(tmp_path / "c2w.txt", sc.c2w)),
                             tmp_path / "a.zarr", image_size=(H, W))
    assert done.missed == ["13"]
    assert [c.split(":")[0] for c in done.close] == ["frame 1", "frame 9"], done.close
    (box, _, _, _), = stored(done.result.path).values()
    np.testing.assert_allclose(np.delete(box, 12, axis=0), np.delete(sc.boxes, 12, axis=0), atol=1e-12)
    r = CliRunner().invoke(main, ["import", "detections", str(mot), "--image-size", "640x480", "--poses",
                                  str(tmp_path / "c2w.txt"), "-o", str(tmp_path / "b.zarr")])
    assert r.exit_code == 0, r.output
    assert "missed detections: 1 frame(s) (13)" in r.output
    assert "close choices: 2 frame(s)" in r.output and "  frame 9: IoU" in r.output


BAD_MOT = {  # name: (text, what the error says)
    "too few fields": ("1,7,10,10,5\n", "gt.txt line 1: 5 fields; a MOTChallenge row has 6 to 10"),
    "a million fields": ("1," * 10**6 + "1\n", "gt.txt line 1: longer than a row can be"),
    "not a number": ("1,7,10,ten,5,5,1\n", "gt.txt line 1: y 'ten' is not a number"),
    "NaN": ("1,7,10,10,nan,5,1\n", "gt.txt line 1: w 'nan' is not a finite number"),
    "frame 0": ("0,7,10,10,5,5,1\n", "gt.txt line 1: frame '0' is not a whole number >= 1"),
    "negative width": ("1,7,10,10,-5,5,1\n", "gt.txt line 1: the box's width and height must be >= 0"),
    "past the poses": ("30,7,10,10,5,5,1\n", "gt.txt line 1: frame 30, but there are 24 poses"),
    "a second box": ("1,7,1,1,5,5,1\n2,7,1,1,5,5,1\n2,7,1,1,5,5,1\n",
                     "gt.txt line 3: track 7 has a second box in frame 2"),
    "not text": (b"1,7,\xff\n", "gt.txt: not a text file"),
}


@pytest.mark.parametrize("case", BAD_MOT)
def test_each_bad_mot_row_is_one_line_and_exit_2(tmp_path, case):
    text, says = BAD_MOT[case]
    mot = tmp_path / "gt.txt"
    mot.write_bytes(text if isinstance(text, bytes) else text.encode())
    poses = write_matrices(tmp_path / "c2w.txt", scene(N).c2w)
    r = CliRunner().invoke(main, ["import", "detections", str(mot), "--track", "7", "--image-size", "640x480",
                                  "--poses", str(poses), "-o", str(tmp_path / "x.zarr")])
    assert r.exit_code == 2, r.output
    lines = r.output.strip().splitlines()
    assert len(lines) == 1 and says in lines[0], r.output
    assert not (tmp_path / "x.zarr").exists()


def test_choosing_the_object_is_checked(tmp_path):
    sc = scene(N)
    mot = write_mot(tmp_path / "gt.txt", track_rows(sc))
    camera = Camera(write_matrices(tmp_path / "c2w.txt", sc.c2w))
    with pytest.raises(InputError, match="gt.txt: no box of track 9"):
        import_detections("mot", mot, camera, tmp_path / "x.zarr", which=Which(track=9), image_size=(H, W))
    with pytest.raises(InputError, match="MOTChallenge rows have no category"):
        import_detections("mot", mot, camera, tmp_path / "x.zarr", which=Which(category=1), image_size=(H, W))
    with pytest.raises(InputError, match="give the frame rate"):
        import_detections("mot", mot, Camera(write_tum(tmp_path / "t.txt", TIMES, sc.c2w)),
                          tmp_path / "x.zarr", which=Which(track=7), image_size=(H, W))


def names_by_time(n: int = N) -> list[str]:
    return [f"{t:.6f}.png" for t in TIMES[:n]]


def test_coco_results_of_a_category_with_the_image_list(tmp_path):
    """COCO results (image ids not in name order), frames ordered by file name and matched to TUM
    poses by the time in their names; another category's higher scores are not taken."""
    sc = scene(N)
    rows = [(k, 1, b, 0.7) for k, b in enumerate(sc.boxes) if k != 3]
    rows += [(k, 2, b, 0.95) for k, b in enumerate(sc.boxes)]  # another category on the same object
    results, images = write_coco(tmp_path, names_by_time(), rows)
    camera = Camera(write_tum(tmp_path / "tum.txt", TIMES + 0.004, sc.c2w))
    done = import_detections("coco", results, camera, tmp_path / "c.zarr", which=Which(category=1),
                             images=images, d1=0.5)
    assert done.missed == [names_by_time()[3]] and done.close == []
    (box, move, _, _), = stored(done.result.path).values()
    np.testing.assert_allclose(np.delete(box, 3, axis=0), np.delete(sc.boxes, 3, axis=0), atol=1e-12)
    np.testing.assert_allclose(move, sc.p[-1] - sc.p, atol=1e-9)
    with pytest.raises(InputError, match="detections of 2 categories"):
        import_detections("coco", results, camera, tmp_path / "x.zarr", images=images)


def test_yolo_labels_with_the_image_size_given_or_read_from_the_images(tmp_path):
    sc = scene(N)
    names = [f"frame{k:04d}.png" for k in range(N)]
    rows = [(k, 0, b, 0.8) for k, b in enumerate(sc.boxes) if k != 7]
    labels = write_yolo(tmp_path / "labels", names, rows)
    (tmp_path / "frames").mkdir()
    for n in names:
        cv2.imwrite(str(tmp_path / "frames" / n), np.zeros((H, W), np.uint8))
    camera = Camera(write_matrices(tmp_path / "c2w.txt", sc.c2w))
    read = import_detections("yolo", labels, camera, tmp_path / "a.zarr", which=Which(category=0),
                             images=tmp_path / "frames")
    assert read.missed == ["frame0007.png"]  # no .txt: nothing detected in that frame
    with pytest.raises(InputError, match="24 poses for 23 frames"):  # without the images, 23 .txt frames
        import_detections("yolo", labels, camera, tmp_path / "b.zarr", image_size=(H, W))
    (labels / "frame0007.txt").write_text("")
    given = import_detections("yolo", labels, camera, tmp_path / "b.zarr", image_size=(H, W))
    assert given.missed == ["frame0007.txt"]
    (box, _, _, _), = stored(read.result.path).values()
    (same, _, _, _), = stored(given.result.path).values()
    np.testing.assert_array_equal(box, same)
    np.testing.assert_allclose(np.delete(box, 7, axis=0), np.delete(sc.boxes, 7, axis=0), atol=1e-15)
    with pytest.raises(InputError, match="give the image size, or the images"):
        import_detections("yolo", labels, camera, tmp_path / "c.zarr")


def ellipse(box: np.ndarray) -> np.ndarray:
    m = np.zeros((H, W), np.uint8)
    cv2.ellipse(m, (int(box[0] * W), int(box[1] * H)), (int(box[2] * W / 2), int(box[3] * H / 2)), 0, 0, 360,
                1, -1)
    return m


def test_coco_rle_segmentations_import_as_masks(tmp_path):
    """Mask R-CNN's results: compressed RLE (and one uncompressed), encoded by pycocotools, into a
    store of masks, closest frame first; a missed frame is an empty mask."""
    from pycocotools import mask as rle

    sc = scene(N)
    truth = [ellipse(b) for b in sc.boxes]
    rows = []
    for k, (b, m) in enumerate(zip(sc.boxes, truth, strict=True)):
        if k == 5:
            continue
        seg = rle.encode(np.asfortranarray(m))
        seg = {"size": seg["size"], "counts": seg["counts"].decode()}
        if k == 9:  # uncompressed, as some tools write it
            flat, runs, value, n = m.ravel(order="F"), [], 0, 0
            for v in flat:
                if v != value:
                    runs.append(n)
                    value, n = v, 0
                n += 1
            seg = {"size": [H, W], "counts": [*runs, n]}
        rows.append((k, 1, b, 0.9, seg))
    results, images = write_coco(tmp_path, names_by_time(), rows)
    camera = Camera(write_matrices(tmp_path / "c2w.txt", sc.c2w))
    done = import_detections("coco", results, camera, tmp_path / "m.zarr", images=images, masks=True, d1=0.5)
    assert done.missed == [names_by_time()[5]] and done.result.attrs.kind == "masks"
    with open_store(done.result.path) as s:
        ex = s.example(s.example_ids[0])
        want = np.stack(truth[::-1]).astype(bool)  # closest first
        want[N - 1 - 5] = False
        np.testing.assert_array_equal(ex.masks, want)
        np.testing.assert_allclose(ex.depth, sc.p[::-1, 2], atol=1e-9)


BAD_RLE = {
    "runs past the image": ({"size": [H, W], "counts": [0, H * W + 5]}, "cover 307205 pixels"),
    "runs short of it": ({"size": [H, W], "counts": "1"}, "cover 1 pixels, the image has 307200"),
    "another size": ({"size": [10, 10], "counts": [100]}, "segmentation size [10, 10] is not the image's"),
    "a polygon": ([[1, 2, 3, 4, 5, 6]], "the segmentation is a polygon"),
    "a character outside RLE's": ({"size": [H, W], "counts": "~~"}, "holds '~', not a COCO RLE character"),
}


@pytest.mark.parametrize("case", BAD_RLE)
def test_a_bad_rle_is_refused_before_it_is_decoded(tmp_path, case):
    seg, says = BAD_RLE[case]
    sc = scene(4)
    rows = [(k, 1, b, 0.9, seg if k == 2 else {"size": [H, W], "counts": [H * W]})
            for k, b in enumerate(sc.boxes)]
    results, images = write_coco(tmp_path, names_by_time(4), rows)
    with pytest.raises(InputError) as e:
        import_detections("coco", results, Camera(write_matrices(tmp_path / "c.txt", sc.c2w)),
                          tmp_path / "m.zarr", images=images, masks=True)
    assert "results.json entry 2: " in str(e.value) and says in str(e.value), str(e.value)


def test_rle_masks_decode_as_pycocotools_decodes_them():
    """Our decoder against the COCO API's own, on masks of every fill and odd sizes: pycocotools
    encodes, both decode, and both give the mask back."""
    from pycocotools import mask as rle

    rng = np.random.default_rng(7)
    for t in range(200):
        h, w = (int(v) for v in rng.integers(1, 50, 2))
        m = (rng.random((h, w)) < [0.0, 1.0, rng.random()][t % 3]).astype(np.uint8)
        enc = rle.encode(np.asfortranarray(m))
        seg = {"size": [h, w], "counts": enc["counts"].decode()}
        ours = RleMask(checked_rle(seg, (h, w), "x"), h, w, "x").read(128)
        with warnings.catch_warnings():  # pycocotools on NumPy 2 warns inside decode
            warnings.simplefilter("ignore", DeprecationWarning)
            theirs = rle.decode(enc).astype(bool)
        np.testing.assert_array_equal(ours, theirs)
        np.testing.assert_array_equal(ours, m.astype(bool))


def test_masks_need_no_pycocotools_and_leave_the_users_warnings_alone(tmp_path):
    """--masks decodes without pycocotools installed, and decoding leaves the process's warning
    filters alone (another thread's warnings meet the filters in place at the time)."""
    from cli.test_extras import without
    from users_warnings import assert_warning_filters_untouched

    sc = scene(4)
    seg = {"size": [H, W], "counts": [H * W]}
    rows = [(k, 1, b, 0.9, seg) for k, b in enumerate(sc.boxes)]
    results, images = write_coco(tmp_path, names_by_time(4), rows)
    r = without("pycocotools", "import", "detections", str(results), "--images", str(images), "--masks",
                "--poses", str(write_matrices(tmp_path / "c.txt", sc.c2w)), "-o", str(tmp_path / "m.zarr"))
    assert r.returncode == 0, r.stderr
    mask = RleMask(checked_rle(seg, (H, W), "x"), H, W, "x")
    assert_warning_filters_untouched(lambda: mask.read(128))


def test_yolo_frames_named_by_time_meet_their_tum_poses(tmp_path):
    """Label files named by their time (1305031102.033333.txt): the whole name is the time."""
    sc = scene(N)
    rows = [(k, 0, b, 0.8) for k, b in enumerate(sc.boxes)]
    labels = write_yolo(tmp_path / "labels", names_by_time(), rows)
    camera = Camera(write_tum(tmp_path / "tum.txt", TIMES + 0.004, sc.c2w))
    done = import_detections("yolo", labels, camera, tmp_path / "y.zarr", image_size=(H, W))
    (box, move, _, _), = stored(done.result.path).values()
    np.testing.assert_allclose(box, sc.boxes, atol=1e-15)
    np.testing.assert_allclose(move, sc.p[-1] - sc.p, atol=1e-9)
