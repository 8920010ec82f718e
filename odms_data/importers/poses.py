"""Camera poses: turning a pose matrix into the camera's centre and optical axis, checking its
rotation, and checking that a sequence's poses were read in the right direction.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError

Pose = tuple[np.ndarray, np.ndarray]  # camera centre, unit optical axis; world coordinates, m
ROTATION_TOLERANCE = 1e-4  # largest |R^T R - I| entry of a rotation (rows written with 5 decimals pass)


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
