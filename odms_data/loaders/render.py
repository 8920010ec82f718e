"""Fast paths for masks at training size, each pixel-exact against the slow way.

- `render_masks`: what `generator.render_masks(spec, params, size)` draws (the contour drawn
  straight at the small size), with the per-frame NumPy work done once for all frames.
- `render_shrunk`: what `resize_masks(generator.render_masks(spec, params), size)` gives (the
  full-size mask shrunk with INTER_AREA, as a store read through the loaders), drawing only the
  object's box at full size: cv2's INTER_AREA weights depend only on the scale, so a crop whose
  edges fall on a whole period of the input/output pixel grids (40 input columns per 7 output
  ones for 640 -> 112) shrinks to exactly the same pixels as the full frame.
- `shrink_boxes`: the same shortcut for stored masks, whose boxes the store records.

Both fall back to `generator.render_frame` (or a full frame) wherever the shortcut would not hold.
tests/test_loaders_transforms.py checks equality with the slow way.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from ..generator import _CROSS, _SHIFT, ExampleSpec, GeneratorParams, render_frame
from .transforms import resize_masks

cv2.setNumThreads(1)


def _geometry(spec: ExampleSpec, params: GeneratorParams, frames: np.ndarray, size: tuple[int, int]):
    """render_frame's per-frame arithmetic, for several frames at once and in the same order of
    operations (so the same floats): fixed-point vertices relative to each frame's canvas, the
    canvas corners lo (x0, y0) and hi (x1, y1), and the perturbation steps k."""
    H0, W0 = params.image_size
    H, W = size
    sx_sy = np.array([W / W0, H / H0])
    scale = params.d_min / spec.z[frames]
    half = (scale * spec.size / 2)[:, None, None]
    centre = np.array([W0 / 2, H0 / 2])
    c = spec.contour
    poly = np.multiply(c[None], scale[:, None, None])  # in place from here on: fewer allocations
    poly += centre
    poly -= half
    poly *= sx_sy
    # The mapping is monotone in each coordinate, so the extremes of the mapped contour are the
    # mapped extremes.
    ends = ((np.stack([c.min(axis=0), c.max(axis=0)])[None] * scale[:, None, None] + centre) - half) * sx_sy
    k = np.round(np.abs(spec.perturb[frames]) * sx_sy.min()).astype(np.int64)
    lo = np.floor(ends[:, 0]).astype(np.int64) - (k + 1)[:, None]
    hi = np.ceil(ends[:, 1]).astype(np.int64) + (k + 2)[:, None]
    poly -= lo[:, None, :]
    poly *= 1 << _SHIFT
    return np.rint(poly, out=poly).astype(np.int32), lo, hi, k


def _frames(spec: ExampleSpec, frames: np.ndarray | None) -> np.ndarray:
    return np.arange(len(spec.z)) if frames is None else np.asarray(frames)


def render_masks(
    spec: ExampleSpec,
    params: GeneratorParams,
    size: tuple[int, int] | None = None,
    frames: np.ndarray | None = None,
) -> np.ndarray:
    """(k, H, W) uint8 0/1: `generator.render_masks(spec, params, size)[frames]` (default: all)."""
    H, W = size or params.image_size
    frames = _frames(spec, frames)
    out = np.zeros((len(frames), H, W), np.uint8)
    fixed, lo, hi, k = _geometry(spec, params, frames, (H, W))
    inside = (k == 0) & (lo >= 0).all(axis=1) & (hi[:, 0] <= W) & (hi[:, 1] <= H)
    offset = lo << _SHIFT
    for j, f in enumerate(frames):
        if inside[j]:
            cv2.fillPoly(out[j], [fixed[j]], 1, cv2.LINE_8, _SHIFT, (int(offset[j, 0]), int(offset[j, 1])))
        else:
            render_frame(spec, params, int(f), out[j])
    return out


def _aligned(a: int, b: int, period: int) -> tuple[int, int]:
    """[a, b) widened to multiples of period."""
    return a // period * period, -(-b // period) * period


def _periods(full: tuple[int, int], size: tuple[int, int]) -> tuple[int, int, int, int]:
    """Input and output pixels per period of INTER_AREA's grid: rows py -> qy, columns px -> qx."""
    (H0, W0), (h, w) = full, size
    gy, gx = math.gcd(H0, h), math.gcd(W0, w)
    return H0 // gy, h // gy, W0 // gx, w // gx


