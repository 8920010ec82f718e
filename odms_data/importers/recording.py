"""Importing a user's own recording: a folder of mask images and a positions CSV or a camera pose
file -> a store.

The CSV's columns, the pose formats and units are documented in schemas/RECORDING.md. With poses,
z is the camera's position along the first frame's optical axis, and an example whose frames turn
more than `max_rotation` degrees is refused and listed (kind "skipped"). Frames are ordered by z
(closest first). The store holds one example over all frames, or the robot protocol's windowed
examples (`windows` lengths, `n_obs` frames evenly spaced in each). Labels come from a `depth`
column (d1 = depth at an example's closest frame), from a known `d1` for a static object (depth =
d1 + z - smallest z), or not at all (unlabelled examples, d1 NaN).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import InputError
from ..inputs import inside, open_input
from ..protocol import WHOLE, protocol_windows, window_id
from ..store.format import store_path
from ..store.oddity import SKIPPED, Oddity
from .builder import Importer, Progress
from .decoding import Workers
from .mask_files import MaskFile, is_mask_file
from .plan import DEFAULT_THRESHOLD, MaskPlan, Skips, store_name
from .poses import (
    DEFAULT_MAX_ROTATION,
    DEFAULT_TIME_TOLERANCE,
    DIRECTIONS,
    axis_positions,
    camera_pose,
    camera_to_world,
    check_pose_direction,
    match_times,
    name_times,
    read_poses,
    window_rotations,
)
from .result import ImportResult
from .text_rows import number

if TYPE_CHECKING:
    import pandas as pd

COLUMNS = ("frame", "z", "depth")
FRAMES_PER_CHUNK = 32
FRAMES_PER_SHARD = 512


def _number(text: str, where: str, column: str, *, blank_ok: bool = False) -> float:
    if blank_ok and text.strip() in ("", "nan", "NaN", "NA"):
        return math.nan
    return number(text, f"{where}: {column}")


def _read_table(positions: Path) -> pd.DataFrame:
    """The positions CSV as text, its columns checked."""
    import pandas as pd

    try:
        with open_input(positions, "a positions CSV") as f:
            table = pd.read_csv(f, dtype=str, keep_default_na=False, skipinitialspace=True)
    except pd.errors.EmptyDataError:
        raise InputError(f"{positions}: is empty (expected a header line 'frame,z')") from None
    except (pd.errors.ParserError, UnicodeDecodeError, OSError) as e:
        raise InputError(f"{positions}: not a readable CSV ({' '.join(str(e).split())})") from None
    table.columns = [str(c).strip() for c in table.columns]
    unknown = [c for c in table.columns if c not in COLUMNS]
    if unknown:
        raise InputError(f"{positions}: unknown column '{unknown[0]}'; the columns are frame, z and "
                         "optionally depth (see schemas/RECORDING.md)")
    for c in ("frame", "z"):
        if c not in table.columns:
            raise InputError(f"{positions}: no '{c}' column (the columns are frame, z[, depth])")
    return table


@dataclass
class _Rows:
    """The CSV rows read so far: each frame, position and file by the line that listed it."""

    mask_dir: Path
    has_depth: bool
    seen_frame: dict[str, int] = field(default_factory=dict)
    seen_z: dict[float, int] = field(default_factory=dict)
    seen_file: dict[tuple[int, int], tuple[int, str]] = field(default_factory=dict)  # (device, inode)
    named: set[str] = field(default_factory=set)  # frames named on any row, good or bad

    def read(self, row: Any, line: int, where: str) -> tuple[Path, float, float]:
        """The row's mask file, z and depth; InputError for its first problem."""
        frame = row.frame.strip()
        self.named.add(os.path.normpath(frame))
        if not frame:
            raise InputError(f"{where}: frame is empty")
        if frame in self.seen_frame:
            first = self.seen_frame[frame]
            raise InputError(f"{where}: frame '{frame}' is listed twice (first on line {first})")
        zi = _number(row.z, where, "z")
        if zi in self.seen_z:
            raise InputError(f"{where}: duplicate position z = {row.z.strip()} (as on line "
                             f"{self.seen_z[zi]}); each frame needs its own position")
        di = _number(row.depth, where, "depth", blank_ok=True) if self.has_depth else math.nan
        if not di > 0 and not math.isnan(di):
            raise InputError(f"{where}: depth {row.depth.strip()} is not a positive distance")
        path = inside(self.mask_dir, frame, f"{where}, column frame")
        if not path.is_file():
            inner = sorted(self.mask_dir.glob(f"*/{frame}"))  # MASK_DIR one folder too high?
            hint = f"; did you mean MASK_DIR {inner[0].parent}?" if inner else ""
            raise InputError(f"{where}: frame '{frame}' not found in {self.mask_dir}{hint}")
        st = path.stat()
        same = self.seen_file.get((st.st_dev, st.st_ino))
        if same:
            raise InputError(f"{where}: frame '{frame}' is the same file as '{same[1]}' on line "
                             f"{same[0]}; each frame is listed once")
        self.seen_frame[frame], self.seen_z[zi] = line, line
        self.seen_file[(st.st_dev, st.st_ino)] = (line, frame)
        return path, zi, di


