"""Importing SYNTHIA-SEQS video sequences into a driving store, as the ODMS paper made its set.

A sequence folder (SYNTHIA-SEQS-XX-SEASON) holds, per camera, numbered label, depth and
camera-parameter files. A mask is the pixels of one instance (car, pedestrian, bicycle) in one
label image. An instance's track runs from its first to its last appearance, absences of up to
`max_gap` frames kept as empty masks. An example is a window of consecutive frames of a track,
closest (last) frame first: z is the camera's displacement along the closest frame's optical
axis, depth the mean of the depth image over the mask, d1 the depth at the closest frame.
Windows ending at the same frame share their frame rows; windows ending elsewhere get their own,
because with a turning camera the same frame has another z. Conventions (with their sources),
the protocol and every option: schemas/SYNTHIA.md.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from itertools import pairwise
from pathlib import Path

import cv2
import numpy as np

from ..errors import InputError
from ..inputs import listed_inside, read_input
from ..store.oddity import Oddity
from .builder import Importer, Progress
from .decoding import Workers
from .mask_files import image_size, read_png
from .plan import MaskPlan, MaskSource, Skips, store_name
from .poses import Pose, camera_pose, check_pose_direction, rotation_problem
from .result import ImportResult, SequenceCounts, SynthiaSummary
from .synthia_protocol import CAMERAS, CLASS_NAMES, PAPER_SELECTION, SYNTHIA_POSES, PoseConvention, Selection

NOT_OCCLUDING = (1, 3, 4, 12)  # sky, road, sidewalk, lane marking: never in front of an object
OCCLUSION_MARGIN = 0.5  # m; a neighbouring pixel this much closer than the object hides part of it
REQUIRED = ("GT/LABELS", "Depth", "CameraParams")
FRAMES_PER_CHUNK = 32
FRAMES_PER_SHARD = 1024
MAX_POSE_BYTES = 1 << 16  # a CameraParams file: 16 numbers


# --- the sequence's files ------------------------------------------------------------------


@dataclass
class SequenceFiles:
    """One sequence's files for one camera, by frame number; only frames every folder has."""

    name: str
    root: Path
    labels: dict[int, Path]
    depth: dict[int, Path]
    params: dict[int, Path]

    @property
    def frames(self) -> list[int]:
        return sorted(self.labels)

    def drop(self, frame: int) -> None:
        for files in (self.labels, self.depth, self.params):
            files.pop(frame, None)


def _numbered(folder: Path, suffix: str) -> dict[int, Path]:
    """Files named by a frame number (000123.png), each inside `folder`; other files are ignored."""
    def numbered(p: Path) -> bool:
        return p.suffix.lower() == suffix and re.fullmatch(r"[0-9]+", p.stem) is not None

    return {int(p.stem): p for p in listed_inside(folder, numbered)}


def find_sequence(seq_dir: Path, camera: str, skip_bad: bool) -> tuple[SequenceFiles, list[Oddity]]:
    """The camera's frames in a sequence folder. A frame missing from one of the folders (RGB
    included, when present) is an error, or with skip_bad left out and returned as an oddity."""
    if not seq_dir.is_dir():
        raise InputError(f"{seq_dir}: no such folder (give SYNTHIA-SEQS-XX-SEASON folders)")
    folders = {k: seq_dir / k / camera for k in REQUIRED}
    for d in folders.values():
        if not d.is_dir():
            inner = sorted(p for p in seq_dir.glob("SYNTHIA-SEQS-*") if p.is_dir())
            hint = f" ({seq_dir} holds sequence folders; give those, e.g. {inner[0]})" if inner else ""
            raise InputError(f"{d}: no such folder{hint}")
    if (seq_dir / "RGB" / camera).is_dir():
        folders["RGB"] = seq_dir / "RGB" / camera
    found = {k: _numbered(d, ".txt" if k == "CameraParams" else ".png") for k, d in folders.items()}
    if not found["GT/LABELS"]:
        raise InputError(f"{folders['GT/LABELS']}: holds no numbered label images (000000.png, ...)")
    common = set.intersection(*(set(f) for f in found.values()))
    skips = Skips(skip_bad)
    for frame in sorted(set.union(*(set(f) for f in found.values())) - common):
        have = next(k for k in found if frame in found[k])
        lack = next(k for k in found if frame not in found[k])
        counts = ", ".join(f"{k} {len(v)}" for k, v in found.items())
        name = found[have][frame].with_suffix(".txt" if lack == "CameraParams" else ".png").name
        skips.add(f"{seq_dir.name} frame {frame}",
                  f"{folders[lack] / name}: missing, but {have} has frame {frame} (frames: {counts})")
    files = [{f: found[k][f] for f in sorted(common)} for k in REQUIRED]
    return SequenceFiles(seq_dir.name, seq_dir, files[0], files[1], files[2]), skips.oddities


