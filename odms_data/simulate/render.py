"""Drawing an example's masks, one frame at a time, at the generator's size or any other.

The reference renderer: batch_render.py's fast paths must match it pixel for pixel. Silhouettes
follow raster.py's rule; a perturbation then erodes or dilates the silhouette.
"""

from __future__ import annotations

import cv2
import numpy as np

from .object_model import ExampleSpec
from .params import GeneratorParams
from .raster import draw_silhouette

CROSS = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))  # the perturbation's structuring element


def render_frame(
    spec: ExampleSpec, params: GeneratorParams, i: int, out: np.ndarray
) -> tuple[int, int, int, int] | None:
    """Draw frame i into `out` (H, W uint8, zeros); returns the drawn box x0, y0, x1, y1 or None.

    The contour is scaled by d_min / z_i, its box centred in the image; `out` may be smaller
    than params.image_size (training resolution), in which case coordinates are scaled per
    axis and the perturbation's iterations by the smaller axis factor. The silhouette is drawn
    (raster.py) and perturbed on a canvas with a margin, so the image border neither closes the
    contour nor erodes the object.
    """
    H0, W0 = params.image_size
    H, W = out.shape
    sy, sx = H / H0, W / W0
    scale = params.d_min / spec.z[i]
    half = scale * spec.size / 2
    poly = spec.contour * scale
    poly[:, 0] = (poly[:, 0] + W0 / 2 - half) * sx
    poly[:, 1] = (poly[:, 1] + H0 / 2 - half) * sy
    p = spec.perturb[i]
    k = int(np.round(abs(p) * min(sx, sy)))
    margin = k + 1
    x0, y0 = int(np.floor(poly[:, 0].min())) - margin, int(np.floor(poly[:, 1].min())) - margin
    x1, y1 = int(np.ceil(poly[:, 0].max())) + margin + 1, int(np.ceil(poly[:, 1].max())) + margin + 1
    canvas: np.ndarray = np.zeros((y1 - y0, x1 - x0), np.uint8)
    draw_silhouette(canvas, poly - [x0, y0])
    if k:
        op = cv2.dilate if p >= 0 else cv2.erode
        canvas = op(canvas, CROSS, iterations=k)
    cx0, cy0, cx1, cy1 = max(x0, 0), max(y0, 0), min(x1, W), min(y1, H)
    if cx0 >= cx1 or cy0 >= cy1:
        return None
    out[cy0:cy1, cx0:cx1] = canvas[cy0 - y0 : cy1 - y0, cx0 - x0 : cx1 - x0]
    return cx0, cy0, cx1, cy1


def reference_masks(
    spec: ExampleSpec, params: GeneratorParams, size: tuple[int, int] | None = None
) -> np.ndarray:
    """(n, H, W) uint8 0/1 masks of an example, at params.image_size or at `size`."""
    H, W = size or params.image_size
    out = np.zeros((len(spec.z), H, W), np.uint8)
    for i in range(len(spec.z)):
        render_frame(spec, params, i, out[i])
    return out
