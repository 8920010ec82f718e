"""Fast paths for masks at training size, for many examples at once, each pixel-exact against
the slow way (render.py, shrink.py).

- `render_masks`: what `render.render_masks(spec, params, size)` draws (the contour drawn
  straight at the small size).
- `render_shrunk`: what `resize_masks(render.render_masks(spec, params), size)` gives (the
  full-size mask shrunk with INTER_AREA, as a store read through the loaders), drawing only each
  object's box at full size (see shrink.py for why that gives the same pixels).
- `render_boxes`: what `render.render_frame` draws into each full-size frame and where (the
  generator writing a store).

The per-frame arithmetic of `render.render_frame` is done once for all frames of all examples,
in the same order of operations (so the same floats), and frames are stacked as rows of one
image where raster.draw_silhouettes draws them in one call; each frame's canvas keeps an empty
border. Frames where a
shortcut would not hold (a box leaving the image) go through render_frame.
tests/loaders/test_loaders_transforms.py checks equality with the slow way.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from ..errors import InputError
from .object_model import ExampleSpec
from .params import GeneratorParams
from .raster import draw_silhouette, draw_silhouettes
from .render import CROSS, render_frame
from .shrink import periods_of, resize_masks, shrink_into

cv2.setNumThreads(1)


@dataclass
class FrameGeometry:
    """Frames of several examples, flattened example-major: F = examples x frames per example."""

    poly: np.ndarray  # (P, 2) vertices relative to each frame's canvas corner
    starts: np.ndarray  # (F + 1,) each frame's first row in `poly`
    lo: np.ndarray  # (F, 2) canvas corner x0, y0 (render_frame's canvas, margin included)
    hi: np.ndarray  # (F, 2) x1, y1, exclusive
    k: np.ndarray  # (F,) perturbation steps
    dilate: np.ndarray  # (F,) whether a perturbation dilates (else erodes)

    def polygon(self, f: int) -> np.ndarray:
        return self.poly[self.starts[f] : self.starts[f + 1]]

    def gather(self, frames: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The vertices of `frames`, in that order, and where each frame's begin (len + 1)."""
        lengths = np.diff(self.starts)[frames]
        starts = np.concatenate([[0], np.cumsum(lengths)])
        rows = np.arange(starts[-1]) + np.repeat(self.starts[frames] - starts[:-1], lengths)
        return self.poly[rows], starts

    def draw(self, image: np.ndarray, frames: np.ndarray, corners: np.ndarray) -> None:
        """Draw the silhouettes of `frames` onto `image`, their canvas corners at `corners` (x, y)."""
        draw_silhouettes(image, self.poly, self.starts, frames, corners)


def frame_geometry(
    specs: Sequence[ExampleSpec], params: GeneratorParams, frames: np.ndarray, size: tuple[int, int]
) -> FrameGeometry:
    """render_frame's arithmetic for `frames` of every example, at once, with the same floats."""
    H0, W0 = params.image_size
    H, W = size
    n = len(frames)
    sx_sy = np.array([W / W0, H / H0])
    scale = params.d_min / np.concatenate([s.z[frames] for s in specs])
    half = scale * np.repeat([s.size for s in specs], n) / 2
    lengths = np.repeat([len(s.contour) for s in specs], n)
    starts = np.concatenate([[0], np.cumsum(lengths)])
    poly = np.concatenate([np.broadcast_to(s.contour, (n, *s.contour.shape)).reshape(-1, 2) for s in specs])
    poly *= np.repeat(scale, lengths)[:, None]  # in place from here on: fewer allocations
    poly += [W0 / 2, H0 / 2]
    poly -= np.repeat(half, lengths)[:, None]
    poly *= sx_sy
    perturb = np.concatenate([s.perturb[frames] for s in specs])
    k = np.round(np.abs(perturb) * sx_sy.min()).astype(np.int64)
    lo = np.floor(np.minimum.reduceat(poly, starts[:-1], axis=0)).astype(np.int64) - (k + 1)[:, None]
    hi = np.ceil(np.maximum.reduceat(poly, starts[:-1], axis=0)).astype(np.int64) + (k + 2)[:, None]
    poly -= np.repeat(lo, lengths, axis=0)
    return FrameGeometry(poly, starts, lo, hi, k, perturb >= 0)


