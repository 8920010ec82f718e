"""The release round trip: the official robot-test set's boxes (ODMD's box rule on its masks) written
out as MOTChallenge, COCO and YOLO files, its camera positions as a TUM trajectory and as 4x4
matrices, and imported again with the robot protocol's windows: every example comes back with the
same boxes and movements, bit for bit, and Box_LS predicts the same as on the official store.
The tracks are taken by id (MOTChallenge), the per-frame detections with --min-iou 0."""

from __future__ import annotations

import numpy as np
import pytest
from detection_formats import write_coco, write_matrices, write_mot, write_tum, write_yolo

from odms_data.evaluation.box_ls import box_ls
from odms_data.importers.detections import Camera, Which, import_detections
from odms_data.protocol import ROBOT_N_OBS, ROBOT_WINDOWS
from odms_data.store.box_rule import example_boxes, frame_boxes
from odms_data.store.reader import open_store

T0, FPS = 1000.0, 10.0
# One detection a frame, taken whatever it overlaps: the box rule's box jumps where a robot mask's
# largest region is clutter (dice_0's far frames), which the association would call another object.
ONE_A_FRAME = Which(category=None, min_iou=0.0)


def _approaches(store) -> dict[str, np.ndarray]:
    """Each robot approach's frame rows, farthest first (the order a robot records them in)."""
    rows: dict[str, set[int]] = {}
    for e, i in enumerate(store.example_ids):
        rows.setdefault(i.split("/")[1], set()).update(store.frames_of(e).tolist())
    return {name: np.array(sorted(r, key=lambda f: -store.z[f])) for name, r in rows.items()}


def _write(root, boxes: np.ndarray, z: np.ndarray, size: tuple[int, int]) -> dict[str, tuple]:
    """The approach in every format: name -> (format, file, Camera, options)."""
    names = [f"{T0 + k / FPS:.6f}.png" for k in range(len(z))]
    c2w = np.tile(np.eye(4), (len(z), 1, 1))
    c2w[:, 2, 3] = -z  # the camera on the object's optical axis, z from it
    present = [k for k in range(len(z)) if boxes[k].any()]  # an empty mask: no detection written
    tum = Camera(write_tum(root / "tum.txt", T0 + np.arange(len(z)) / FPS, c2w))
    matrices = Camera(write_matrices(root / "c2w.txt", c2w))
    mot = write_mot(root / "gt.txt", [(k + 1, 1, boxes[k], 1.0) for k in present], size)
    results, images = write_coco(root, names, [(k, 1, boxes[k], 0.9) for k in present], size)
    yolo = write_yolo(root / "labels", names, [(k, 0, boxes[k], 0.9) for k in present], every_frame=True)
    return {
        "mot-tum": ("mot", mot, Camera(tum.poses, fps=FPS, start_time=T0), {"which": Which(track=1),
                                                                          "image_size": size}),
        "mot-4x4": ("mot", mot, matrices, {"which": Which(track=1), "image_size": size}),
        "coco-tum": ("coco", results, tum, {"images": images, "which": ONE_A_FRAME}),
        "coco-4x4": ("coco", results, matrices, {"images": images, "which": ONE_A_FRAME}),
        "yolo-tum": ("yolo", yolo, tum, {"image_size": size, "which": ONE_A_FRAME}),
        "yolo-4x4": ("yolo", yolo, matrices, {"image_size": size, "which": ONE_A_FRAME}),
    }


def _pixel_exact(boxes: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """The boxes as the writers' pixel boxes give them back: ODMD's boxes come from whole pixels, so
    rounding their pixel corners and sizes to whole numbers writes them exactly."""
    H, W = size
    px = np.rint(np.stack([boxes[:, 0] * W - boxes[:, 2] * W / 2, boxes[:, 1] * H - boxes[:, 3] * H / 2,
                           boxes[:, 2] * W, boxes[:, 3] * H], axis=1))
    out = np.stack([(px[:, 0] + px[:, 2] / 2) / W, (px[:, 1] + px[:, 3] / 2) / H, px[:, 2] / W, px[:, 3] / H],
                   axis=1)
    np.testing.assert_array_equal(out[boxes[:, 2] > 0], boxes[boxes[:, 2] > 0])
    return out


def test_the_official_robot_test_set_comes_back_in_every_format(official_stores, tmp_path):
    with open_store(official_stores["robot-test"]) as official:
        size = (official.height, official.width)
        want_ls = dict(zip(official.example_ids, box_ls(official).d1, strict=True))
        want = example_boxes(official, np.arange(official.n_examples), ROBOT_N_OBS)
        index = {i: e for e, i in enumerate(official.example_ids)}
        approaches = _approaches(official)
        boxes = {n: frame_boxes(official, f) for n, f in approaches.items()}
        z = {n: official.z[f] for n, f in approaches.items()}
    assert len(approaches) == 48
    compared = 0
    for name in approaches:
        _pixel_exact(boxes[name], size)
        root = tmp_path / name
        root.mkdir()
        for label, (fmt, path, camera, options) in _write(root, boxes[name], z[name], size).items():
            done = import_detections(fmt, path, camera, root / f"{label}.zarr", windows=list(ROBOT_WINDOWS),
                                     n_obs=ROBOT_N_OBS, d1=float(z[name].min()), name=name, **options)
            with open_store(done.result.path) as got:
                assert got.n_examples == 55, (name, label)
                ls = box_ls(got).d1
                for e, i in enumerate(got.example_ids):
                    o = index[f"robot-test/{i}"]
                    f = got.frames_of(e)
                    np.testing.assert_array_equal(got.box[f], want.boxes[o], err_msg=f"{label} {i}")
                    np.testing.assert_array_equal(got.move[f], want.move[o], err_msg=f"{label} {i}")
                    assert got.d1[e] == pytest.approx(want.depth[o], abs=1e-12), (label, i)
                    assert ls[e] == want_ls[f"robot-test/{i}"], (label, i)  # bit for bit
                    compared += 1
    assert compared == 6 * 2640