def read_positions(
    positions: Path, mask_dir: Path, skip_bad: bool
) -> tuple[list[Path], np.ndarray, np.ndarray | None, list[Oddity]]:
    """Mask files, z and depth (None without a depth column) of the listed frames, in CSV order,
    and the frames skipped (skip_bad) as oddities; InputError for the first problem otherwise."""
    table = _read_table(positions)
    rows = _Rows(mask_dir, "depth" in table.columns)
    skips = Skips(skip_bad)
    files, z, depth = [], [], []
    for i, row in enumerate(table.itertuples(index=False)):
        try:
            path, zi, di = rows.read(row, i + 2, f"{positions} line {i + 2}")
        except InputError as e:
            skips.add(f"line {i + 2}", e)
            continue
        files.append(path)
        z.append(zi)
        depth.append(di)
    for p in sorted(mask_dir.iterdir()):
        if is_mask_file(p) and p.name not in rows.named:  # no resolve(): it raises on symlink loops
            skips.add(p.name, f"{p}: no row in {positions} (every mask needs its camera position)")
    return files, np.array(z, np.float64), np.array(depth, np.float64) if rows.has_depth else None, \
        skips.oddities


def read_pose_frames(
    poses: Path, mask_dir: Path, direction: str, time_tolerance: float
) -> tuple[list[Path], np.ndarray, np.ndarray]:
    """The folder's mask files (by name), their z and camera-to-world matrices, from a pose file:
    one pose per mask in name order, or (TUM) the pose nearest each mask's time."""
    files = sorted(p for p in mask_dir.iterdir() if is_mask_file(p))
    table = read_poses(poses)
    if table.times is None:
        if len(table.matrices) != len(files):
            raise InputError(f"{poses}: {len(table.matrices)} poses for {len(files)} masks in {mask_dir} "
                             "(one pose per mask, in the order of the masks' names)")
        matrices = table.matrices
    else:
        names = [str(f) for f in files]
        matrices = table.matrices[match_times(table, name_times(names), names, time_tolerance)]
    c2w = camera_to_world(matrices, direction)
    check_pose_direction(str(poses), {i: camera_pose(M, "camera-to-world") for i, M in enumerate(c2w)},
                         direction)
    return files, axis_positions(c2w), c2w


def _turning(
    ids: list[str], frame_index: np.ndarray, c2w: np.ndarray | None, max_rotation: float
) -> tuple[np.ndarray, list[Oddity]]:
    """Which examples turn at most max_rotation degrees, and an oddity for each of the others."""
    if c2w is None:
        return np.ones(len(ids), bool), []
    turn = window_rotations(c2w, frame_index)
    keep = turn <= max_rotation
    return keep, [Oddity(SKIPPED, ids[e], f"{ids[e]}: its frames turn by {turn[e]:.2f} degrees, more than "
                         f"max_rotation {max_rotation:g}") for e in np.flatnonzero(~keep)]


