"""Box examples as ODMD's released generator makes them (griffbr/ODMD, odmd/data_gen), each drawn
from its own generator seeded by (seed, index) (seeding.py), so an example depends on nothing else.

An object of width and height U(size_lim) m starts at depth U(z_lim) and at an x, y inside the
field of view with room for the largest move; it moves by +-U(move_min, move_max) m per axis, the
start and end swapped with probability 1/2 (`end_swap`); the num_pos - 2 positions between are
uniform draws along the way, sorted so each axis moves monotonically. Each position's box is the
pinhole projection [xc, yc, w, h], normalised by the image width (x, w) and height (y, h).

With `perturb`: N(0, std_dev) on every box coordinate; a fraction `shuffle` of examples has one
frame's box replaced by another example's box of the same frame; N(0, cam_dev) m on every camera
movement. ODMD shuffles within a batch (exactly int(shuffle * batch) examples, the donor another
example of the batch). Here each example is shuffled with probability `shuffle` and its donor is
a further example drawn from its own generator, so an example never depends on its batch.

Per example: `boxes` (n, 4), `move` (n, 3) the object's displacement from each frame to the last
(ODMD's camera movement; the last row 0), `depth` the object's depth at the last frame, float64.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .seeding import example_rngs


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

    def __post_init__(self) -> None:
        if self.num_pos < 2:
            raise InputError(f"num_pos must be at least 2, got {self.num_pos}")
        if not 0 <= self.shuffle <= 1 or self.std_dev < 0 or self.cam_dev < 0:
            raise InputError("shuffle must lie in [0, 1] and std_dev, cam_dev be non-negative")
        lo, hi = self.x_range(self.z_lim[0]), self.y_range(self.z_lim[0])
        if lo[0] > 0 or hi[0] > 0:
            raise InputError(f"the field of view at depth {self.z_lim[0]} m has no room for the moves; "
                             "raise z_lim")

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


@dataclass
class _Draws:
    """One example's geometry draws: 8 uniforms, 3 signs, the swap, the intermediate uniforms and
    the box noise."""

    u: np.ndarray
    sign: np.ndarray
    swap: bool
    mid: np.ndarray
    noise: np.ndarray | None


def _draw(p: BoxParams, rng: np.random.Generator) -> _Draws:
    u = rng.random(8)
    sign = rng.integers(0, 2, 3) * 2 - 1
    swap = bool(rng.integers(0, 2)) if p.end_swap else False
    mid = rng.random((p.num_pos - 2, 3))
    noise = rng.normal(0, p.std_dev, (p.num_pos, 4)) if p.perturb and p.std_dev > 0 else None
    return _Draws(u, sign, swap, mid, noise)


def _positions(p: BoxParams, d: _Draws) -> np.ndarray:
    """(num_pos, 3) object positions x, y, z in camera coordinates, m."""
    u = d.u
    z0 = p.z_lim[0] + (p.z_lim[1] - p.z_lim[0]) * u[0]
    (xlo, xhi), (ylo, yhi) = p.x_range(z0), p.y_range(z0)
    start = np.array([xlo + u[1] * (xhi - xlo), ylo + u[2] * (yhi - ylo), z0])
    lo, hi = np.array(p.move_min), np.array(p.move_max)
    end = start + d.sign * (lo + (hi - lo) * u[3:6])
    if d.swap:
        start, end = end, start
    out = np.empty((p.num_pos, 3))
    out[0], out[-1] = start, end
    out[1:-1] = start + (end - start) * np.sort(d.mid, axis=0)  # monotone from start to end
    return out


def _boxes(p: BoxParams, pos: np.ndarray, size: np.ndarray) -> np.ndarray:
    h, w = p.image_dim
    z = pos[:, 2]
    return np.stack([pos[:, 0] * (p.fx / w) / z + p.cx / w, pos[:, 1] * (p.fy / h) / z + p.cy / h,
                     size[0] * (p.fx / w) / z, size[1] * (p.fy / h) / z], axis=1)


def _example(p: BoxParams, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, float]:
    d = _draw(p, rng)
    pos = _positions(p, d)
    size = p.size_lim[0] + (p.size_lim[1] - p.size_lim[0]) * d.u[6:8]
    boxes = _boxes(p, pos, size)
    if d.noise is not None:
        boxes += d.noise
    if p.perturb and p.shuffle > 0 and rng.random() < p.shuffle:
        frame = int(rng.integers(p.num_pos))
        donor = _draw(p, rng)
        donor_size = p.size_lim[0] + (p.size_lim[1] - p.size_lim[0]) * donor.u[6:8]
        donor_boxes = _boxes(p, _positions(p, donor), donor_size)
        if donor.noise is not None:
            donor_boxes += donor.noise
        boxes[frame] = donor_boxes[frame]
    move = pos[-1] - pos
    if p.perturb and p.cam_dev > 0:
        move[:-1] += rng.normal(0, p.cam_dev, (p.num_pos - 1, 3))
    return boxes, move, float(pos[-1, 2])


def sample_box_examples(p: BoxParams, seed: int, indices: Sequence[int] | np.ndarray
                        ) -> dict[str, np.ndarray]:
    """The examples at generator `indices` of (p, seed): `boxes` (B, n, 4), `move` (B, n, 3),
    `depth` (B,), float64; each depends only on (p, seed, its index)."""
    rngs = example_rngs(seed, [int(i) for i in indices])
    boxes = np.empty((len(rngs), p.num_pos, 4))
    move = np.empty((len(rngs), p.num_pos, 3))
    depth = np.empty(len(rngs))
    for k, rng in enumerate(rngs):
        boxes[k], move[k], depth[k] = _example(p, rng)
    return {"boxes": boxes, "move": move, "depth": depth}
