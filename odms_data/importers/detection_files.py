"""Detections as detectors and trackers write them, read into one table: MOTChallenge text
(`frame,id,x,y,w,h,conf,...`), COCO results JSON (`image_id, category_id, bbox, score`, with the
dataset's image list) and YOLO (one `.txt` per frame, `class cx cy w h [conf]`, normalised).

Every box becomes ODMD's [x_c, y_c, w, h] normalised by the image size: a pixel box (x, y, w, h)
with its top-left corner at (x, y) is [(x + w / 2) / W, (y + h / 2) / H, w / W, h / H]. Every
reader bounds what it reads before it allocates (file sizes, line lengths, fields, rows, JSON
size and nesting) and names the file and row of the first bad one. The formats and the choices
made where they are silent: docs/DETECTIONS.md.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..inputs import read_input
from ..protocol import MAX_RECORDING_FRAMES
from ..safe_json import loads
from .mask_files import MAX_PIXELS, image_size, is_mask_file
from .text_rows import number, text_rows

FORMATS = ("mot", "coco", "yolo")
MAX_FILE_BYTES = 1 << 30  # a MOT file or a COCO JSON larger than this is refused before it is read
MAX_LINE_CHARS = 1024  # a MOT row of 10 numbers in full precision takes under 300
MAX_ROWS = 10_000_000  # detections in one import
MAX_FRAMES = MAX_RECORDING_FRAMES
MAX_YOLO_BYTES = 1 << 20  # one frame's .txt
MOT_FIELDS = (6, 10)  # frame,id,x,y,w,h[,conf[,x,y,z]] (MOT16's ground truth: conf,class,visibility)
YOLO_FIELDS = (5, 6)  # class cx cy w h [conf]
MAX_RLE_CHARS = 1 << 26  # a compressed RLE string


@dataclass
class Detections:
    """Every detection read: per row its `frame` (index into `frames`, the frames in order),
    `label` (track id, or category), `box` (k, 4) ODMD's normalised [x_c, y_c, w, h], `score` and
    `rows` (where it was read, for messages); `segmentations` (COCO) each row's segmentation or
    None. `size` is the images' (height, width)."""

    frames: list[str]
    size: tuple[int, int]
    frame: np.ndarray
    label: np.ndarray
    box: np.ndarray
    score: np.ndarray
    rows: list[str]
    segmentations: list[dict[str, Any] | None] | None = None


def _bounded_size(path: Path, limit: int, what: str) -> None:
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    size = path.stat().st_size
    if size > limit:
        raise InputError(f"{path}: {size} bytes, more than {what} may have ({limit})")


def whole(text: str, where: str, what: str, low: int) -> int:
    """A whole number >= low (written as an integer or as a float with no fraction)."""
    value = number(text, f"{where}: {what}")
    if value != int(value) or value < low or abs(value) > 2**53:
        raise InputError(f"{where}: {what} '{text[:40]}' is not a whole number >= {low}")
    return int(value)


def _check_size(width: float, height: float, where: str) -> None:
    if width < 0 or height < 0:
        raise InputError(f"{where}: the box's width and height must be >= 0 (got {width:g}, {height:g})")


class _Table:
    """Rows as they are read, turned into a `Detections`."""

    def __init__(self) -> None:
        self.frame: list[int] = []
        self.label: list[int] = []
        self.box: list[tuple[float, float, float, float]] = []
        self.score: list[float] = []
        self.rows: list[str] = []

    def add(self, frame: int, label: int, box: tuple[float, float, float, float], score: float,
            where: str) -> None:
        if len(self.rows) >= MAX_ROWS:
            raise InputError(f"{where}: more than {MAX_ROWS} detections")
        self.frame.append(frame)
        self.label.append(label)
        self.box.append(box)
        self.score.append(score)
        self.rows.append(where)

    def done(self, frames: list[str], size: tuple[int, int], **more: Any) -> Detections:
        box = np.array(self.box, np.float64).reshape(-1, 4)
        return Detections(frames, size, np.array(self.frame, np.int64), np.array(self.label, np.int64), box,
                          np.array(self.score, np.float64), self.rows, **more)


def pixel_box(x: float, y: float, w: float, h: float, size: tuple[int, int]
              ) -> tuple[float, float, float, float]:
    """ODMD's normalised [x_c, y_c, w, h] of a pixel box with its top-left corner at (x, y)."""
    H, W = size
    return (x + w / 2) / W, (y + h / 2) / H, w / W, h / H