def windowed_examples(
    name: str, where: Path, n: int, windows: list[int] | None, n_obs: int, c2w: np.ndarray | None,
    max_rotation: float,
) -> tuple[list[str], np.ndarray, list[Oddity]]:
    """The ids and frame rows (E, k) of the examples over `n` frames ordered closest first: one over
    all frames, or the robot protocol's windows; those whose frames turn more than `max_rotation`
    degrees (`c2w` in that order) are left out, and returned as oddities."""
    if windows:
        too_long = [w for w in windows if w > n]
        if too_long:
            raise InputError(f"{where}: window of {too_long[0]} frames does not fit the recording's "
                             f"{n} frames")
        if n_obs > min(windows):
            raise InputError(f"n_obs {n_obs} is more than the shortest window ({min(windows)} frames)")
        digits = max(2, len(str(n - 1)))
        spans = protocol_windows(n, windows, n_obs)
        ids = [window_id(name, w, s, digits) for w, s, _ in spans]
        frame_index = np.stack([idx for _, _, idx in spans])
    else:
        ids, frame_index = [f"{name}/{WHOLE}"], np.arange(n)[None, :]
    keep, turned = _turning(ids, frame_index, c2w, max_rotation)
    if not keep.any():
        raise InputError(f"{where}: every example turns more than max_rotation {max_rotation:g} "
                         f"degrees ({turned[0].detail})")
    return [i for i, k in zip(ids, keep, strict=True) if k], frame_index[keep], turned


def make_plan(
    name: str, mask_dir: Path, files: list[Path], z: np.ndarray, depth: np.ndarray,
    windows: list[int] | None, n_obs: int, threshold: int, skipped: list[Oddity],
    c2w: np.ndarray | None = None, max_rotation: float = DEFAULT_MAX_ROTATION,
) -> MaskPlan:
    if len(files) < 2:
        raise InputError(f"{mask_dir}: {len(files)} usable frame(s), at least 2 are needed")
    order = np.argsort(z, kind="stable")
    files, z, depth = [files[i] for i in order], z[order], depth[order]
    c2w = c2w[order] if c2w is not None else None
    ids, frame_index, turned = windowed_examples(name, mask_dir, len(files), windows, n_obs, c2w,
                                                 max_rotation)
    d1 = depth[frame_index[:, 0]]
    return MaskPlan(
        split=name, domain="recording", source=f"recording {mask_dir.name}",
        masks=[MaskFile(f) for f in files], z=z,
        depth=depth, frame_index=frame_index, d1=d1, ids=ids, sources=[mask_dir.name] * len(ids),
        frames_per_chunk=FRAMES_PER_CHUNK, frames_per_shard=FRAMES_PER_SHARD,
        oddities=list(skipped) + turned, threshold=threshold,
    )


def _check_options(mask_dir: Path, threshold: int, n_obs: int, windows: list[int] | None,
                   d1: float | None) -> None:
    if not mask_dir.is_dir():
        raise InputError(f"{mask_dir}: no such folder")
    if not 0 <= threshold <= 255:
        raise InputError(f"threshold {threshold} is outside 0..255")
    if n_obs < 2:
        raise InputError(f"n_obs {n_obs}: at least 2 observations are needed")
    if windows is not None and (not windows or min(windows) < 2):
        raise InputError("windows must be lengths of at least 2 frames, e.g. 10,15,20,25,30")
    if d1 is not None and not (math.isfinite(d1) and d1 > 0):
        raise InputError(f"d1 {d1} is not a positive distance")


def _check_pose_options(positions: str | Path | None, poses: str | Path | None, pose: str,
                        time_tolerance: float, max_rotation: float) -> None:
    if (positions is None) == (poses is None):
        raise InputError("give the camera as either positions (a CSV) or poses (a pose file), one of them")
    if pose not in DIRECTIONS:
        raise InputError(f"pose '{pose}': expected {' or '.join(DIRECTIONS)}")
    if not time_tolerance >= 0 or not math.isfinite(time_tolerance):
        raise InputError(f"time tolerance {time_tolerance}: expected seconds >= 0")
    if not 0 <= max_rotation <= 180:
        raise InputError(f"max_rotation {max_rotation}: expected degrees from 0 to 180")


