"""Render a small recording to try `odms-data import recording` and `odms-data estimate` on: a box
object seen by a pinhole camera that approaches it with a known translation and turns slightly.

    python examples/rendered_scene.py -o scene
    odms-data import recording scene/masks --poses scene/poses.txt --d1 0.3 --windows 10,15,20,25,30 \
        -o scene.zarr
    odms-data estimate scene.zarr --method vosde -o scene-depth --plot scene-depth.png
    odms-data import detections scene/boxes_mot.txt --track 1 --image-size 640x480 \
        --poses scene/trajectory.txt --fps 30 --d1 0.3 --windows 10,15,20,25,30 -o scene-boxes.zarr
    odms-data estimate scene-boxes.zarr --method box-ls -o scene-boxes-depth

Everything is made here, from numbers: no data from elsewhere. The world's +z is the first
frame's optical axis; the object, a box 12 x 9 x 6 cm, sits on it. Frame by frame the camera
moves `--step` metres along that axis towards the object and turns `--rotation` degrees about its
own vertical axis (a yaw), so a window of w frames turns (w - 1) x rotation degrees. Each frame's
mask is the box's silhouette: its eight corners projected (focal length 500 px, 640 x 480 pixels)
and their convex hull filled. The folder it writes:

- masks/<time>.png: the masks (0/255), named by their time in seconds, 30 frames a second;
- poses.txt: a camera-to-world 4x4 matrix a line, row by row, one per mask in name order;
- trajectory.txt: the same poses in TUM RGB-D's format, `timestamp tx ty tz qx qy qz qw`;
- the object's box in each frame (the projected corners' bounds, on a grid of 1/64 pixel so
  that every format carries the same numbers exactly), in the three formats `import detections`
  reads, with the corner in the image's pixel coordinates (x from 0 at the left) in each:
  - boxes_mot.txt: MOTChallenge, `frame,id,bb_left,bb_top,bb_width,bb_height,conf,x,y,z`
    (frames from 1, id 1);
  - boxes_coco.json and images_coco.json: COCO results (`image_id, category_id, bbox, score`,
    category 1) and the image list they need (each frame's `<time>.png`, 640 x 480);
  - boxes_yolo/<time>.txt: YOLO, `class cx cy w h`, normalised to the image (class 0);
- truth.csv: each mask's time and the depth of the box's front face along the first frame's
  optical axis, the depth `import recording --d1` labels (the closest frame's is `--closest`).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import cv2
import numpy as np

WIDTH, HEIGHT, FOCAL = 640, 480, 500.0  # pixels
HALF_SIZE = np.array([0.06, 0.045, 0.03])  # the box's half width, height and thickness, m
START_TIME, FPS = 1700000000.0, 30.0
SHIFT = 4  # sub-pixel bits of the filled polygon's corners
GRID = 64  # a box's corners are multiples of 1 / GRID pixel


def yaw(degrees: float) -> np.ndarray:
    """The rotation by `degrees` about the y axis."""
    a = np.radians(degrees)
    return np.array([[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]])


def scene(frames: int, step: float, rotation: float, closest: float) -> tuple[np.ndarray, np.ndarray, float]:
    """(frames, 4, 4) camera-to-world poses in time order, the box's eight corners (8, 3) in the
    world, and the front face's depth at the first frame."""
    first = closest + step * (frames - 1)
    centre = np.array([0.0, 0.0, first + HALF_SIZE[2]])
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], np.float64)
    poses = np.tile(np.eye(4), (frames, 1, 1))
    for i in range(frames):
        poses[i, :3, :3] = yaw(rotation * i)
        poses[i, :3, 3] = (0.0, 0.0, step * i)
    return poses, centre + signs * HALF_SIZE, first