def checked_size(size: tuple[int, int], where: str) -> tuple[int, int]:
    H, W = size
    if not (0 < H and 0 < W and H * W <= MAX_PIXELS):
        raise InputError(f"{where}: image size {W}x{H} is not a size of at most {MAX_PIXELS} pixels")
    return H, W


# --- MOTChallenge -----------------------------------------------------------------------------


def read_mot(path: Path, size: tuple[int, int], n_frames: int | None) -> Detections:
    """A MOTChallenge file (`frame,id,x,y,w,h[,conf,...]`, frames from 1, boxes in pixels). Its
    frames are 1..n_frames, else 1..the largest frame it names."""
    _bounded_size(path, MAX_FILE_BYTES, "a MOTChallenge file")
    table = _Table()
    last = 0
    for i, line in text_rows(path, MAX_LINE_CHARS, 2 * MAX_ROWS):
        where, fields = f"{path} line {i}", line.split(",")
        if not MOT_FIELDS[0] <= len(fields) <= MOT_FIELDS[1]:
            raise InputError(f"{where}: {len(fields)} fields; a MOTChallenge row has 6 to 10 "
                             "(frame,id,x,y,w,h,conf,...)")
        frame = whole(fields[0], where, "frame", 1)
        if n_frames is not None and frame > n_frames:
            raise InputError(f"{where}: frame {frame}, but there are {n_frames} poses (one per frame)")
        track = whole(fields[1], where, "id", -1)
        x, y, w, h = (number(t, f"{where}: {c}")
                      for t, c in zip(fields[2:6], ("x", "y", "w", "h"), strict=True))
        _check_size(w, h, where)
        score = number(fields[6], f"{where}: conf") if len(fields) > 6 else 1.0
        table.add(frame - 1, track, pixel_box(x, y, w, h, size), score, where)
        last = max(last, frame)
    n = n_frames if n_frames is not None else last
    if n == 0:
        raise InputError(f"{path}: holds no detections")
    if n > MAX_FRAMES:
        raise InputError(f"{path}: {n} frames, more than {MAX_FRAMES}")
    return table.done([str(f) for f in range(1, n + 1)], size)


# --- COCO results -------------------------------------------------------------------------


def _json_file(path: Path, what: str) -> Any:
    _bounded_size(path, MAX_FILE_BYTES, what)
    return loads(read_input(path, what, MAX_FILE_BYTES), str(path), max_bytes=MAX_FILE_BYTES)


def _field(entry: Any, key: str, where: str) -> Any:
    if not isinstance(entry, dict) or key not in entry:
        raise InputError(f"{where}: no '{key}'")
    return entry[key]


def _integer(value: Any, where: str, what: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise InputError(f"{where}: {what} {str(value)[:40]} is not an integer")
    return value


def _image_list(path: Path) -> tuple[dict[int, int], list[str], tuple[int, int]]:
    """The dataset's images (`{"images": [{id, file_name, width, height}, ...]}`), ordered by file
    name: id -> frame, the frames' names and their one image size."""
    data = _json_file(path, "a COCO dataset file")
    images = data.get("images") if isinstance(data, dict) else None
    if not isinstance(images, list) or not images:
        raise InputError(f"{path}: no 'images' list (the dataset's image list: id, file_name, width, height)")
    if len(images) > MAX_FRAMES:
        raise InputError(f"{path}: {len(images)} images, more than {MAX_FRAMES}")
    seen: dict[int, str] = {}
    sizes: dict[tuple[int, int], str] = {}
    for k, entry in enumerate(images):
        where = f"{path} images[{k}]"
        image_id = _integer(_field(entry, "id", where), where, "id")
        name = _field(entry, "file_name", where)
        if not isinstance(name, str) or not name or len(name) > 4096:
            raise InputError(f"{where}: file_name is not a name")
        if image_id in seen:
            raise InputError(f"{where}: image id {image_id} is listed twice")
        seen[image_id] = name
        dim = (_integer(_field(entry, "height", where), where, "height"),
               _integer(_field(entry, "width", where), where, "width"))
        sizes.setdefault(checked_size(dim, where), where)
        if len(sizes) > 1:
            first = next(iter(sizes))
            raise InputError(f"{where}: its size {dim} differs from {first} ({sizes[first]}); one "
                             "recording's images have one size")
    order = sorted(seen, key=lambda i: seen[i])
    return {i: f for f, i in enumerate(order)}, [seen[i] for i in order], next(iter(sizes))


def read_coco(path: Path, image_list: Path) -> Detections:
    """COCO results (a list of {image_id, category_id, bbox [x, y, w, h] in pixels, score[,
    segmentation]}) over the images of the dataset file `image_list`."""
    frame_of, names, size = _image_list(image_list)
    results = _json_file(path, "a COCO results file")
    if not isinstance(results, list):
        raise InputError(f"{path}: not a list of detections (COCO results: "
                         "[{image_id, category_id, bbox, score}, ...])")
    table, segmentations = _Table(), list[dict[str, Any] | None]()
    for k, entry in enumerate(results):
        where = f"{path} entry {k}"
        image = _integer(_field(entry, "image_id", where), where, "image_id")
        if image not in frame_of:
            raise InputError(f"{where}: image_id {image} is not in {image_list}'s images")
        category = _integer(_field(entry, "category_id", where), where, "category_id")
        bbox = _field(entry, "bbox", where)
        if (not isinstance(bbox, list) or len(bbox) != 4
                or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in bbox)):
            raise InputError(f"{where}: bbox is not 4 numbers [x, y, width, height]")
        _check_size(bbox[2], bbox[3], where)
        score = _field(entry, "score", where)
        if isinstance(score, bool) or not isinstance(score, int | float):
            raise InputError(f"{where}: score {str(score)[:40]} is not a number")
        x, y, w, h = (float(v) for v in bbox)
        table.add(frame_of[image], category, pixel_box(x, y, w, h, size), float(score), where)
        segmentations.append(entry.get("segmentation"))
    return table.done(names, size, segmentations=segmentations)


