"""Small sequences in SYNTHIA-SEQS's layout, rendered here for the importer's tests and benchmark.

A pinhole camera with SYNTHIA's intrinsics (760x1280, focal 532.740352 px, principal point
(640, 380)) drives along the ground (turning a little) past boxes and ellipsoids, ray cast per
pixel. Files as SYNTHIA writes them (schemas/SYNTHIA.md): GT/LABELS 16-bit PNGs with the class
in R and the instance in G, Depth 16-bit PNGs in centimetres (planar depth) in all three
channels, CameraParams one line of the 16 numbers of the camera-to-world matrix in column-major
order, the camera looking along -z of that matrix (x right, y up).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

FOCAL, CX, CY = 532.740352, 640.0, 380.0
H, W = 760, 1280
SKY, ROAD = 1, 3
FAR_CM = 65535  # depth of the sky, the largest a 16-bit PNG holds
CAMERA = "Stereo_Left/Omni_F"
_U, _V = np.meshgrid(np.arange(W, dtype=np.float64), np.arange(H, dtype=np.float64))
_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], np.float64)


@dataclass
class Thing:
    """A box or an ellipsoid with axes along the world's, moving at a constant velocity."""

    instance: int  # 0 for static stuff (buildings), as SYNTHIA labels it
    cls: int
    shape: str  # "box" or "ellipsoid"
    centre: tuple[float, float, float]  # m, world, at frame 0
    half: tuple[float, float, float]  # half extents or semi-axes, m
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)  # m per frame

    def centre_at(self, k: int) -> np.ndarray:
        return np.add(self.centre, np.multiply(self.velocity, k))


@dataclass
class Scene:
    """A camera at `height` m driving `steps[k]` m along its heading from frame k to k + 1 and
    turning `yaw_rate` rad per frame (to the left; `turns[k]` rad from frame k to k + 1 where
    given) from the heading `start_yaw` rad left of -z, past `things`."""

    name: str
    steps: list[float]
    things: list[Thing] = field(default_factory=list)
    yaw_rate: float = 0.004
    height: float = 1.5
    turns: list[float] | None = None
    start_yaw: float = 0.0

    def yaw(self, k: int) -> float:
        """The heading of frame k, rad to the left of the world's -z."""
        return self.start_yaw + (sum(self.turns[:k]) if self.turns is not None else self.yaw_rate * k)

    @property
    def n_frames(self) -> int:
        return len(self.steps) + 1

    def pose(self, k: int) -> np.ndarray:
        """Camera-to-world matrix of frame k: columns right, up, back (the camera looks along
        -z), centre."""
        centre = np.array([0.0, self.height, 0.0])
        for j in range(k):
            centre += self.steps[j] * heading(self.yaw(j))
        t = self.yaw(k)
        M = np.eye(4)
        M[:3, 0] = (np.cos(t), 0.0, -np.sin(t))
        M[:3, 2] = -heading(t)
        M[:3, 3] = centre
        return M

    def camera_move(self, closest: int, frame: int) -> float:
        """The camera's displacement from `frame` to `closest` along the optical axis at `closest`."""
        Mc, Mf = self.pose(closest), self.pose(frame)
        return float(np.dot(Mc[:3, 3] - Mf[:3, 3], -Mc[:3, 2]))


def heading(yaw: float) -> np.ndarray:
    return np.array([-np.sin(yaw), 0.0, -np.cos(yaw)])


