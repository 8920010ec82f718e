"""Box examples as ODMD's released generator makes them (griffbr/ODMD, odmd/data_gen), each drawn
from its own counter-based stream keyed by (seed, index) (counter_draws.py), so an example depends
on nothing else, and a batch is drawn in a few array operations.

An object of width and height U(size_lim) m starts at depth U(z_lim) and at an x, y inside the
field of view with room for the largest move; it moves by +-U(move_min, move_max) m per axis, the
start and end swapped with probability 1/2 (`end_swap`); the num_pos - 2 positions between are
uniform draws along the way, sorted so each axis moves monotonically. Each position's box is the
pinhole projection [xc, yc, w, h], normalised by the image width (x, w) and height (y, h).

With `perturb`: N(0, std_dev) on every box coordinate; a fraction `shuffle` of examples has one
frame's box replaced by another example's box of the same frame; N(0, cam_dev) m on every camera
movement. ODMD shuffles within a batch (exactly int(shuffle * batch) examples, the donor another
example of the batch). Here each example is shuffled with probability `shuffle` and its donor is
a further example drawn from its own stream, so an example never depends on its batch.

With `rotation` (odms-data's addition, not a setting of the authors' generator: degrees, 0 by
default), the camera also turns, about an axis drawn uniformly on the sphere per example,
steadily from the first frame to the last, by `rotation` in all: the last frame's camera is
unturned, so the label and the movements (the true translations, in its axes) are those of the
unturned example, while each frame's box is the object's projection in its turned camera, of the
object's size at its depth along the turned optical axis (benchmarks/rotation_cost.py).

BOX_GENERATOR_VERSION is what a generated store of boxes records as `generator.version`: 2 for
these streams; version 1 (stores without the key) drew each example from its own PCG64.

Per example: `boxes` (n, 4), `move` (n, 3) the object's displacement from each frame to the last
(ODMD's camera movement; the last row 0), `depth` the object's depth at the last frame, float64.
`frame_depth` is each frame's depth along that frame's optical axis.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import astuple, dataclass, fields

import numpy as np

from ..errors import InputError
from . import counter_draws
from .params import MAX_SIDE


@dataclass(frozen=True)
class BoxParams:
    """A generator configuration (ODMD's config/data_gen) and its camera (config/camera)."""

    z_lim: tuple[float, float] = (0.55, 1.0)
    move_min: tuple[float, float, float] = (0.0, 0.0, 0.05)
    move_max: tuple[float, float, float] = (0.25, 0.175, 0.325)
    size_lim: tuple[float, float] = (0.01, 0.175)
    num_pos: int = 10
    end_swap: bool = True
    perturb: bool = True
    std_dev: float = 0.001
    cam_dev: float = 0.01
    shuffle: float = 0.1
    image_dim: tuple[int, int] = (480, 640)  # height, width
    fx: float = 205.5
    fy: float = 205.5
    cx: float = 320.5
    cy: float = 240.5
    rotation: float = 0.0  # degrees the camera turns from the first frame to the last (odms-data's)

    def __post_init__(self) -> None:
        problem = _value_problem(self)
        if problem:
            raise InputError(problem)
        for name, (kind, count) in _KINDS.items():  # 1 and 1.0 are one setting, recorded as 1.0
            if kind is float:
                value = getattr(self, name)
                object.__setattr__(self, name, tuple(map(float, value)) if count else float(value))
        problem = _range_problem(self)
        if problem:
            raise InputError(problem)
        lo, hi = self.x_range(self.z_lim[0]), self.y_range(self.z_lim[0])
        if lo[0] > 0 or hi[0] > 0:
            raise InputError(f"the field of view at depth {self.z_lim[0]} m has no room for the moves; "
                             "raise z_lim")

    def max_rotation(self) -> float:
        """The largest `rotation` this camera allows, degrees: under 90 less the angle from the
        optical axis to the image's farthest corner, so that no object turns behind the camera,
        and at most MAX_ROTATION."""
        h, w = self.image_dim
        corner = math.hypot(max(self.cx, w - self.cx) / self.fx, max(self.cy, h - self.cy) / self.fy)
        return min(MAX_ROTATION, math.floor(10 * (90 - math.degrees(math.atan(corner)))) / 10)

    def _margins(self, axis: int, c: float, f: float, extent: float) -> tuple[float, float, float, float]:
        """lo(z) = a_lo z + b_lo and hi(z) = a_hi z + b_hi: where an object at depth z may start so
        that it stays in view after any move."""
        pad = self.move_max[axis] + self.size_lim[1] / 2
        a_lo, a_hi = -c / f, (extent - c) / f
        return a_lo, pad + self.move_max[2] * c / f, a_hi, -pad - self.move_max[2] * a_hi

    def x_range(self, z: float | np.ndarray) -> tuple[float | np.ndarray, float | np.ndarray]:
        a_lo, b_lo, a_hi, b_hi = self._margins(0, self.cx, self.fx, self.image_dim[1])
        return z * a_lo + b_lo, z * a_hi + b_hi

    def y_range(self, z: float | np.ndarray) -> tuple[float | np.ndarray, float | np.ndarray]:
        a_lo, b_lo, a_hi, b_hi = self._margins(1, self.cy, self.fy, self.image_dim[0])
        return z * a_lo + b_lo, z * a_hi + b_hi


MAX_ROTATION = 30.0  # degrees: the range benchmarks/rotation_cost.py charts
MAX_NUM_POS = 1000
MAX_DEPTH = 1e3  # m, of z_lim, move_max and size_lim
# field -> (kind, count: None for a scalar): the type of each setting
_KINDS: dict[str, tuple[type, int | None]] = {
    "z_lim": (float, 2), "move_min": (float, 3), "move_max": (float, 3), "size_lim": (float, 2),
    "num_pos": (int, None), "end_swap": (bool, None), "perturb": (bool, None), "std_dev": (float, None),
    "cam_dev": (float, None), "shuffle": (float, None), "image_dim": (int, 2), "fx": (float, None),
    "fy": (float, None), "cx": (float, None), "cy": (float, None), "rotation": (float, None),
}


def shown(value: object, limit: int = 60) -> str:
    """`value` as a message shows it: its repr (a tuple as a list), cut to about `limit` characters."""
    text = repr(list(value) if isinstance(value, tuple) else value)
    return text if len(text) <= limit else text[:limit] + "..."


def _value_problem(p: BoxParams) -> str | None:
    """What is wrong with the type of a setting of `p`, naming it; None when nothing."""
    for name, (kind, count) in _KINDS.items():
        value = getattr(p, name)
        items = value if count is not None and isinstance(value, tuple) else (value,)
        ok = (count is None) != isinstance(value, tuple) and (count is None or len(items) == count)
        for v in items:
            if kind is bool:
                ok = ok and isinstance(v, bool)
            else:
                ok = ok and not isinstance(v, bool) and isinstance(v, int if kind is int else int | float)
                ok = ok and math.isfinite(v)
        if not ok:
            what = {bool: "true or false", int: "a whole number", float: "a number"}[kind]
            if count is not None:
                what = f"a list of {count} {'whole numbers' if kind is int else 'numbers'}"
            return f"{name} must be {what}, got {shown(value)}"
    return None


def _range_problem(p: BoxParams) -> str | None:
    """What is wrong with the range of a setting of `p`, naming it; None when nothing."""
    limits = f"[low, high] with 0 < low <= high <= {MAX_DEPTH:g} m"
    checks = (
        ("num_pos", 2 <= p.num_pos <= MAX_NUM_POS, f"from 2 to {MAX_NUM_POS}"),
        ("z_lim", 0 < p.z_lim[0] <= p.z_lim[1] <= MAX_DEPTH, limits),
        ("size_lim", 0 < p.size_lim[0] <= p.size_lim[1] <= MAX_DEPTH, limits),
        ("move_max", all(0 <= v <= MAX_DEPTH for v in p.move_max), f"from 0 to {MAX_DEPTH:g} m on each axis"),
        ("move_min", all(0 <= lo <= hi for lo, hi in zip(p.move_min, p.move_max, strict=True)),
         "from 0 to move_max on each axis"),
        ("std_dev", 0 <= p.std_dev <= 1, "from 0 to 1 (a share of the image side)"),
        ("cam_dev", 0 <= p.cam_dev <= MAX_DEPTH, f"from 0 to {MAX_DEPTH:g} m"),
        ("shuffle", 0 <= p.shuffle <= 1, "from 0 to 1"),
        ("image_dim", all(1 <= v <= MAX_SIDE for v in p.image_dim), f"[height, width] of 1 to {MAX_SIDE} px"),
        ("fx", p.fx > 0, "above 0"), ("fy", p.fy > 0, "above 0"),
        ("cx", abs(p.cx) <= 4 * MAX_SIDE, f"from -{4 * MAX_SIDE} to {4 * MAX_SIDE} px"),
        ("cy", abs(p.cy) <= 4 * MAX_SIDE, f"from -{4 * MAX_SIDE} to {4 * MAX_SIDE} px"),
    )
    for name, ok, allowed in checks:
        if not ok:
            value = getattr(p, name)
            return f"{name} must be {allowed}, got {shown(value)}"
    if not 0 <= p.rotation <= p.max_rotation():
        return (f"rotation must be from 0 to {p.max_rotation():g} degrees with this camera (at most "
                f"{MAX_ROTATION:g}, and no turn that could put an object behind it), got {p.rotation!r}")
    return None


def preset_name(p: BoxParams) -> str | None:
    """The name of the preset whose settings are `p`'s, if any."""
    return next((name for name, q in BOX_PRESETS.items() if astuple(q) == astuple(p)), None)


def box_setting_names() -> list[str]:
    return [f.name for f in fields(BoxParams)]


DEFAULT_BOX_EXAMPLES_PER_SHARD = 4096  # examples a task of a store of boxes makes: about a CPU-second

BOX_PRESETS = {
    # the released generator: config/data_gen/standard_data.yaml with the HSR grasp camera (its demo)
    "odmd": BoxParams(),
    # the same without perturbations, and with one kind each: what ODMD's Normal, Perturb Camera
    # and Perturb Detect sets show (their boxes, movements and sizes)
    "odmd-normal": BoxParams(perturb=False),
    "odmd-perturb-motion": BoxParams(std_dev=0.0, shuffle=0.0),
    "odmd-perturb-detection": BoxParams(cam_dev=0.0),
    # config/data_gen/ODMS.yaml: motion along z only, with the ODMS camera
    "odms": BoxParams(move_max=(0.0, 0.0, 0.4625), fx=240.5, fy=240.5),
}


BOX_GENERATOR_VERSION = 2
CHUNK = 1024  # examples made at a time


def _n_uniforms(p: BoxParams) -> int:
    """Uniforms an example draws: 8 for start, move and size, 3 signs, the swap, the shuffle
    and 3 per intermediate position."""
    return 13 + 3 * (p.num_pos - 2)


def _positions(p: BoxParams, u: np.ndarray) -> np.ndarray:
    """(num_pos, 3, B) object positions x, y, z in camera coordinates, m, from uniforms u (k, B)."""
    z0 = p.z_lim[0] + (p.z_lim[1] - p.z_lim[0]) * u[0]
    (xlo, xhi), (ylo, yhi) = p.x_range(z0), p.y_range(z0)
    start = np.stack([xlo + u[1] * (xhi - xlo), ylo + u[2] * (yhi - ylo), z0])
    lo, hi = np.array(p.move_min)[:, None], np.array(p.move_max)[:, None]
    end = start + np.where(u[8:11] < 0.5, -1.0, 1.0) * (lo + (hi - lo) * u[3:6])
    if p.end_swap:
        swap = u[11] < 0.5
        start, end = np.where(swap, end, start), np.where(swap, start, end)
    out = np.empty((p.num_pos, 3, u.shape[1]))
    out[0], out[-1] = start, end
    along = np.sort(u[13:].reshape(p.num_pos - 2, 3, -1), axis=0)  # monotone from start to end
    np.multiply(end - start, along, out=out[1:-1])
    out[1:-1] += start
    return out


def _turned(p: BoxParams, pos: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """(num_pos, 3, B) positions `pos` in cameras turned about unit `axes` (3, B), frame i by
    `rotation` (num_pos - 1 - i) / (num_pos - 1) degrees: R^T x by Rodrigues' formula."""
    turn = np.radians(p.rotation) * np.arange(p.num_pos - 1, -1, -1)[:, None, None] / (p.num_pos - 1)
    k = axes[None]
    cross = np.cross(k, pos, axis=1)
    along = (k * pos).sum(axis=1, keepdims=True) * k
    return pos * np.cos(turn) - cross * np.sin(turn) + along * (1 - np.cos(turn))


def _boxes(p: BoxParams, u: np.ndarray, noise: np.ndarray | None, axes: np.ndarray | None
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(num_pos, 4, B) boxes, with the box noise (4 num_pos, B) when given, seen by cameras
    turned about `axes` (3, B) when given; the positions (num_pos, 3, B) in the last frame's
    axes; and each frame's depth (num_pos, B) along its own optical axis."""
    pos = _positions(p, u)
    seen = pos if axes is None else _turned(p, pos, axes)
    h, w = p.image_dim
    inv_z = 1 / seen[:, 2]
    boxes = np.empty((p.num_pos, 4, u.shape[1]))
    np.multiply(seen[:, 0] * (p.fx / w), inv_z, out=boxes[:, 0])
    np.multiply(seen[:, 1] * (p.fy / h), inv_z, out=boxes[:, 1])
    boxes[:, 0] += p.cx / w
    boxes[:, 1] += p.cy / h
    size = p.size_lim[0] + (p.size_lim[1] - p.size_lim[0]) * u[6:8]
    np.multiply(size[0] * (p.fx / w), inv_z, out=boxes[:, 2])
    np.multiply(size[1] * (p.fy / h), inv_z, out=boxes[:, 3])
    if noise is not None:
        boxes += p.std_dev * noise.reshape(p.num_pos, 4, -1)
    return boxes, pos, seen[:, 2]


def sample_box_examples(p: BoxParams, seed: int, indices: Sequence[int] | np.ndarray
                        ) -> dict[str, np.ndarray]:
    """The examples at generator `indices` of (p, seed): `boxes` (B, n, 4), `move` (B, n, 3),
    `depth` (B,) and each frame's true depth `frame_depth` (B, n), float64; each depends only on
    (p, seed, its index). Each example's stream gives, in order: its uniforms, its normals (with
    `perturb`: box noise then camera noise), when shuffled the frame, the donor's uniforms and
    box noise, and with `rotation` its axis and the donor's. Made CHUNK examples at a time, one
    array row a draw, so that the arrays stay in the cache and each step runs along a contiguous
    row."""
    keys = counter_draws.example_keys(seed, indices)
    b, n = len(keys), p.num_pos
    out = {"boxes": np.empty((b, n, 4)), "move": np.empty((b, n, 3)), "depth": np.empty(b),
           "frame_depth": np.empty((b, n))}
    for i in range(0, b, CHUNK):
        boxes, depth, move = _examples(p, keys[i:i + CHUNK])
        out["boxes"][i:i + CHUNK] = boxes.transpose(2, 0, 1)
        out["move"][i:i + CHUNK] = move.transpose(2, 0, 1)
        out["frame_depth"][i:i + CHUNK] = depth.T
    out["depth"][:] = out["frame_depth"][:, -1]
    return out


def _examples(p: BoxParams, keys: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The boxes (n, 4, B), each frame's depth (n, B) and the movements (n, 3, B) of the
    examples of stream `keys`."""
    n, k = p.num_pos, _n_uniforms(p)
    box_noise = p.perturb and p.std_dev > 0
    cam_noise = p.perturb and p.cam_dev > 0
    n_normal = 4 * n * box_noise + 3 * (n - 1) * cam_noise
    at_normal = (k + 1) // 2  # the draws: uniforms, normals, then the donor's uniforms and normals
    at_donor = at_normal + (n_normal + 1) // 2
    at_axes = at_donor + (k + 2) // 2 + 2 * n  # after the donor's k + 1 uniforms and 4 n normals
    u = counter_draws.uniforms(keys, 0, k)
    normal = counter_draws.normals(keys, at_normal, n_normal)
    shuffled = np.flatnonzero(u[12] < p.shuffle) if p.perturb else np.zeros(0, np.int64)
    frame = np.zeros(0, np.int64)
    b = len(keys)
    noise = normal[:4 * n] if box_noise else None
    if len(shuffled):  # the donors' boxes are made with the examples', as further columns
        dk = keys[shuffled]
        du = counter_draws.uniforms(dk, at_donor, k + 1)  # the frame, then the donor's uniforms
        frame = (du[0] * n).astype(np.int64)
        u = np.concatenate([u, du[1:]], axis=1)
        if noise is not None:
            noise = np.concatenate([noise, counter_draws.normals(dk, at_donor + (k + 2) // 2, 4 * n)], axis=1)
    axes = None
    if p.rotation > 0:  # each example's axis, then its donor's
        both = counter_draws.normals(keys, at_axes, 6)
        axes = np.concatenate([both[:3], both[3:, shuffled]], axis=1)
        axes /= np.sqrt((axes * axes).sum(axis=0))
    boxes, pos, depth = _boxes(p, u, noise, axes)
    boxes[frame, :, shuffled] = boxes[frame, :, b + np.arange(len(shuffled))]
    boxes, pos, depth = boxes[..., :b], pos[..., :b], depth[:, :b]
    move = pos[-1:] - pos
    if cam_noise:
        move[:-1] += p.cam_dev * normal[n_normal - 3 * (n - 1):].reshape(n - 1, 3, -1)
    return boxes, depth, move