# --- YOLO ---------------------------------------------------------------------------------


def _yolo_frames(label_dir: Path, images: Path | None) -> tuple[list[str], list[Path | None]]:
    """The frames (file names, in name order) and each one's .txt (None: no detections): the images
    of `images`, else the .txt files of `label_dir`."""
    if not label_dir.is_dir():
        raise InputError(f"{label_dir}: no such folder (YOLO: a folder of one .txt per frame)")
    texts = {p.stem: p for p in label_dir.iterdir() if p.suffix == ".txt" and not p.name.startswith(".")}
    if images is None:
        names = sorted(p.name for p in texts.values())
    else:
        if not images.is_dir():
            raise InputError(f"{images}: no such folder")
        names = sorted(p.name for p in images.iterdir() if is_mask_file(p))
        stray = sorted(set(texts) - {Path(n).stem for n in names})
        if stray:
            raise InputError(f"{texts[stray[0]]}: no image of that name in {images}")
    if not names:
        raise InputError(f"{images or label_dir}: holds no frames")
    if len(names) > MAX_FRAMES:
        raise InputError(f"{label_dir}: {len(names)} frames, more than {MAX_FRAMES}")
    return names, [texts.get(Path(n).stem) for n in names]


def _yolo_size(images: Path, names: list[str]) -> tuple[int, int]:
    """The images' one size, read from their headers."""
    files = {p.name: p for p in images.iterdir() if is_mask_file(p)}
    first = files[names[0]]
    size = checked_size(image_size(first), str(first))
    for n in names[1:]:
        other = image_size(files[n])
        if other != size:
            raise InputError(f"{files[n]}: {other[1]}x{other[0]} pixels, but {first} has "
                             f"{size[1]}x{size[0]}; one recording's images have one size")
    return size


def read_yolo(label_dir: Path, size: tuple[int, int] | None, images: Path | None) -> Detections:
    """YOLO labels: one .txt per frame, `class cx cy w h [conf]` normalised to the image. The image
    size is `size`, else read from the headers of the images in `images`."""
    names, files = _yolo_frames(label_dir, images)
    if size is None:
        if images is None:
            raise InputError("YOLO boxes are normalised: give the image size, or the images to read it from")
        size = _yolo_size(images, names)
    table = _Table()
    for f, path in enumerate(files):
        if path is None:
            continue
        _bounded_size(path, MAX_YOLO_BYTES, "a YOLO label file")
        for i, line in text_rows(path, MAX_LINE_CHARS, MAX_ROWS):
            where, fields = f"{path} line {i}", line.split()
            if len(fields) not in YOLO_FIELDS:
                raise InputError(f"{where}: {len(fields)} fields; a YOLO row has 5 or 6 "
                                 "(class cx cy w h [conf])")
            category = whole(fields[0], where, "class", 0)
            cx, cy, w, h = (number(t, f"{where}: {c}")
                            for t, c in zip(fields[1:5], ("cx", "cy", "w", "h"), strict=True))
            _check_size(w, h, where)
            score = number(fields[5], f"{where}: conf") if len(fields) > 5 else 1.0
            table.add(f, category, (cx, cy, w, h), score, where)
    return table.done(names, size)