def read_pose(path: Path, convention: PoseConvention) -> Pose:
    """(camera centre, unit optical axis) in world coordinates from one CameraParams file."""
    try:
        tokens = read_input(path, "a CameraParams file", MAX_POSE_BYTES).decode().split()
    except UnicodeDecodeError as e:
        raise InputError(f"{path}: cannot be read ({e})") from None
    if len(tokens) != 16:
        raise InputError(f"{path}: expected 16 numbers (a 4x4 matrix), found {len(tokens)}")
    values = np.empty(16)
    for k, t in enumerate(tokens):
        try:
            values[k] = float(t)
        except ValueError:
            raise InputError(f"{path}: '{t}' is not a number") from None
    if not np.isfinite(values).all():
        raise InputError(f"{path}: holds a number that is not finite")
    M = values.reshape(4, 4, order="F" if convention.order == "column-major" else "C")
    if not np.allclose(M[3], (0, 0, 0, 1), atol=1e-6):
        other = "row-major" if convention.order == "column-major" else "column-major"
        raise InputError(f"{path}: the matrix's last row is {' '.join(f'{v:g}' for v in M[3])}, not 0 0 0 1",
                         fix=f"matrix-order-{other}")
    problem = rotation_problem(M[:3, :3], proper=False)  # SYNTHIA's cameras may mirror an axis
    if problem:
        raise InputError(f"{path}: {problem}")
    return camera_pose(M, convention.direction, convention.forward)


# --- scanning the label and depth images (on the workers) ----------------------------------


@dataclass(frozen=True, eq=False)
class InstanceMask:
    """One instance's pixels in one label image, as a `MaskSource`: its bounding box and the
    packed pixels inside it (an absent instance has an empty box)."""

    label: str  # the label image
    instance: int
    height: int
    width: int
    box: tuple[int, int, int, int]  # x, y, w, h
    bits: np.ndarray  # (h, ceil(w / 8)) uint8, np.packbits of the box's pixels along rows

    @property
    def name(self) -> str:
        return f"{Path(self.label).name} (instance {self.instance})"

    def __str__(self) -> str:
        return f"{self.label} (instance {self.instance})"

    def size(self) -> tuple[int, int]:
        return self.height, self.width

    def read(self, threshold: int = 0, expect: tuple[int, int] | None = None) -> np.ndarray:
        if expect is not None and (self.height, self.width) != tuple(expect):
            raise InputError(f"{self}: image size {self.height}x{self.width} differs from the "
                             f"{expect[0]}x{expect[1]} (height x width) of the other images")
        mask = np.zeros((self.height, self.width), bool)
        x, y, w, h = self.box
        if w:
            mask[y : y + h, x : x + w] = np.unpackbits(self.bits, axis=1, count=w).view(bool)
        return mask


@dataclass
class Sighting:
    """One instance in one frame."""

    instance: int
    cls: int  # its most frequent class among the selected ones
    area: int
    depth: float  # m, mean of the depth image over the mask
    border: bool  # touches the image border
    occluded: bool  # partly hidden (see _occluded)
    mask: InstanceMask


@dataclass
class FrameScan:
    """The selected instances of one frame, or why the frame could not be read."""

    frame: int
    sightings: list[Sighting] = field(default_factory=list)
    classes: tuple[int, ...] = ()  # selected classes seen on pixels with an instance id
    size: tuple[int, int] = (0, 0)
    failure: str | None = None


