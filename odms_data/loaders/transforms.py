"""The network inputs of the paper (Griffin & Corso, ECCV 2020, section 4), framework-free, as
the authors' released code makes them (griffbr/ODMS, odn/model_utils.py).

One example becomes a dict of NumPy arrays:

- `masks` (n_obs, h, w) float32: `n_obs` evenly spaced observations, `numpy.linspace(0, n-1,
  n_obs)` truncated to integers, each shrunk to `size` with cv2 INTER_AREA: the fraction of each
  pixel the object covers. With `rounded=True`, uint8 0/1 instead: the fraction rounded (1 where
  the object covers about half the pixel or more), a quarter of the bytes, not the paper's input.
- `dz` (n_obs - 1,) float32: z_i - z_1 for 1 < i <= n, m (the paper's dz_2 .. dz_n).
- `zbar` (n_obs - 2,) float32: (z_i - z_1) / (z_n - z_1) for 1 < i < n.
- labels, float32 scalars: `d1` (m), `d1_norm` = d1 / (z_n - z_1) and `scale` = d1 / d_n, the
  relative scale, with d_n = d1 + z_n - z_1 (a still object, the camera moving along its axis).
- `radial` (1, h, w) float32 when asked for: the authors' radial template (radial_image).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any, ClassVar

import cv2
import numpy as np

from ..errors import InputError
from ..protocol import observation_indices
from ..simulate.shrink import resize_masks
from .targets import labels

PAPER_SIZE = (112, 112)
LABELS = ("d1", "d1_norm", "scale")
TEMPLATE_SIZE = 224  # the released radial template (data/misc/radial2D.png) is 224x224


def distances(z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """dz = z_i - z_1 (1 < i <= n) and zbar = (z_i - z_1) / (z_n - z_1) (1 < i < n)."""
    z = np.asarray(z, np.float64)
    dz = z[1:] - z[0]
    return dz.astype(np.float32), (dz[:-1] / dz[-1]).astype(np.float32)


def radial_template() -> np.ndarray:
    """The authors' 224x224 8-bit radial image: round(255 * (1 - r / (112 sqrt 2))), clipped at
    0, r the distance of pixel (x, y) from pixel (112, 112). It is their radial2D.png pixel for
    pixel (tests/loaders/test_transforms.py)."""
    c = TEMPLATE_SIZE // 2
    y, x = np.mgrid[:TEMPLATE_SIZE, :TEMPLATE_SIZE]
    r = np.hypot(y - c, x - c)
    return np.clip(np.round(255 * (1 - r / (c * np.sqrt(2)))), 0, 255).astype(np.uint8)


@lru_cache(maxsize=8)
def radial_image(size: tuple[int, int]) -> np.ndarray:
    """(h, w) float32: the radial template resized to `size` by cv2.resize (its default, linear
    interpolation), divided by 255, as the authors' code loads it."""
    h, w = size
    return (cv2.resize(radial_template(), (w, h)) / 255).astype(np.float32)


@dataclass(frozen=True)
class Transform:
    """Masks, camera positions and label of one example to the network inputs.

    `size` (h, w) of the masks given to the network (None: keep the store's size); `n_obs`
    observations (None: all of the example's); `radial` adds the radial image; `rounded` gives
    uint8 0/1 masks (the covered fractions rounded) instead of the paper's float32 fractions.
    """

    kind: ClassVar[str] = "masks"  # the kind of example it takes (kinds.py)
    size: tuple[int, int] | None = PAPER_SIZE
    n_obs: int | None = None
    radial: bool = False
    rounded: bool = False

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
        return {"masks": resize_masks(masks, size, not self.rounded), **self.vectors(z, d1, size)}

    def vectors(self, z: np.ndarray, d1: float, size: tuple[int, int]) -> dict[str, Any]:
        """Every input but the masks (of shape `size`), from the selected z (k,) and label d1."""
        dz, zbar = distances(z)
        out = {"dz": dz, "zbar": zbar, **labels(d1, z)}
        if self.radial:
            out["radial"] = radial_image(size)[None]
        return out


PAPER_TRANSFORM = Transform()  # 112x112 float32 masks, every observation, no radial image