def _shrink_into(out: np.ndarray, crop: np.ndarray, X0: int, Y0: int, periods: tuple) -> None:
    """Write the INTER_AREA shrink of `crop`, the aligned region at (X0, Y0) of a full frame, into
    its place in `out`, the shrunk frame."""
    py, qy, px, qx = periods
    oy0, ox0 = Y0 // py * qy, X0 // px * qx
    oh, ow = crop.shape[0] // py * qy, crop.shape[1] // px * qx
    out[oy0 : oy0 + oh, ox0 : ox0 + ow] = cv2.resize(crop, (ow, oh), interpolation=cv2.INTER_AREA)


def shrink_boxes(masks: np.ndarray, boxes: np.ndarray, size: tuple[int, int], coverage: bool = False):
    """`resize_masks(masks, size, coverage)` for (k, H, W) masks whose objects lie inside `boxes`
    (k, 4: x0, y0, x1, y1 half-open, as stored): only each box, widened to the grid, is shrunk."""
    k, H0, W0 = masks.shape
    if size[0] > H0 or size[1] > W0:
        return resize_masks(masks, size, coverage)
    out = np.zeros((k, *size), np.float32 if coverage else np.uint8)
    periods = _periods((H0, W0), size)
    py, _, px, _ = periods
    for j, (x0, y0, x1, y1) in enumerate(np.asarray(boxes, np.int64)):
        if x0 >= x1 or y0 >= y1:
            continue
        X0, X1 = _aligned(x0, x1, px)
        Y0, Y1 = _aligned(y0, y1, py)
        crop = masks[j, Y0:Y1, X0:X1].astype(out.dtype)
        _shrink_into(out[j], crop, X0, Y0, periods)
    return out


def render_shrunk(
    spec: ExampleSpec,
    params: GeneratorParams,
    size: tuple[int, int],
    frames: np.ndarray | None = None,
    coverage: bool = False,
) -> np.ndarray:
    """(k, h, w): `resize_masks(generator.render_masks(spec, params)[frames], size, coverage)`."""
    H0, W0 = params.image_size
    h, w = size
    frames = _frames(spec, frames)
    if h > H0 or w > W0:
        return resize_masks(render_masks(spec, params, None, frames), size, coverage)
    out = np.zeros((len(frames), h, w), np.float32 if coverage else np.uint8)
    periods = _periods((H0, W0), size)
    py, _, px, _ = periods
    fixed, lo, hi, k = _geometry(spec, params, frames, (H0, W0))
    for j in range(len(frames)):
        (x0, y0), (x1, y1) = lo[j], hi[j]
        cx0, cy0, cx1, cy1 = max(x0, 0), max(y0, 0), min(x1, W0), min(y1, H0)
        if cx0 >= cx1 or cy0 >= cy1:
            continue
        X0, X1 = _aligned(cx0, cx1, px)
        Y0, Y1 = _aligned(cy0, cy1, py)
        op = (cv2.dilate if spec.perturb[frames[j]] >= 0 else cv2.erode) if k[j] else None
        if (cx0, cy0, cx1, cy1) == (x0, y0, x1, y1):
            # render_frame's canvas lies inside the crop with an empty margin, so drawing and
            # perturbing on the crop itself gives the same pixels
            crop = np.zeros((Y1 - Y0, X1 - X0), np.uint8)
            offset = (int(x0 - X0) << _SHIFT, int(y0 - Y0) << _SHIFT)
            cv2.fillPoly(crop, [fixed[j]], 1, cv2.LINE_8, _SHIFT, offset)
            if op:
                crop = op(crop, _CROSS, iterations=int(k[j]))
        else:
            canvas = np.zeros((y1 - y0, x1 - x0), np.uint8)
            cv2.fillPoly(canvas, [fixed[j]], 1, cv2.LINE_8, _SHIFT)
            if op:
                canvas = op(canvas, _CROSS, iterations=int(k[j]))
            crop = np.zeros((Y1 - Y0, X1 - X0), np.uint8)
            crop[cy0 - Y0 : cy1 - Y0, cx0 - X0 : cx1 - X0] = canvas[cy0 - y0 : cy1 - y0, cx0 - x0 : cx1 - x0]
        _shrink_into(out[j], crop.astype(out.dtype, copy=False), X0, Y0, periods)
    return out