def scan_frame(task: tuple[int, str, str, tuple[int, ...], tuple[int, int] | None]) -> FrameScan:
    """Every instance of the selected classes in one frame (run on a worker); its images must be
    `expect` (height, width) in size, checked from their headers."""
    frame, label_path, depth_path, classes, expect = task
    try:
        labels = _read_16bit(Path(label_path), "label", 3, expect)
        depth = _read_16bit(Path(depth_path), "depth", 1, labels.shape[:2])
    except InputError as e:
        return FrameScan(frame, failure=str(e))
    cls, inst = cv2.extractChannel(labels, 2), cv2.extractChannel(labels, 1)  # BGR: R = class, G = instance
    cm = depth[..., 2] if depth.ndim == 3 else depth
    H, W = cls.shape
    wanted = np.zeros(1 << 16, bool)
    wanted[list(classes)] = True
    found = cv2.findNonZero((inst != 0).view(np.uint8))  # pixels with an instance id (dynamic objects)
    xs, ys = np.reshape(found if found is not None else np.zeros((0, 2), np.int32), (-1, 2)).T
    keep = wanted[cls[ys, xs]]
    ys, xs = ys[keep], xs[keep]
    ids = inst[ys, xs]
    order = np.argsort(ids, kind="stable")
    ys, xs, ids = ys[order], xs[order], ids[order]
    scan = FrameScan(frame, size=(H, W), classes=tuple(int(c) for c in np.unique(cls[ys, xs])))
    bounds = np.flatnonzero(np.diff(ids, prepend=-1, append=-1))
    for a, b in pairwise(bounds):
        yy, xx = ys[a:b], xs[a:b]
        x, y = int(xx.min()), int(yy.min())
        w, h = int(xx.max()) + 1 - x, int(yy.max()) + 1 - y
        box = np.zeros((h, w), bool)
        box[yy - y, xx - x] = True
        i = int(ids[a])
        scan.sightings.append(Sighting(
            instance=i, cls=int(np.bincount(cls[yy, xx]).argmax()), area=int(b - a),
            depth=float(cm[yy, xx].sum(dtype=np.int64)) / 100.0 / (b - a),
            border=x == 0 or y == 0 or x + w == W or y + h == H,
            occluded=_occluded(box, x, y, cls, inst, cm, i),
            mask=InstanceMask(label_path, i, H, W, (x, y, w, h), np.packbits(box, axis=1)),
        ))
    return scan


def _read_16bit(path: Path, what: str, min_channels: int, expect: tuple[int, int] | None) -> np.ndarray:
    img = read_png(path, expect)
    if img.dtype != np.uint16:
        raise InputError(f"{path}: {8 * img.itemsize}-bit PNG; SYNTHIA {what} images are 16-bit")
    channels = 1 if img.ndim == 2 else img.shape[2]
    if channels < min_channels:
        raise InputError(f"{path}: {channels} channel(s); SYNTHIA label images have 3 "
                         "(class, instance, unused)")
    return img


def _occluded(box: np.ndarray, x: int, y: int, cls: np.ndarray, inst: np.ndarray, cm: np.ndarray,
              i: int) -> bool:
    """Whether a pixel next to the instance (its pixels `box` at x, y), neither ground nor sky nor
    the instance itself, is more than OCCLUSION_MARGIN closer than the instance's pixels beside it."""
    H, W = cls.shape
    h, w = box.shape
    y0, y1, x0, x1 = max(0, y - 1), min(H, y + h + 1), max(0, x - 1), min(W, x + w + 1)
    m = np.zeros((y1 - y0, x1 - x0), bool)
    m[y - y0 : y - y0 + h, x - x0 : x - x0 + w] = box
    metres = cm[y0:y1, x0:x1].astype(np.float32) / 100
    kernel = np.ones((3, 3), np.uint8)
    ring = cv2.dilate(m.view(np.uint8), kernel).view(bool) & ~m
    beside = cv2.dilate(np.where(m, metres, 0), kernel)  # the farthest instance pixel beside each pixel
    hides = ring & ~np.isin(cls[y0:y1, x0:x1], NOT_OCCLUDING) & (inst[y0:y1, x0:x1] != i)
    return bool(np.any(hides & (metres + OCCLUSION_MARGIN < beside)))


