"""`odms-data import detections`: a detector's or tracker's boxes (detection_files.py) and the
camera's poses (poses.py) -> a store of boxes, or, from COCO RLE segmentations, a store of masks.

Which object: a track, or a category's detections by the association rule (association.py). A
frame without the object's box is a missed detection: box [0, 0, 0, 0], as ODMD stores one (zero
width) and Box_LS fills it.

Examples are chosen as recordings choose them (recording.windowed_examples: frames ordered by the
camera's position along the first frame's optical axis, closest first; one example or the robot
protocol's windows; windows turning past `max_rotation` refused and listed). A store of boxes
holds each example in ODMD's order, far to near, the label at the last (closest) frame, and the
movement as ODMD defines it (griffbr/ODMD, data_gen.py: `camera_movement = p[-1] - p`, p the
object's position in the camera's axes): frame k's is R_last^T (c_k - c_last), c the camera's
centre and R_last its orientation at the example's last frame; negative along z as the camera
approaches. docs/DETECTIONS.md.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..store.box_store import BoxRows
from ..store.format import store_path
from .association import DEFAULT_MIN_IOU, Choice, associate, choose_track
from .builder import Importer, Progress
from .detection_files import MAX_RLE_CHARS, Detections, checked_size, read_coco, read_mot, read_yolo
from .plan import DEFAULT_THRESHOLD, BoxPlan, MaskPlan, store_name
from .poses import (
    DEFAULT_MAX_ROTATION,
    DEFAULT_TIME_TOLERANCE,
    DIRECTIONS,
    PoseTable,
    axis_positions,
    camera_to_world,
    match_times,
    name_times,
    read_poses,
)
from .recording import FRAMES_PER_CHUNK, FRAMES_PER_SHARD, windowed_examples
from .result import ImportResult

# --- RLE masks -------------------------------------------------------------------------------


def _rle_runs(counts: str, where: str) -> Iterator[int]:
    """The runs of a compressed COCO RLE string, one at a time (its alphabet, its 5-bit groups and
    the delta of each run from the one two before it, as COCO's maskApi writes them): checking a
    string of many runs holds none of them."""
    before: list[int] = [0, 0]  # the last two runs
    n, value, shift = 0, 0, 0
    for ch in counts:
        c = ord(ch) - 48
        if not 0 <= c < 64:
            raise InputError(f"{where}: segmentation counts holds '{ch}', not a COCO RLE character")
        value |= (c & 0x1F) << shift
        shift += 5
        if c & 0x20:
            continue
        if c & 0x10:
            value -= 1 << shift
        if n > 2:
            value += before[n % 2]
        if value < 0:
            raise InputError(f"{where}: segmentation counts has a negative run")
        yield value
        before[n % 2] = value
        n, value, shift = n + 1, 0, 0
    if shift:
        raise InputError(f"{where}: segmentation counts ends inside a run")


def checked_rle(seg: Any, size: tuple[int, int], where: str) -> dict[str, Any]:
    """A COCO RLE segmentation {size: [h, w], counts: str or list} of an image of `size`, its runs
    covering the image exactly."""
    if isinstance(seg, list):
        raise InputError(f"{where}: the segmentation is a polygon; masks are read from RLE segmentations")
    if not isinstance(seg, dict) or not isinstance(seg.get("counts"), str | list):
        raise InputError(f"{where}: no RLE segmentation {{size, counts}}")
    if seg.get("size") != list(size):
        raise InputError(f"{where}: segmentation size {str(seg.get('size'))[:40]} is not the image's "
                         f"[{size[0]}, {size[1]}]")
    counts = seg["counts"]
    if isinstance(counts, str):
        if len(counts) > MAX_RLE_CHARS:
            raise InputError(f"{where}: segmentation counts longer than {MAX_RLE_CHARS} characters")
        total = sum(_rle_runs(counts, where))
    else:
        if len(counts) > size[0] * size[1] + 1 or not all(
                isinstance(v, int) and not isinstance(v, bool) and v >= 0 for v in counts):
            raise InputError(f"{where}: segmentation counts are not runs of pixels")
        total = sum(counts)
    if total != size[0] * size[1]:
        raise InputError(f"{where}: segmentation runs cover {total} pixels, the image has "
                         f"{size[0] * size[1]}")
    return {"size": list(size), "counts": counts}


@dataclass(frozen=True)
class RleMask:
    """One frame's mask as a COCO RLE (None: a missed detection, an empty mask), as a `MaskSource`."""

    rle: dict[str, Any] | None
    height: int
    width: int
    where: str

    @property
    def name(self) -> str:
        return self.where

    def __str__(self) -> str:
        return self.where

    def size(self) -> tuple[int, int]:
        return self.height, self.width

    def read(self, threshold: int, expect: tuple[int, int] | None = None) -> np.ndarray:
        if expect is not None and expect != self.size():
            raise InputError(f"{self.where}: {self.width}x{self.height}, not {expect[1]}x{expect[0]} as the "
                             "other frames")
        if self.rle is None:
            return np.zeros(self.size(), bool)
        counts = self.rle["counts"]
        # checked to cover the image (checked_rle): each run fits int32, and there are no more runs
        # than characters (MAX_RLE_CHARS)
        runs = np.fromiter(_rle_runs(counts, self.where), np.int32) if isinstance(counts, str) else counts
        values = np.arange(len(runs)) % 2 == 1  # runs alternate, background first, column by column
        return np.ascontiguousarray(np.repeat(values, runs).reshape(self.width, self.height).T)


# --- poses and the plan --------------------------------------------------------------------


def frame_matrices(table: PoseTable, names: list[str], fps: float | None, start: float | None,
                   tolerance: float) -> np.ndarray:
    """Each frame's pose matrix: one pose per frame in order, or (TUM) the pose nearest each frame's
    time, from the frame rate (frame k at start + k / fps) or the frames' names."""
    if table.times is None:
        if len(table.matrices) != len(names):
            raise InputError(f"{table.path}: {len(table.matrices)} poses for {len(names)} frames "
                             "(one pose per frame, in the frames' order)")
        return table.matrices
    if fps is not None:
        first = table.times[0] if start is None else start
        times = first + np.arange(len(names)) / fps
    else:
        times = name_times(names)
    return table.matrices[match_times(table, times, [f"frame {n}" for n in names], tolerance)]


@dataclass
class Recording:
    """The camera's frames, ordered closest first, and the examples chosen over them."""

    order: np.ndarray  # frame numbers (detection order) closest first
    c2w: np.ndarray  # (F, 4, 4) in detection order
    z: np.ndarray  # (F,) in detection order
    depth: np.ndarray  # (F,) in detection order, NaN where unknown
    ids: list[str]
    frame_index: np.ndarray  # (E, k) rows of `order`, closest first
    oddities: list = field(default_factory=list)


def _recording(name: str, where: Path, c2w: np.ndarray, windows: list[int] | None, n_obs: int,
               max_rotation: float, d1: float | None) -> Recording:
    if len(c2w) < 2:
        raise InputError(f"{where}: {len(c2w)} frame(s), at least 2 are needed")
    z = axis_positions(c2w)
    order = np.argsort(z, kind="stable")
    ids, frame_index, turned = windowed_examples(name, where, len(z), windows, n_obs, c2w[order],
                                                 max_rotation)
    with np.errstate(over="ignore"):
        depth = d1 + (z - z[order[0]]) if d1 is not None else np.full(len(z), math.nan)
    return Recording(order, c2w, z, depth, ids, frame_index, turned)


def box_plan(rec: Recording, choice: Choice, name: str, source: str, size: tuple[int, int]) -> BoxPlan:
    """Each example far to near, with ODMD's movement to its last frame (module doc)."""
    f = rec.order[rec.frame_index][:, ::-1]
    centre, R = rec.c2w[:, :3, 3], rec.c2w[:, :3, :3]
    move = np.einsum("eji,ekj->eki", R[f[:, -1]], centre[f] - centre[f[:, -1:]])
    depth = rec.depth[f]
    rows = BoxRows(boxes=choice.boxes[f], move=move, depth=depth, d1=depth[:, -1].copy(), ids=rec.ids,
                   sources=[source] * len(rec.ids))
    return BoxPlan(split=name, domain="recording", source=f"detections {source}", rows=rows, image_size=size,
                   oddities=list(rec.oddities))


def mask_plan(rec: Recording, dets: Detections, choice: Choice, name: str, source: str,
              threshold: int = DEFAULT_THRESHOLD) -> MaskPlan:
    """The chosen detections' RLE segmentations as masks, frames closest first."""
    H, W = dets.size
    masks = []
    for f in rec.order:
        r = int(choice.rows[f])
        if r < 0:
            masks.append(RleMask(None, H, W, f"frame {dets.frames[f]} (missed)"))
            continue
        seg = dets.segmentations[r] if dets.segmentations is not None else None
        masks.append(RleMask(checked_rle(seg, dets.size, dets.rows[r]), H, W, dets.rows[r]))
    z, depth = rec.z[rec.order], rec.depth[rec.order]
    return MaskPlan(split=name, domain="recording", source=f"detections {source}", masks=masks, z=z - z[0],
                    depth=depth, frame_index=rec.frame_index, d1=depth[rec.frame_index[:, 0]], ids=rec.ids,
                    sources=[source] * len(rec.ids), frames_per_chunk=FRAMES_PER_CHUNK,
                    frames_per_shard=FRAMES_PER_SHARD, oddities=list(rec.oddities), threshold=threshold)


@dataclass
class DetectionsImporter(Importer):
    """A planned store of the chosen object's boxes or masks."""

    planned: BoxPlan | MaskPlan

    def plan(self) -> BoxPlan | MaskPlan:
        return self.planned


@dataclass(frozen=True)
class DetectionsResult:
    """What `import_detections` wrote, the frames where the object was missed and the close choices."""

    result: ImportResult
    frames: int
    missed: list[str]
    close: list[str]


@dataclass(frozen=True)
class Which:
    """Which object: a track of a track format, or the association rule over a category."""

    track: int | None = None
    category: int | None = None
    min_iou: float = DEFAULT_MIN_IOU


@dataclass(frozen=True)
class Camera:
    """The camera's poses: the file, its direction and, for TUM, how frames get their times."""

    poses: Path
    direction: str = "camera-to-world"
    fps: float | None = None
    start_time: float | None = None
    time_tolerance: float = DEFAULT_TIME_TOLERANCE
    max_rotation: float = DEFAULT_MAX_ROTATION


def read_detections(fmt: str, path: Path, images: Path | None, size: tuple[int, int] | None,
                    table: PoseTable, fps: float | None) -> Detections:
    """The file's detections, in the format `fmt`."""
    if fmt == "mot":
        if size is None:
            raise InputError("MOTChallenge boxes are in pixels: give the image size (WIDTHxHEIGHT)")
        if table.times is not None and fps is None:
            raise InputError("MOTChallenge frames are numbers: give the frame rate to match them to "
                             "TUM poses")
        return read_mot(path, size, None if table.times is not None else len(table.matrices))
    if fmt == "coco":
        if images is None:
            raise InputError("COCO results name images by id: give the dataset's JSON with its image list")
        return read_coco(path, images)
    if fmt == "yolo":
        return read_yolo(path, size, images)
    raise InputError(f"format '{fmt}': expected mot, coco or yolo")


def _check_which(which: Which, fmt: str, masks: bool) -> None:
    if not 0 <= which.min_iou <= 1:
        raise InputError(f"min_iou {which.min_iou}: expected 0 to 1")
    if which.track is not None and which.category is not None:
        raise InputError("give a track (track formats) or a category (per-frame detections), not both")
    if which.track is not None and fmt != "mot":
        raise InputError(f"{fmt} detections have no tracks: choose the object by its category")
    if which.category is not None and fmt == "mot":
        raise InputError("MOTChallenge rows have no category: choose the object by its track")
    if masks and fmt != "coco":
        raise InputError("masks come from COCO results' RLE segmentations")


def _check(camera: Camera, which: Which, fmt: str, masks: bool, n_obs: int, windows: list[int] | None,
           d1: float | None) -> None:
    if camera.direction not in DIRECTIONS:
        raise InputError(f"pose '{camera.direction}': expected {' or '.join(DIRECTIONS)}")
    if camera.fps is not None and not (math.isfinite(camera.fps) and camera.fps > 0):
        raise InputError(f"fps {camera.fps}: expected frames per second > 0")
    if not 0 <= camera.max_rotation <= 180:
        raise InputError(f"max_rotation {camera.max_rotation}: expected degrees from 0 to 180")
    _check_which(which, fmt, masks)
    if n_obs < 2 or (windows is not None and (not windows or min(windows) < 2)):
        raise InputError("windows must be lengths of at least 2 frames, with n_obs at least 2")
    if d1 is not None and not (math.isfinite(d1) and d1 > 0):
        raise InputError(f"d1 {d1} is not a positive distance")


def import_detections(
    fmt: str, path: str | Path, camera: Camera, out: str | Path | None = None, *, which: Which = Which(),
    images: str | Path | None = None, image_size: tuple[int, int] | None = None, masks: bool = False,
    windows: list[int] | None = None, n_obs: int = 10, d1: float | None = None, name: str | None = None,
    store_format: str | None = None, overwrite: bool = False, progress: Progress | None = None,
) -> DetectionsResult:
    """Import the detections at `path` (format `fmt`: mot, coco or yolo) with the camera's poses into
    a store of boxes (or, `masks`, of the chosen detections' RLE masks) at `out` (default
    `<path name>.zarr`). `image_size` is (height, width); `images` the COCO dataset's JSON (its
    image list) or the YOLO images' folder. Labels: `d1`, the depth at the closest frame of a
    static object, else none."""
    path = Path(path)
    _check(camera, which, fmt, masks, n_obs, windows, d1)
    if image_size is not None:
        image_size = checked_size(image_size, "image size")
    table = read_poses(camera.poses)
    dets = read_detections(fmt, path, Path(images) if images is not None else None, image_size, table,
                           camera.fps)
    if which.track is not None:
        choice = choose_track(dets, which.track, str(path))
    else:
        cats = np.unique(dets.label)
        if which.category is None and fmt != "mot" and len(cats) > 1:
            raise InputError(f"{path}: detections of {len(cats)} categories ({', '.join(map(str, cats[:5]))}"
                             f"{', ...' if len(cats) > 5 else ''}): choose one")
        choice = associate(dets, which.category, which.min_iou, str(path))
    c2w = camera_to_world(frame_matrices(table, dets.frames, camera.fps, camera.start_time,
                                         camera.time_tolerance), camera.direction)
    if out is None:
        out = store_path(".", path.resolve().stem, "hdf5" if store_format == "hdf5" else "zarr")
    out = Path(out)
    name = store_name(name, out, path.resolve().stem, "detections")
    rec = _recording(name, path, c2w, windows, n_obs, camera.max_rotation, d1)
    plan = (mask_plan(rec, dets, choice, name, path.name) if masks
            else box_plan(rec, choice, name, path.name, dets.size))
    result = DetectionsImporter(plan).write(out, store_format, overwrite=overwrite, progress=progress)
    missed = [dets.frames[f] for f in np.flatnonzero(choice.rows < 0)]
    return DetectionsResult(result, len(dets.frames), missed, choice.close)