def project(pose: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """(8, 2) pixel coordinates of the corners seen from the camera-to-world `pose`."""
    cam = (corners - pose[:3, 3]) @ pose[:3, :3]  # R^T (X - c), row by row
    return np.stack([FOCAL * cam[:, 0] / cam[:, 2] + (WIDTH - 1) / 2,
                     FOCAL * cam[:, 1] / cam[:, 2] + (HEIGHT - 1) / 2], axis=1)


def silhouette(points: np.ndarray) -> np.ndarray:
    """The mask (0/255) of the convex hull of `points`."""
    mask = np.zeros((HEIGHT, WIDTH), np.uint8)
    hull = cv2.convexHull(np.round(points * (1 << SHIFT)).astype(np.int32))
    cv2.fillConvexPoly(mask, hull, 255, lineType=cv2.LINE_8, shift=SHIFT)
    return mask


def quaternion(degrees: float) -> tuple[float, float, float, float]:
    """(qx, qy, qz, qw) of the yaw by `degrees`."""
    half = np.radians(degrees) / 2
    return 0.0, float(np.sin(half)), 0.0, float(np.cos(half))


def write(out: Path, frames: int, step: float, rotation: float, closest: float) -> None:
    poses, corners, first = scene(frames, step, rotation, closest)
    (out / "masks").mkdir(parents=True)
    times = START_TIME + np.arange(frames) / FPS
    (out / "boxes_yolo").mkdir()
    pose_lines, tum, mot, truth = [], ["# timestamp tx ty tz qx qy qz qw"], [], ["time,depth"]
    images, results = [], []
    for i, (t, pose) in enumerate(zip(times, poses, strict=True)):
        points = project(pose, corners)
        cv2.imwrite(str(out / "masks" / f"{t:.6f}.png"), silhouette(points))
        pose_lines.append(" ".join(f"{v:.17g}" for v in pose.ravel()))
        tum.append(f"{t:.6f} " + " ".join(f"{v:.17g}" for v in (*pose[:3, 3], *quaternion(rotation * i))))
        (x0, y0), (x1, y1) = (np.round(points.min(axis=0) * GRID) / GRID,
                              np.round(points.max(axis=0) * GRID) / GRID)
        x, y, w, h = float(x0), float(y0), float(x1 - x0), float(y1 - y0)  # exact on the grid
        mot.append(f"{i + 1},1,{x!r},{y!r},{w!r},{h!r},1,-1,-1,-1")
        images.append({"id": i + 1, "file_name": f"{t:.6f}.png", "width": WIDTH, "height": HEIGHT})
        results.append({"image_id": i + 1, "category_id": 1, "bbox": [x, y, w, h], "score": 1.0})
        yolo = ((x + w / 2) / WIDTH, (y + h / 2) / HEIGHT, w / WIDTH, h / HEIGHT)  # as pixel_box computes it
        (out / "boxes_yolo" / f"{t:.6f}.txt").write_text("0 " + " ".join(map(repr, yolo)) + "\n")
        truth.append(f"{t:.6f},{first - step * i:.17g}")
    for name, lines in (("poses.txt", pose_lines), ("trajectory.txt", tum), ("boxes_mot.txt", mot),
                        ("truth.csv", truth)):
        (out / name).write_text("\n".join(lines) + "\n")
    (out / "boxes_coco.json").write_text(json.dumps(results) + "\n")
    (out / "images_coco.json").write_text(json.dumps({"images": images}) + "\n")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog="example: python examples/rendered_scene.py -o scene --frames 40")
    p.add_argument("-o", "--out", required=True, type=Path, help="folder to write (must not exist)")
    p.add_argument("--frames", type=int, default=40, help="frames (default 40)")
    p.add_argument("--step", type=float, default=0.02, help="metres the camera moves a frame (default 0.02)")
    p.add_argument("--rotation", type=float, default=0.12,
                   help="degrees the camera turns a frame (default 0.12: windows of 30 frames turn 3.48)")
    p.add_argument("--closest", type=float, default=0.3,
                   help="depth of the box's front face at the last, closest frame, m (default 0.3)")
    a = p.parse_args()
    if a.out.exists():
        sys.exit(f"rendered_scene.py: error: {a.out} already exists; name a new folder")
    if a.frames < 2 or not a.step > 0 or not a.closest > 0.05:
        sys.exit("rendered_scene.py: error: give --frames >= 2, --step > 0 and --closest > 0.05")
    write(a.out, a.frames, a.step, a.rotation, a.closest)
    print(f"wrote {a.out}: {a.frames} masks, poses.txt, trajectory.txt, boxes_mot.txt, boxes_coco.json with "
          f"images_coco.json, boxes_yolo/, truth.csv; the front "
          f"face's depth at the closest frame is {a.closest:g} m (import recording ... --d1 {a.closest:g})")


if __name__ == "__main__":
    main()
