"""The network inputs of the paper (Griffin & Corso, ECCV 2020, section 4), framework-free.

One example becomes a dict of NumPy arrays:

- `masks` (n_obs, h, w): `n_obs` evenly spaced observations, `numpy.linspace(0, n-1, n_obs)`
  truncated to integers, each resized to `size` with cv2 INTER_AREA. By default uint8 0/1 (a pixel
  is 1 when the object covers about half of it or more: INTER_AREA's mean, rounded), a quarter of
  the bytes of float32, to be made float on the accelerator; with `coverage=True`, float32
  fractions of each pixel covered.
- `dz` (n_obs,) float32: z_i - z_1, m.
- `zbar` (n_obs - 2,) float32: (z_i - z_1) / (z_n - z_1) for 1 < i < n.
- labels, float32 scalars: `d1` (m), `d1_norm` = d1 / (z_n - z_1) and `scale` = d1 / d_n, the
  relative scale, with d_n = d1 + z_n - z_1 (a still object, the camera moving along its axis).
- `radial` (1, h, w) float32 when asked for: 1 at the image centre falling linearly with the
  distance from it to 0 at the corner pixels.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import cv2
import numpy as np

from ..benchmark import evenly_spaced
from ..errors import InputError
from ..simulate.shrink import resize_masks
from .targets import labels

cv2.setNumThreads(1)

PAPER_SIZE = (112, 112)
LABELS = ("d1", "d1_norm", "scale")


def observation_indices(n: int, n_obs: int) -> np.ndarray:
    """Indices of `n_obs` evenly spaced observations out of `n`, first and last included."""
    if not 2 <= n_obs <= n:
        raise InputError(f"need 2 <= n_obs <= n, got n_obs={n_obs} for an example of {n} frames")
    return evenly_spaced(0, n - 1, n_obs)


def distances(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """dz = z_i - z_1 (all i) and zbar = (z_i - z_1) / (z_n - z_1) (1 < i < n)."""
    z = np.asarray(z, np.float64)
    dz = z - z[0]
    return dz.astype(np.float32), (dz[1:-1] / dz[-1]).astype(np.float32)


@lru_cache(maxsize=8)
def radial_image(size: tuple[int, int]) -> np.ndarray:
    """(h, w) float32: 1 at the centre, falling linearly with the distance to 0 at the corners."""
    h, w = size
    y = np.arange(h) - (h - 1) / 2
    x = np.arange(w) - (w - 1) / 2
    r = np.hypot(y[:, None], x[None, :])
    corner = r.max()
    return (1 - r / corner if corner > 0 else np.ones((h, w))).astype(np.float32)


@dataclass(frozen=True)
class Transform:
    """Masks, camera positions and label of one example to the network inputs.

    `size` (h, w) of the masks given to the network (None: keep the store's size); `n_obs`
    observations (None: all of the example's); `radial` adds the radial image; `coverage`
    gives float32 covered fractions instead of uint8 0/1 masks.
    """

    size: tuple[int, int] | None = PAPER_SIZE
    n_obs: int | None = None
    radial: bool = False
    coverage: bool = False

    def __post_init__(self) -> None:
        if self.size is not None and (len(self.size) != 2 or min(self.size) < 1):
            raise InputError(f"size must be (height, width) >= 1, got {self.size}")
        if self.n_obs is not None and self.n_obs < 2:
            raise InputError(f"n_obs must be at least 2, got {self.n_obs}")

    def select(self, n: int) -> np.ndarray:
        """Which of an example's n frames to use."""
        return observation_indices(n, self.n_obs or n)

    def __call__(self, masks: np.ndarray, z: np.ndarray, d1: float) -> dict[str, Any]:
        """Inputs from the already selected observations: masks (k, H, W), z (k,), label d1."""
        size = self.size or masks.shape[1:]
        return {"masks": resize_masks(masks, size, self.coverage), **self.vectors(z, d1, size)}

    def vectors(self, z: np.ndarray, d1: float, size: tuple[int, int]) -> dict[str, Any]:
        """Every input but the masks (of shape `size`), from the selected z (k,) and label d1."""
        dz, zbar = distances(z)
        out = {"dz": dz, "zbar": zbar, **labels(d1, z)}
        if self.radial:
            out["radial"] = radial_image(size)[None]
        return out


PAPER_TRANSFORM = Transform()  # 112x112 uint8 masks, every observation, no radial image