def render(scene: Scene, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(class, instance, planar depth in m) of every pixel of frame k."""
    M = scene.pose(k)
    R, c = M[:3, :3], M[:3, 3]
    cls = np.full((H, W), SKY, np.uint16)
    inst = np.zeros((H, W), np.uint16)
    depth = np.full((H, W), FAR_CM / 100)
    below = np.arange(H) > CY  # the ground (no pitch, no roll: its depth depends on the row only)
    depth[below] = np.minimum(scene.height * FOCAL / (np.arange(H)[below] - CY), FAR_CM / 100)[:, None]
    cls[below] = ROAD
    for th in scene.things:
        centre, half = th.centre_at(k), np.asarray(th.half)
        cam = (centre + half * _CORNERS - c) @ R  # corners in camera coordinates
        if np.any(cam[:, 2] > -0.1):
            continue  # reaches behind the camera: not used by these scenes
        u = CX + FOCAL * cam[:, 0] / -cam[:, 2]
        v = CY - FOCAL * cam[:, 1] / -cam[:, 2]
        u0, u1 = max(0, int(u.min())), min(W, int(np.ceil(u.max())) + 1)
        v0, v1 = max(0, int(v.min())), min(H, int(np.ceil(v.max())) + 1)
        if u0 >= u1 or v0 >= v1:
            continue
        ray = np.stack([(_U[v0:v1, u0:u1] - CX) / FOCAL, (CY - _V[v0:v1, u0:u1]) / FOCAL,
                        -np.ones((v1 - v0, u1 - u0))], -1) @ R.T  # world, per metre of depth
        t, hit = _intersect(th.shape, c - centre, ray, half)
        sub = depth[v0:v1, u0:u1]
        win = hit & (t < sub)
        sub[win] = t[win]
        cls[v0:v1, u0:u1][win] = th.cls
        inst[v0:v1, u0:u1][win] = th.instance
    return cls, inst, depth


def _intersect(shape: str, origin: np.ndarray, ray: np.ndarray, half: np.ndarray):
    """Planar depth of the first hit of each ray, and whether it hits."""
    if shape == "box":
        with np.errstate(divide="ignore", invalid="ignore"):
            a, b = (-half - origin) / ray, (half - origin) / ray
        near = np.nanmax(np.minimum(a, b), -1)
        far = np.nanmin(np.maximum(a, b), -1)
        return near, (near <= far) & (near > 0)
    o, r = origin / half, ray / half
    a, b, c = (r * r).sum(-1), (o * r).sum(-1), (o * o).sum() - 1
    disc = b * b - a * c
    t = (-b - np.sqrt(np.maximum(disc, 0))) / a
    return t, (disc >= 0) & (t > 0)


def write_sequence(root: Path, scene: Scene, camera: str = CAMERA) -> Path:
    """Write `scene` as root/<scene.name> in SYNTHIA-SEQS's layout; returns that folder."""
    seq = root / scene.name
    folders = {k: seq / k / camera for k in ("RGB", "GT/LABELS", "Depth", "CameraParams")}
    for d in folders.values():
        d.mkdir(parents=True, exist_ok=True)
    (seq / "CameraParams" / "intrinsics.txt").write_text(f"{FOCAL}\n\n{CX:g}\n\n{CY:g}\n\n0.8\n")
    fast = [cv2.IMWRITE_PNG_COMPRESSION, 1]
    for k in range(scene.n_frames):
        cls, inst, depth = render(scene, k)
        name = f"{k:06d}"
        label = np.zeros((H, W, 3), np.uint16)
        label[..., 2], label[..., 1] = cls, inst  # OpenCV writes BGR: R = class, G = instance
        cv2.imwrite(str(folders["GT/LABELS"] / f"{name}.png"), label, fast)
        cm = np.minimum(np.rint(depth * 100), FAR_CM).astype(np.uint16)
        cv2.imwrite(str(folders["Depth"] / f"{name}.png"), np.repeat(cm[..., None], 3, -1), fast)
        cv2.imwrite(str(folders["RGB"] / f"{name}.png"), (cls * 16).astype(np.uint8), fast)
        numbers = scene.pose(k).ravel(order="F")
        (folders["CameraParams"] / f"{name}.txt").write_text(" ".join(repr(float(x)) for x in numbers) + "\n")
    return seq


CAR, PEDESTRIAN, BICYCLE, BUILDING = 8, 10, 11, 2


def street(n_frames: int = 24) -> Scene:
    """Driving 1.25 m per frame (turning 0.23 degrees per frame) past still and moving objects."""
    return Scene("SYNTHIA-SEQS-01-DAWN", [1.25] * (n_frames - 1), [
        Thing(12, CAR, "box", (1.2, 0.75, -40.0), (0.9, 0.75, 0.05)),  # still, a car's back
        Thing(7, PEDESTRIAN, "ellipsoid", (-2.5, 0.9, -34.0), (0.3, 0.9, 0.25)),  # still
        Thing(30, BICYCLE, "ellipsoid", (1.0, 0.8, -52.0), (0.3, 0.8, 0.9), (0.0, 0.0, -0.3)),
        # 30 rides away; hidden behind 12 in frames 0 and 1, partly in the next
        Thing(5, CAR, "box", (6.5, 0.75, -22.0), (0.9, 0.75, 2.1)),  # parked; leaves the frame at 15
        Thing(9, PEDESTRIAN, "ellipsoid", (-2.2, 0.9, -47.0), (0.3, 0.9, 0.25)),  # partly hidden by 41
        Thing(41, CAR, "box", (-1.6, 0.75, -43.0), (0.9, 0.75, 2.1)),  # still
        Thing(0, BUILDING, "box", (4.0, 1.5, -60.0), (0.6, 1.5, 0.3)),  # a kiosk
        Thing(22, PEDESTRIAN, "ellipsoid", (2.4, 0.9, -64.0), (0.3, 0.9, 0.25), (0.45, 0.0, 0.0)),
        # 22 walks behind the kiosk: absent in frames 3 to 5
    ])


STILL_AND_CLEAR = (12, 7, 41)  # instances neither moving, hidden nor cut by the border
