"""Camera poses: reading what SLAM systems and datasets write (4x4 matrices as text or `.npy`,
TUM RGB-D trajectories, KITTI odometry rows), checking every row, and turning poses into what
the importers need: the camera's centre and optical axis, its position along that axis, the
rotation over a window, and the check that poses were read in the right direction. The formats
and conventions: schemas/RECORDING.md.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..pickles import load_npy
from .text_rows import number, text_rows

DIRECTIONS = ("camera-to-world", "world-to-camera")
Pose = tuple[np.ndarray, np.ndarray]  # camera centre, unit optical axis; world coordinates, m

MAX_FILE_BYTES = 256 << 20  # a pose file larger than this is refused before it is read
MAX_POSES = 1_000_000  # rows
MAX_LINE_CHARS = 4096  # a row of 16 numbers in full float64 precision takes under 400
MAX_LINES = 2 * MAX_POSES  # poses, blank lines and comments
FIELDS = {16: "4x4", 12: "kitti", 8: "tum"}  # numbers on a row -> format
ROTATION_TOLERANCE = 1e-4  # largest |R^T R - I| entry of a rotation (rows written with 5 decimals pass)
QUATERNION_TOLERANCE = 1e-3  # largest | |q| - 1 | of a TUM quaternion (TUM's files have 4 decimals)
DEFAULT_TIME_TOLERANCE = 0.02  # s between a frame and its pose (TUM's associate.py: max_difference)
DEFAULT_MAX_ROTATION = 3.0  # degrees over a window; docs/ODMD.md "What camera rotation costs"


@dataclass(frozen=True)
class PoseTable:
    """A pose file's rows: `matrices` (n, 4, 4) as written, `times` (n,) for TUM (else None), and the
    file's `format` ("4x4", "kitti", "tum", "npy")."""

    path: Path
    format: str
    matrices: np.ndarray
    times: np.ndarray | None


# --- checks shared by every pose reader ------------------------------------------------------


def rotation_problem(R: np.ndarray, proper: bool = True) -> str | None:
    """Why the 3x3 `R` is not a rotation (orthonormal within ROTATION_TOLERANCE and, when `proper`,
    det = +1), or None."""
    off = float(np.abs(R.T @ R - np.eye(3)).max())
    if not off <= ROTATION_TOLERANCE:
        return f"the rotation part is not orthonormal (R^T R differs from I by {off:.2g}; not a camera pose)"
    if proper and np.linalg.det(R) < 0:
        return "the rotation part is a reflection (det -1), not a rotation"
    return None


def camera_pose(M: np.ndarray, direction: str, forward: str = "+z") -> Pose:
    """(camera centre, unit optical axis) in world coordinates from a checked 4x4 pose matrix."""
    R = M[:3, :3]
    if direction == "camera-to-world":
        centre, axes = M[:3, 3], R  # columns: the camera's axes in the world
    else:
        centre, axes = -R.T @ M[:3, 3], R.T
    axis = axes[:, 2] if forward == "+z" else -axes[:, 2]
    return centre, axis / np.linalg.norm(axis)


def camera_to_world(matrices: np.ndarray, direction: str) -> np.ndarray:
    """(n, 4, 4) camera-to-world matrices from checked ones in `direction`."""
    if direction == "camera-to-world":
        return matrices
    out = np.zeros_like(matrices)
    Rt = np.swapaxes(matrices[:, :3, :3], 1, 2)
    out[:, :3, :3], out[:, :3, 3], out[:, 3, 3] = Rt, -np.einsum("nij,nj->ni", Rt, matrices[:, :3, 3]), 1
    return out


# --- reading ---------------------------------------------------------------------------------


def _quaternion_matrices(q: np.ndarray) -> np.ndarray:
    """(n, 3, 3) rotations of the (n, 4) unit quaternions (qx, qy, qz, qw)."""
    x, y, z, w = q.T
    return np.stack([np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
                     np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
                     np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1)], 1)