def _frames(specs: Sequence[ExampleSpec], frames: np.ndarray | None) -> np.ndarray:
    if not specs:
        raise InputError("no examples to draw")
    return np.arange(len(specs[0].z)) if frames is None else np.asarray(frames)


def _out(out: np.ndarray | None, shape: tuple[int, ...], dtype) -> np.ndarray:
    """`out` zeroed (the caller's buffer, e.g. a batch in shared memory), or a new zero array."""
    if out is None:
        return np.zeros(shape, dtype)
    if out.shape != shape or out.dtype != dtype or not out.flags.c_contiguous:
        raise InputError(f"out has shape {out.shape} and dtype {out.dtype}; need a C-contiguous "
                         f"array of shape {shape} and dtype {np.dtype(dtype)}")
    out[...] = 0
    return out


def render_masks(
    specs: Sequence[ExampleSpec],
    params: GeneratorParams,
    size: tuple[int, int] | None = None,
    frames: np.ndarray | None = None,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """(examples, k, H, W) uint8 0/1: `render.render_masks(spec, params, size)[frames]` of each
    example (frames default: all), written into `out` when given."""
    H, W = size or params.image_size
    frames = _frames(specs, frames)
    n = len(frames)
    out = _out(out, (len(specs), n, H, W), np.uint8)
    g = frame_geometry(specs, params, frames, (H, W))
    inside = (g.k == 0) & (g.lo >= 0).all(axis=1) & (g.hi[:, 0] <= W) & (g.hi[:, 1] <= H)
    if inside.any():  # frame f is rows f * H ... of out seen as one (examples * k * H, W) image
        rows = np.arange(len(inside)) * H
        stacked = out.reshape(-1, W)
        drawn = np.flatnonzero(inside)
        corners = g.lo + np.stack([np.zeros_like(rows), rows], axis=1)
        g.draw(stacked, drawn, corners[drawn])
    for f in np.flatnonzero(~inside):
        e, j = divmod(int(f), n)
        render_frame(specs[e], params, int(frames[j]), out[e, j])
    return out


def render_boxes(
    specs: Sequence[ExampleSpec], params: GeneratorParams
) -> list[tuple[np.ndarray, int, int, bool] | None]:
    """For every frame of every example (example-major): the pixels `render.render_frame` draws
    into a full-size frame, as (the drawn box, x0, y0, one_region), or None where it draws
    nothing. `one_region`: the object is known to be one 8-connected region, as a silhouette is
    (its contour pixels are a closed chain, the rest enclosed by it) unless eroded or cut by
    the image border."""
    H, W = params.image_size
    g = frame_geometry(specs, params, _frames(specs, None), (H, W))
    size = g.hi - g.lo
    tops = np.concatenate([[0], np.cumsum(size[:, 1])])
    stacked = np.zeros((int(tops[-1]), int(size[:, 0].max())), np.uint8)  # the canvases, top to bottom
    g.draw(stacked, np.arange(len(size)), np.stack([np.zeros_like(tops[:-1]), tops[:-1]], axis=1))
    clip_lo, clip_hi = np.maximum(g.lo, 0), np.minimum(g.hi, [W, H])
    whole = (clip_lo == g.lo).all(axis=1) & (clip_hi == g.hi).all(axis=1) & (g.dilate | (g.k == 0))
    out: list[tuple[np.ndarray, int, int, bool] | None] = []
    for f in range(len(size)):
        canvas: np.ndarray = stacked[tops[f] : tops[f + 1], : size[f, 0]]
        if g.k[f]:
            canvas = (cv2.dilate if g.dilate[f] else cv2.erode)(canvas, CROSS, iterations=int(g.k[f]))
        (x0, y0), (cx0, cy0), (cx1, cy1) = g.lo[f], clip_lo[f], clip_hi[f]
        drawn = cx0 < cx1 and cy0 < cy1
        box = canvas[cy0 - y0 : cy1 - y0, cx0 - x0 : cx1 - x0]
        out.append((box, int(cx0), int(cy0), bool(whole[f])) if drawn else None)
    return out


def render_shrunk(
    specs: Sequence[ExampleSpec],
    params: GeneratorParams,
    size: tuple[int, int],
    frames: np.ndarray | None = None,
    coverage: bool = False,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """(examples, k, h, w): `resize_masks(render.render_masks(spec, params)[frames], size,
    coverage)` of each example, written into `out` when given.

    Each frame's box, widened to whole periods of the INTER_AREA grid, becomes a tile. Tiles of
    one width are stacked in one image, drawn and filled at once, shrunk by one cv2.resize call
    and cut back into their frames. Frames whose box leaves the image go one by one.
    """
    H0, W0 = params.image_size
    h, w = size
    frames = _frames(specs, frames)
    n = len(frames)
    dtype = np.float32 if coverage else np.uint8
    if h > H0 or w > W0:
        full = render_masks(specs, params, None, frames)
        shrunk = np.stack([resize_masks(m, size, coverage) for m in full])
        if out is None:
            return shrunk
        out[...] = shrunk
        return out
    out = _out(out, (len(specs), n, h, w), dtype).reshape(-1, h, w)
    periods = py, qy, px, qx = periods_of((H0, W0), size)
    g = frame_geometry(specs, params, frames, (H0, W0))
    clip_lo, clip_hi = np.maximum(g.lo, 0), np.minimum(g.hi, [W0, H0])
    tile_lo = clip_lo // [px, py] * [px, py]
    tile_hi = -(-clip_hi // [px, py]) * [px, py]
    inside = (g.lo == clip_lo).all(axis=1) & (g.hi == clip_hi).all(axis=1)
    # tiles of one width are stacked top to bottom, in frame order: tile t of a group starts at
    # row top[t] of the group's image
    tiled = np.flatnonzero(inside)
    tiled = tiled[np.argsort(tile_hi[tiled, 0] - tile_lo[tiled, 0], kind="stable")]
    widths, heights = (tile_hi[tiled] - tile_lo[tiled]).T
    groups = np.flatnonzero(np.diff(widths, prepend=-1, append=-1))
    above = np.cumsum(heights) - heights
    top = above - np.repeat(above[groups[:-1]], np.diff(groups))
    offsets = g.lo[tiled] - tile_lo[tiled] + np.stack([np.zeros_like(top), top], axis=1)
    for a, b in zip(groups[:-1], groups[1:], strict=True):
        tiles, width = tiled[a:b], int(widths[a])
        canvas: np.ndarray = np.zeros((int(top[b - 1] + heights[b - 1]), width), np.uint8)
        # render_frame's canvas lies inside the tile with an empty margin, so drawing and
        # perturbing on the tile gives the same pixels as on the canvas
        g.draw(canvas, tiles, offsets[a:b])
        for t in np.flatnonzero(g.k[tiles]) + a:
            band = canvas[top[t] : top[t] + heights[t]]
            op = cv2.dilate if g.dilate[tiled[t]] else cv2.erode
            band[...] = op(band, CROSS, iterations=int(g.k[tiled[t]]))
        ow = width // px * qx
        small = cv2.resize(canvas.astype(dtype, copy=False), (ow, len(canvas) // py * qy),
                           interpolation=cv2.INTER_AREA)
        for t in range(a, b):
            (X0, Y0), oh, r = tile_lo[tiled[t]], heights[t] // py * qy, top[t] // py * qy
            oy, ox = Y0 // py * qy, X0 // px * qx
            out[tiled[t], oy : oy + oh, ox : ox + ow] = small[r : r + oh]
    for f in np.flatnonzero((clip_lo < clip_hi).all(axis=1) & ~inside):
        (x0, y0), (x1, y1), (X0, Y0), (X1, Y1) = g.lo[f], g.hi[f], tile_lo[f], tile_hi[f]
        (cx0, cy0), (cx1, cy1) = clip_lo[f], clip_hi[f]
        canvas = np.zeros((y1 - y0, x1 - x0), np.uint8)
        draw_silhouette(canvas, g.polygon(int(f)))
        if g.k[f]:
            canvas = (cv2.dilate if g.dilate[f] else cv2.erode)(canvas, CROSS, iterations=int(g.k[f]))
        crop = np.zeros((Y1 - Y0, X1 - X0), dtype)
        crop[cy0 - Y0 : cy1 - Y0, cx0 - X0 : cx1 - X0] = canvas[cy0 - y0 : cy1 - y0, cx0 - x0 : cx1 - x0]
        shrink_into(out[f], crop, int(X0), int(Y0), periods)
    return out.reshape(len(specs), n, h, w)