@dataclass
class Scanned:
    """Every sequence read and scanned: what the plan is made from."""

    camera: str
    sequences: list[SequenceFiles]
    poses: dict[str, dict[int, Pose]]
    scans: dict[str, dict[int, FrameScan]]
    size: tuple[int, int]
    oddities: list[Oddity]  # frames and sequences skipped as bad


def _find_sequences(seq_dirs: Sequence[str | Path], camera: str, skips: Skips) -> list[SequenceFiles]:
    """Every sequence's frames, those that are bad left out (skips)."""
    sequences: list[SequenceFiles] = []
    for d in map(Path, seq_dirs):
        try:
            seq, skipped = find_sequence(d, camera, skips.skip_bad)
        except InputError as e:
            skips.add(d.name, e)
            continue
        if any(s.name == seq.name for s in sequences):
            raise InputError(f"{d}: a second sequence named {seq.name} (their example ids would collide)")
        sequences.append(seq)
        skips.oddities += skipped
    return sequences


def _read_poses(
    sequences: list[SequenceFiles], convention: PoseConvention, skips: Skips
) -> dict[str, dict[int, Pose]]:
    """Every frame's camera pose; a frame whose parameters are bad is dropped (skips); a sequence
    whose poses look read in the wrong direction is refused (check_pose_direction)."""
    poses: dict[str, dict[int, Pose]] = {}
    for seq in sequences:
        poses[seq.name] = {}
        for f in seq.frames:
            try:
                poses[seq.name][f] = read_pose(seq.params[f], convention)
            except InputError as e:
                seq.drop(f)
                skips.add(f"{seq.name} frame {f}", e)
        check_pose_direction(seq.name, poses[seq.name], convention.direction)
    return poses


def _scan_frames(
    seq: SequenceFiles, pool: Workers, classes: tuple[int, ...], size: tuple[int, int] | None, skips: Skips,
    progress: Progress | None,
) -> tuple[dict[int, FrameScan], tuple[int, int] | None]:
    """The scans of a sequence's frames, and the image size (the first readable frame's); a frame
    that cannot be read or has another size is dropped (skips)."""
    tasks = [(f, str(seq.labels[f]), str(seq.depth[f]), classes, size) for f in seq.frames]
    scans: dict[int, FrameScan] = {}
    with pool.map(scan_frame, tasks) as results:
        for k, scan in enumerate(results, 1):
            if scan.failure is None and size is not None and scan.size != size:
                scan.failure = (f"{seq.labels[scan.frame]}: {scan.size[0]}x{scan.size[1]} pixels, "
                                f"but the first label image has {size[0]}x{size[1]}")
            if scan.failure is not None:
                seq.drop(scan.frame)
                skips.add(f"{seq.name} frame {scan.frame}", scan.failure)
            else:
                size = size or scan.size
                scans[scan.frame] = scan
            if progress:
                progress(seq.name, k, len(tasks))
    return scans, size


def scan_sequences(
    seq_dirs: Sequence[str | Path],
    pool: Workers,
    *,
    camera: str = CAMERAS[0],
    classes: tuple[int, ...] = PAPER_SELECTION.classes,
    convention: PoseConvention = SYNTHIA_POSES,
    skip_bad: bool = False,
    progress: Progress | None = None,
) -> Scanned:
    """Read the camera parameters and scan the label and depth images of every sequence."""
    if camera not in CAMERAS:
        raise InputError(f"camera {camera}: not a SYNTHIA camera; one of {', '.join(CAMERAS)}")
    skips = Skips(skip_bad)
    sequences = _find_sequences(seq_dirs, camera, skips)
    poses = _read_poses(sequences, convention, skips)
    scans: dict[str, dict[int, FrameScan]] = {}
    size = _first_size(sequences)
    for seq in sequences:
        scans[seq.name], size = _scan_frames(seq, pool, classes, size, skips, progress)
    if size is None:
        raise InputError(f"no readable frame in {', '.join(map(str, seq_dirs))}")
    return Scanned(camera, sequences, poses, scans, size, skips.oddities)


def _first_size(sequences: list[SequenceFiles]) -> tuple[int, int] | None:
    """(height, width) of the first label image, from its header; None when it is unreadable
    (its scan then says why)."""
    first = next((s.labels[s.frames[0]] for s in sequences if s.frames), None)
    try:
        return image_size(first) if first is not None else None
    except InputError:
        return None


