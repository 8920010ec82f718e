"""A fast path for `generator.render_masks`: the same pixels, with the per-frame NumPy work done
once for all frames of an example.

Frames whose drawn box would leave the image, or that are perturbed by at least one dilation or
erosion step, go through `generator.render_frame` itself; every other frame is filled straight
into its output with the same fixed-point vertices. tests/test_loaders_render.py checks equality
with `generator.render_masks` at native and training sizes.
"""

from __future__ import annotations

import cv2
import numpy as np

from ..generator import _SHIFT, ExampleSpec, GeneratorParams, render_frame

cv2.setNumThreads(1)


def render_masks(
    spec: ExampleSpec,
    params: GeneratorParams,
    size: tuple[int, int] | None = None,
    frames: np.ndarray | None = None,
) -> np.ndarray:
    """(k, H, W) uint8 0/1 masks of the given frames (default: all) at params.image_size or `size`."""
    H0, W0 = params.image_size
    H, W = size or params.image_size
    frames = np.arange(len(spec.z)) if frames is None else np.asarray(frames)
    out = np.zeros((len(frames), H, W), np.uint8)
    sy, sx = H / H0, W / W0
    scale = params.d_min / spec.z[frames]
    half = scale * spec.size / 2
    shift = np.stack([W0 / 2 - half, H0 / 2 - half], axis=1)[:, None, :]
    axis_scale = np.array([sx, sy])
    # Rounding is monotone, so the extremes of the mapped contour are the mapped extremes.
    c = spec.contour
    poly = (c[None] * scale[:, None, None] + shift) * axis_scale
    ends = (np.stack([c.min(axis=0), c.max(axis=0)])[None] * scale[:, None, None] + shift) * axis_scale
    k = np.round(np.abs(spec.perturb[frames]) * min(sx, sy)).astype(np.int64)
    lo = np.floor(ends[:, 0]).astype(np.int64) - (k + 1)[:, None]
    hi = np.ceil(ends[:, 1]).astype(np.int64) + (k + 2)[:, None]
    inside = (k == 0) & (lo >= 0).all(axis=1) & (hi[:, 0] <= W) & (hi[:, 1] <= H)
    fixed = np.round((poly - lo[:, None, :]) * (1 << _SHIFT)).astype(np.int32)
    offset = lo << _SHIFT
    for j, f in enumerate(frames):
        if inside[j]:
            cv2.fillPoly(out[j], [fixed[j]], 1, cv2.LINE_8, _SHIFT, (int(offset[j, 0]), int(offset[j, 1])))
        else:
            render_frame(spec, params, int(f), out[j])
    return out