def _checked_matrices(values: np.ndarray, fmt: str, where: Callable[[int], str]) -> np.ndarray:
    """(n, 4, 4) matrices of rows of numbers (TUM: without the timestamp), every row checked;
    InputError naming the first bad row (`where(k)`)."""
    n = len(values)
    M = np.tile(np.eye(4), (n, 1, 1))
    if fmt == "tum":
        q = values[:, 3:]
        norm = np.linalg.norm(q, axis=1)
        for k in np.flatnonzero(~(np.abs(norm - 1) <= QUATERNION_TOLERANCE))[:1]:
            raise InputError(f"{where(k)}: quaternion qx qy qz qw has norm {norm[k]:.6g}, not 1 (within "
                             f"{QUATERNION_TOLERANCE:g})")
        M[:, :3, :3], M[:, :3, 3] = _quaternion_matrices(q / norm[:, None]), values[:, :3]
        return M
    M[:, : values.shape[1] // 4] = values.reshape(n, -1, 4)
    if fmt == "4x4":
        for k in np.flatnonzero(~np.isclose(M[:, 3], (0, 0, 0, 1), rtol=0, atol=1e-6).all(axis=1))[:1]:
            raise InputError(f"{where(k)}: the matrix's last row is {' '.join(f'{v:g}' for v in M[k, 3])}, "
                             "not 0 0 0 1")
    R = M[:, :3, :3]
    off = np.abs(np.einsum("nji,njk->nik", R, R) - np.eye(3)).max(axis=(1, 2))
    for k in np.flatnonzero(~(off <= ROTATION_TOLERANCE) | (np.linalg.det(R) < 0))[:1]:
        raise InputError(f"{where(k)}: {rotation_problem(R[k])}")
    return M


def _numbers(fields: list[str], where: str) -> np.ndarray:
    try:
        values = np.array([float(t) for t in fields])
        if np.isfinite(values).all():
            return values
    except ValueError:
        pass
    return np.array([number(t, f"{where}, field {k + 1}:") for k, t in enumerate(fields)], np.float64)


def _text_lines(path: Path) -> list[tuple[int, str]]:
    """The file's data lines with their line numbers (text_rows), at most MAX_POSES of them."""
    rows = list(text_rows(path, MAX_LINE_CHARS, MAX_LINES, "a pose row"))
    if len(rows) > MAX_POSES:
        raise InputError(f"{path}: more than {MAX_POSES} poses")
    if not rows:
        raise InputError(f"{path}: holds no poses")
    return rows


def _read_text(path: Path) -> PoseTable:
    rows = _text_lines(path)
    first = len(rows[0][1].split())
    if first not in FIELDS:
        raise InputError(f"{path} line {rows[0][0]}: {first} numbers; a pose row has 16 (a 4x4 matrix), "
                         "12 (KITTI's 3x4) or 8 (TUM: timestamp tx ty tz qx qy qz qw)")
    fmt = FIELDS[first]
    values = np.empty((len(rows), first))
    for k, (i, line) in enumerate(rows):
        fields = line.split()
        if len(fields) != first:
            raise InputError(f"{path} line {i}: {len(fields)} numbers, expected {first} as on line "
                             f"{rows[0][0]}")
        values[k] = _numbers(fields, f"{path} line {i}")
    times = values[:, 0] if fmt == "tum" else None
    if times is not None:
        for k in np.flatnonzero(~(times[1:] > times[:-1]))[:1]:
            line, text = rows[k + 1]
            raise InputError(f"{path} line {line}: timestamp {text.split()[0]} is not after the line "
                             "before's")
    matrices = _checked_matrices(values[:, 1:] if fmt == "tum" else values, fmt,
                                 lambda k: f"{path} line {rows[k][0]}")
    return PoseTable(path, fmt, matrices, times)


def _read_npy(path: Path) -> PoseTable:
    """An (n, 4, 4) float array, its header checked before the array is read (pickles.load_npy)."""
    array = load_npy(path, (4, 4), MAX_POSES, "poses")
    for k in np.flatnonzero(~np.isfinite(array).all(axis=(1, 2)))[:1]:
        raise InputError(f"{path} pose {k}: holds a number that is not finite")
    _checked_matrices(array.reshape(len(array), 16), "4x4", lambda k: f"{path} pose {k}")
    return PoseTable(path, "npy", array, None)


def read_poses(path: str | Path) -> PoseTable:
    """A pose file: `.npy` (n, 4, 4), else text whose first row's count of numbers gives the format
    (16: 4x4 matrix, 12: KITTI 3x4, 8: TUM). InputError naming the file and row for the first bad row."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    size = path.stat().st_size
    if size > MAX_FILE_BYTES:
        raise InputError(f"{path}: {size} bytes, more than a pose file may have ({MAX_FILE_BYTES})")
    return _read_npy(path) if path.suffix.lower() == ".npy" else _read_text(path)


# --- the direction check ------------------------------------------------------------------


# The camera is fixed to the car: the angle between its movement from one frame to the next and
# its optical axis (the mean of the two frames' axes, which a chord along a turn parallels) stays
# nearly constant along a sequence, or becomes 180 degrees minus itself while the car backs up.
# Read in the wrong direction, the "centre" is -R^T t, and on a straight stretch of road that
# angle is 180 degrees minus the car's heading: from one stretch to the next it changes by about
# the turn between them. Where a car turns, the angle of a camera L ahead of the rear axle moves
# off by atan(L / R) for a turn of radius R, either way: with L = 3 m (the front axle of a large
# car) and R = 4.5 m (a car's tightest turn, at the rear axle) that is 34 degrees, so 68 degrees of
# spread for a side camera through tight left and right turns (34 for a front or back camera);
# tests/importers/test_import_synthia.py drives that case at SYNTHIA's 5 frames per second.
# MAX_ANGLE_SPREAD keeps a margin above it.
MAX_ANGLE_SPREAD = 80.0  # degrees
MIN_MOVE = 0.05  # m between frames (0.9 km/h at 5 fps): below it the car stands and its movement is noise
NEAR_HALT = 0.8  # m: the most a car braking or starting at 1 g covers in a frame beside a halt


def angle_spread(poses: dict[int, Pose]) -> float:
    """The range, in degrees, of the angle between the camera's movement from each frame to the
    next and its optical axis, over the consecutive frames that move at least MIN_MOVE (0 for
    fewer than two). A movement against the one before it, one of them slow enough to be beside
    a halt (NEAR_HALT), is the car changing between driving and backing up: while it backs up,
    the angle of its reversed movement counts."""
    angles: list[float] = []
    before, before_length, backing = None, 0.0, False
    for f in sorted(poses):
        if f + 1 not in poses:
            continue
        (c0, a0), (c1, a1) = poses[f], poses[f + 1]
        move, axis = c1 - c0, a0 + a1
        length, width = float(np.linalg.norm(move)), float(np.linalg.norm(axis))
        if length < MIN_MOVE or width == 0:
            continue
        if before is not None and np.dot(move, before) < 0 and min(length, before_length) < NEAR_HALT:
            backing = not backing  # through a halt: its heading cannot turn that far in a frame
        before, before_length = move, length
        cos = float(np.clip(np.dot(move, axis) / (length * width), -1, 1))
        angles.append(math.degrees(math.acos(-cos if backing else cos)))
    return max(angles) - min(angles) if angles else 0.0


def check_pose_direction(name: str, poses: dict[int, Pose], direction: str) -> None:
    """InputError when the angle between the camera's movement and its optical axis varies along
    the sequence `name` more than a camera fixed to a car allows (MAX_ANGLE_SPREAD): its poses are
    then probably read in the wrong direction."""
    spread = angle_spread(poses)
    if spread > MAX_ANGLE_SPREAD:
        other = "world-to-camera" if direction == "camera-to-world" else "camera-to-world"
        raise InputError(f"{name}: the angle between the camera's movement and its optical axis varies by "
                         f"{spread:.0f} degrees along the sequence, more than the {MAX_ANGLE_SPREAD:.0f} "
                         f"a camera fixed to a car can: its poses are probably not {direction} "
                         "matrices", fix=f"pose-{other}")


# --- from poses to what the importers need ---------------------------------------------------


def match_times(table: PoseTable, frame_times: np.ndarray, frames: list[str], tolerance: float) -> np.ndarray:
    """For each frame time, the index of the pose with the nearest timestamp; InputError naming the
    first frame with no pose within `tolerance` seconds."""
    assert table.times is not None
    t = table.times
    right = np.clip(np.searchsorted(t, frame_times), 0, len(t) - 1)
    left = np.maximum(right - 1, 0)
    nearest = np.where(np.abs(t[left] - frame_times) <= np.abs(t[right] - frame_times), left, right)
    gap = np.abs(t[nearest] - frame_times)
    for k in np.flatnonzero(~(gap <= tolerance))[:1]:
        raise InputError(f"{frames[k]}: no pose in {table.path} within {tolerance:g} s of its time "
                         f"{frame_times[k]:.6f} (nearest {gap[k]:.3g} s away)")
    return nearest


def name_times(names: list[str]) -> np.ndarray:
    """Each frame's time from its name (1305031102.175304.png), to match TUM poses."""
    times = np.empty(len(names))
    for k, name in enumerate(names):
        try:
            times[k] = float(Path(name).stem)
        except ValueError:
            times[k] = math.nan
        if not math.isfinite(times[k]):
            raise InputError(f"{name}: its name is not a time in seconds; TUM poses are matched to frames "
                             "named by their time (e.g. 1305031102.175304.png)")
    return times


def axis_positions(c2w: np.ndarray) -> np.ndarray:
    """Each camera's position along the first camera's optical axis (+z), growing away from what
    it looks at (the recording's z), relative to the first frame."""
    axis = c2w[0, :3, 2] / np.linalg.norm(c2w[0, :3, 2])
    return -(c2w[:, :3, 3] - c2w[0, :3, 3]) @ axis


def window_rotations(c2w: np.ndarray, frame_index: np.ndarray) -> np.ndarray:
    """(examples,) the largest angle, in degrees, between the orientation of each example's first
    frame and that of any of its frames (`frame_index` rows index the matrices)."""
    R = c2w[:, :3, :3]
    first = R[frame_index[:, 0]]  # (E, 3, 3)
    trace = np.einsum("eab,ekab->ek", first, R[frame_index])  # trace(R_first^T R_k)
    return np.degrees(np.arccos(np.clip((trace - 1) / 2, -1, 1))).max(axis=1)