def check_classes(scanned: Scanned, classes: tuple[int, ...]) -> None:
    """InputError for a class that no instance of any sequence has."""
    seen = {c for scans in scanned.scans.values() for s in scans.values() for c in s.classes}
    for c in classes:
        if c not in seen:
            where = scanned.sequences[0].root / "GT/LABELS" / scanned.camera
            others = len(scanned.sequences) - 1
            more = f", nor in the other {others} sequence(s)" if others else ""
            raise InputError(f"{where}: no instance of class {c} ({CLASS_NAMES.get(c, 'schemas/SYNTHIA.md')})"
                             f" in any label image{more}")


# --- tracks, windows and the plan ----------------------------------------------------------


@dataclass
class Track:
    """One instance from its first to its last appearance, short absences included."""

    sequence: SequenceFiles
    instance: int
    frames: list[int]  # consecutive frame numbers
    sightings: dict[int, Sighting]

    @property
    def cls(self) -> int:
        return int(np.bincount([s.cls for s in self.sightings.values()]).argmax())


def find_tracks(seq: SequenceFiles, scans: dict[int, FrameScan], max_gap: int) -> list[Track]:
    """Every instance's tracks; a track ends at an absence longer than max_gap frames and at a
    frame the sequence lacks (a bad frame skipped)."""
    seen: dict[int, dict[int, Sighting]] = {}
    for f in seq.frames:
        for s in scans[f].sightings:
            seen.setdefault(s.instance, {})[f] = s
    present = set(seq.frames)
    tracks = []
    for instance, by_frame in sorted(seen.items()):
        frames = sorted(by_frame)
        runs = [[frames[0]]]
        for prev, nxt in pairwise(frames):
            if nxt - prev - 1 <= max_gap and all(g in present for g in range(prev + 1, nxt)):
                runs[-1].append(nxt)
            else:
                runs.append([nxt])
        for run in runs:
            span = list(range(run[0], run[-1] + 1))
            tracks.append(Track(seq, instance, span, {g: by_frame[g] for g in run}))
    return tracks


def select_windows(track: Track, poses: dict[int, Pose], sel: Selection) -> dict[int, list[int]]:
    """closest frame -> lengths of the track's windows ending there that pass the rules."""
    out: dict[int, list[int]] = {}
    t0 = track.frames[0]
    for c in track.frames:
        s = track.sightings.get(c)
        if s is None or s.area < sel.min_area or not sel.d1[0] <= s.depth <= sel.d1[1]:
            continue
        centre, axis = poses[c]
        for n in sorted(sel.frames):
            first = c - n + 1
            if first < t0 or (first - t0) % sel.stride:
                continue
            if not sel.move[0] <= float(np.dot(centre - poses[first][0], axis)) <= sel.move[1]:
                continue
            inside = [track.sightings[f] for f in range(first, c + 1) if f in track.sightings]
            if n - len(inside) > sel.max_gap:  # the gap rule over the window's empty masks in all
                continue
            if (not sel.border and any(x.border for x in inside)) or \
                    (not sel.occluded and any(x.occluded for x in inside)):
                continue
            out.setdefault(c, []).append(n)
    return out