@dataclass
class RecordingImporter(Importer):
    """A recording's frames as read from its CSV, less those left out so far."""

    name: str
    mask_dir: Path
    files: list[Path]
    z: np.ndarray
    depth: np.ndarray
    windows: list[int] | None
    n_obs: int
    threshold: int
    skipped: list[Oddity]
    skip_bad: bool = False
    c2w: np.ndarray | None = None  # (frames, 4, 4) camera-to-world, from a pose file
    max_rotation: float = DEFAULT_MAX_ROTATION

    def plan(self) -> MaskPlan:
        return make_plan(self.name, self.mask_dir, self.files, self.z, self.depth, self.windows, self.n_obs,
                         self.threshold, self.skipped, self.c2w, self.max_rotation)

    def drop(self, plan: MaskPlan, failures: list[tuple[int, str]]) -> None:
        bad = {str(plan.masks[row]) for row, _ in failures}
        self.skipped = self.skipped + [Oddity(SKIPPED, plan.masks[row].name, m) for row, m in failures]
        keep = [i for i, f in enumerate(self.files) if str(f) not in bad]
        self.files, self.z, self.depth = [self.files[i] for i in keep], self.z[keep], self.depth[keep]
        if self.c2w is not None:
            self.c2w = self.c2w[keep]


def import_recording(
    mask_dir: str | Path,
    positions: str | Path | None = None,
    out: str | Path | None = None,
    *,
    poses: str | Path | None = None,
    pose: str = "camera-to-world",
    time_tolerance: float = DEFAULT_TIME_TOLERANCE,
    max_rotation: float = DEFAULT_MAX_ROTATION,
    windows: list[int] | None = None,
    n_obs: int = 10,
    threshold: int = DEFAULT_THRESHOLD,
    d1: float | None = None,
    name: str | None = None,
    fmt: str | None = None,
    overwrite: bool = False,
    skip_bad: bool = False,
    workers: int | None = None,
    progress: Progress | None = None,
) -> ImportResult:
    """Import the recording into a store at `out` (default `<mask_dir name>.zarr`), its camera given by
    `positions` (a CSV) or `poses` (a pose file in the `pose` direction). With skip_bad, bad rows and
    files are left out and recorded as oddities of kind "skipped", as are examples that turn more
    than `max_rotation` degrees.
    `progress(mask_dir, done, total)` follows the decoding."""
    label = str(mask_dir)
    mask_dir = Path(mask_dir)
    _check_options(mask_dir, threshold, n_obs, windows, d1)
    _check_pose_options(positions, poses, pose, time_tolerance, max_rotation)
    if out is None:
        out = store_path(".", mask_dir.resolve().name, "hdf5" if fmt == "hdf5" else "zarr")
    out = Path(out)
    name = store_name(name, out, mask_dir.resolve().name, "recording")
    c2w, depth, skipped = None, None, list[Oddity]()
    if poses is not None:
        files, z, c2w = read_pose_frames(Path(poses), mask_dir, pose, time_tolerance)
    else:
        positions = Path(str(positions))
        files, z, depth, skipped = read_positions(positions, mask_dir, skip_bad)
    if depth is not None and d1 is not None:
        raise InputError(f"{positions}: has a depth column; give either per-frame depth or d1, not both")
    if depth is None:  # a known d1 means a static object: depth = d1 + z - smallest z
        with np.errstate(over="ignore"):  # an overflow to inf is refused with the format's rules
            depth = d1 + (z - z.min()) if d1 is not None and len(z) else np.full(len(z), math.nan)
    source = RecordingImporter(name, mask_dir, files, z, depth, windows, n_obs, threshold, skipped, skip_bad,
                               c2w, max_rotation)
    with Workers(workers) as pool:
        return source.write(out, fmt, pool, label=label, overwrite=overwrite, progress=progress)
