"""Detections and poses written as detectors, trackers and SLAM systems write them (MOTChallenge,
COCO results with the dataset's image list, YOLO; 4x4 matrices, TUM), and a scene to write: a box
seen through a pinhole camera that approaches it. The writers invert the importer's reading
(detection_files.pixel_box): a box [x_c, y_c, w, h] normalised is the pixel box with top-left
corner ((x_c - w / 2) W, (y_c - h / 2) H) and size (w W, h H)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

H, W = 480, 640
FX = FY = 500.0
CX, CY = 320.0, 240.0
SIZE = (0.10, 0.15)  # the object's width and height, m


@dataclass
class Scene:
    """F frames: camera-to-world poses, the object's position in the camera's axes (ODMD's p) and
    its normalised box in each frame."""

    c2w: np.ndarray
    p: np.ndarray
    boxes: np.ndarray


def scene(n: int, seed: int = 0, turn_deg: np.ndarray | None = None) -> Scene:
    """A camera in an arbitrary orientation approaching a box at the world's origin from 1.2 m to
    0.5 m, moving sideways a little; with `turn_deg`, turned that much about its y axis (the box
    is then projected as the turned camera sees it)."""
    rng = np.random.default_rng(seed)
    R0 = Rotation.from_euler("xyz", [20, -35, 50], degrees=True).as_matrix()
    depth = np.linspace(1.2, 0.5, n)
    p = np.stack([0.004 * rng.standard_normal(n), 0.004 * rng.standard_normal(n), depth], axis=1)
    c2w = np.tile(np.eye(4), (n, 1, 1))
    for k in range(n):
        c2w[k, :3, :3] = R0
        c2w[k, :3, 3] = -R0 @ p[k]  # the object, at the origin, is at p in the camera's axes
        if turn_deg is not None:
            c2w[k, :3, :3] = R0 @ Rotation.from_euler("y", turn_deg[k], degrees=True).as_matrix()
    p_seen = np.einsum("kji,kj->ki", c2w[:, :3, :3], -c2w[:, :3, 3])
    z = p_seen[:, 2]
    boxes = np.stack([(p_seen[:, 0] * FX / z + CX) / W, (p_seen[:, 1] * FY / z + CY) / H,
                      SIZE[0] * FX / z / W, SIZE[1] * FY / z / H], axis=1)
    return Scene(c2w, p_seen, boxes)


def pixels(box: np.ndarray, size: tuple[int, int] = (H, W)) -> np.ndarray:
    """(k, 4) pixel boxes x, y, w, h of normalised ones in images of `size` (height, width), to
    nine decimals, as a tool writes them (whole pixels stay whole)."""
    box = np.asarray(box, np.float64).reshape(-1, 4)
    h, w = size
    return np.round(np.stack([(box[:, 0] - box[:, 2] / 2) * w, (box[:, 1] - box[:, 3] / 2) * h,
                              box[:, 2] * w, box[:, 3] * h], axis=1), 9)


def write_mot(path: Path, rows: list[tuple[int, int, np.ndarray, float]], size: tuple[int, int] = (H, W)
              ) -> Path:
    """MOTChallenge rows (frame from 1, id, normalised box, conf)."""
    text = "".join(f"{f},{i}," + ",".join(repr(float(v)) for v in pixels(b, size)[0]) + f",{s!r},-1,-1,-1\n"
                   for f, i, b, s in rows)
    path.write_text(text)
    return path


def write_coco(root: Path, names: list[str], rows: list[tuple], size: tuple[int, int] = (H, W)
               ) -> tuple[Path, Path]:
    """COCO results (frame index, category, normalised box, score[, segmentation]) and the dataset's
    image list, image ids not in name order."""
    ids = [1000 - 3 * k for k in range(len(names))]
    images = {"images": [{"id": i, "file_name": n, "width": size[1], "height": size[0]}
                         for i, n in reversed(list(zip(ids, names, strict=True)))],
              "categories": [{"id": 1, "name": "cup"}]}
    results = []
    for f, c, b, s, *seg in rows:
        box = [float(v) for v in pixels(b, size)[0]]
        entry = {"image_id": ids[f], "category_id": c, "bbox": box, "score": s}
        if seg:
            entry["segmentation"] = seg[0]
        results.append(entry)
    (root / "instances.json").write_text(json.dumps(images))
    (root / "results.json").write_text(json.dumps(results))
    return root / "results.json", root / "instances.json"


def write_yolo(folder: Path, names: list[str], rows: list[tuple[int, int, np.ndarray, float]],
               every_frame: bool = False) -> Path:
    """One .txt per frame that has a row (frame index, class, normalised box, conf); with
    `every_frame`, an empty one for each other frame."""
    folder.mkdir()
    lines: dict[int, list[str]] = {f: [] for f in range(len(names))} if every_frame else {}
    for f, c, b, s in rows:
        lines.setdefault(f, []).append(f"{c} " + " ".join(repr(float(v)) for v in b) + f" {s!r}\n")
    for f, text in lines.items():
        (folder / f"{Path(names[f]).stem}.txt").write_text("".join(text))
    return folder


def write_matrices(path: Path, c2w: np.ndarray) -> Path:
    path.write_text("".join(" ".join(repr(float(v)) for v in M.ravel()) + "\n" for M in c2w))
    return path


def write_tum(path: Path, times: np.ndarray, c2w: np.ndarray) -> Path:
    quats = Rotation.from_matrix(c2w[:, :3, :3]).as_quat()
    path.write_text("# timestamp tx ty tz qx qy qz qw\n" + "".join(
        f"{t:.6f} " + " ".join(repr(float(v)) for v in (*M[:3, 3], *q)) + "\n"
        for t, M, q in zip(times, c2w, quats, strict=True)))
    return path