def plan_store(scanned: Scanned, sel: Selection, split: str) -> tuple[MaskPlan, dict[str, dict]]:
    """The store's frame rows (per track and closest frame, closest first) and examples, and per
    sequence the number of tracks and examples of each class."""
    masks: list[MaskSource] = []
    z: list[float] = []
    depth: list[float] = []
    examples = []
    counts: dict[str, dict] = {s.name: {"frames": len(scanned.scans[s.name]), "tracks": {}, "examples": {}}
                               for s in scanned.sequences}
    for seq in scanned.sequences:
        poses = scanned.poses[seq.name]
        for t in find_tracks(seq, scanned.scans[seq.name], sel.max_gap):
            if t.cls not in sel.classes:
                continue
            cname = CLASS_NAMES.get(t.cls, str(t.cls))
            tally = counts[seq.name]
            tally["tracks"][cname] = tally["tracks"].get(cname, 0) + 1
            for c, lengths in select_windows(t, poses, sel).items():
                base = len(masks)
                centre, axis = poses[c]
                for f in range(c, c - max(lengths), -1):
                    s = t.sightings.get(f)
                    masks.append(s.mask if s else InstanceMask(str(seq.labels[f]), t.instance, *scanned.size,
                                                               (0, 0, 0, 0), np.zeros((0, 0), np.uint8)))
                    z.append(float(np.dot(centre - poses[f][0], axis)))
                    depth.append(s.depth if s else math.nan)
                for n in lengths:
                    source = f"{seq.name} {scanned.camera} {cname} {t.instance}"
                    eid = f"{split}/{seq.name}_{c - n + 1}_{n}_{t.instance}"
                    examples.append((eid, base, n, t.sightings[c].depth, source))
                    tally["examples"][cname] = tally["examples"].get(cname, 0) + 1
    examples.sort(key=lambda e: [int(p) if p.isdigit() else p for p in re.split(r"(\d+)", e[0])])
    frame_index = np.full((len(examples), max((e[2] for e in examples), default=1)), -1, np.int64)
    for k, (_, base, n, _, _) in enumerate(examples):
        frame_index[k, :n] = base + np.arange(n)
    plan = MaskPlan(
        split=split, domain="driving", source=f"SYNTHIA-SEQS, {scanned.camera}", masks=masks,
        z=np.array(z, np.float64), depth=np.array(depth, np.float64), frame_index=frame_index,
        d1=np.array([e[3] for e in examples], np.float64), ids=[e[0] for e in examples],
        sources=[e[4] for e in examples], frames_per_chunk=FRAMES_PER_CHUNK,
        frames_per_shard=FRAMES_PER_SHARD, oddities=list(scanned.oddities),
    )
    return plan, counts


# --- the import ----------------------------------------------------------------------------


@dataclass
class SynthiaImporter(Importer):
    """The store planned from the scanned sequences; bad frames were left out while scanning, so
    none is dropped while writing."""

    planned: MaskPlan

    def plan(self) -> MaskPlan:
        return self.planned


def import_synthia(
    seq_dirs: Sequence[str | Path],
    out: str | Path,
    *,
    camera: str = CAMERAS[0],
    selection: Selection = PAPER_SELECTION,
    classes_given: bool = False,
    convention: PoseConvention = SYNTHIA_POSES,
    name: str | None = None,
    fmt: str | None = None,
    overwrite: bool = False,
    skip_bad: bool = False,
    workers: int | None = None,
    progress: Progress | None = None,
) -> ImportResult:
    """Import SYNTHIA-SEQS sequence folders into one driving store at `out`.

    Everything is read and checked before anything is written. The result's summary holds, per
    sequence, its frames, tracks and examples of each class. With `classes_given`, a selected
    class that no sequence shows is an error. With skip_bad, bad frames and sequences are left
    out and recorded as oddities of kind "skipped".
    `progress(label, done, total)` follows the scanning of each sequence, then the writing.
    """
    selection.check()
    out = Path(out)
    split = store_name(name, out, "synthia", "synthia")
    with Workers(workers) as pool:
        scanned = scan_sequences(seq_dirs, pool, camera=camera, classes=selection.classes,
                                 convention=convention, skip_bad=skip_bad, progress=progress)
        if classes_given:
            check_classes(scanned, selection.classes)
        plan, counts = plan_store(scanned, selection, split)
        if not plan.ids:
            names = ", ".join(s.name for s in scanned.sequences)
            raise InputError(f"no window of {names} passes the selection rules", fix="synthia-selection")
        result = SynthiaImporter(plan).write(out, fmt, pool, label=f"{out.name} (writing)",
                                             overwrite=overwrite, progress=progress)
    attrs = result.attrs
    summary = SynthiaSummary(
        store=str(out), split=split, camera=camera, examples=attrs.counts["examples"],
        frames=attrs.counts["frames"], digest=attrs.digest, skipped=tuple(result.skipped),
        oddities=len(attrs.oddities),
        sequences=tuple(SequenceCounts(s.name, **counts[s.name]) for s in scanned.sequences),
    )
    return replace(result, summary=summary)
