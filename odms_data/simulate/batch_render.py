"""Fast paths for masks at training size, for many examples at once, each pixel-exact against
the slow way (render.py, shrink.py).

- `render_masks`: what `render.reference_masks(spec, params, size)` draws (the contour drawn
  straight at the small size).
- `render_shrunk`: what `resize_masks(render.reference_masks(spec, params), size)` gives (the
  full-size mask shrunk with INTER_AREA, as a store read through the loaders), drawing only each
  object's canvas at full size and shrinking it with cv2's arithmetic (shrink.shrink_canvases).
- `render_boxes`: what `render.render_frame` draws into each full-size frame and where (the
  generator writing a store).

The per-frame arithmetic of `render.render_frame` is done once for all frames of all examples,
in the same order of operations (so the same floats), and the frames' canvases are stacked as
rows of one image where raster.draw_silhouettes draws them in one call. render_masks draws
frames whose canvas leaves the image, or is perturbed, through render_frame.
tests/loaders/test_transforms.py checks equality with the slow way."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from ..errors import InputError
from .kernel import kernel
from .object_model import ExampleSpec
from .params import GeneratorParams
from .raster import draw_silhouettes
from .render import CROSS, render_frame
from .shrink import computes_like_cv2, resize_masks, shrink_canvases, shrink_tables, stacked_canvases


@dataclass
class FrameGeometry:
    """Frames of several examples, flattened example-major: F = examples x frames per example."""

    poly: np.ndarray  # (P, 2) vertices relative to each frame's canvas corner
    starts: np.ndarray  # (F + 1,) each frame's first row in `poly`
    lo: np.ndarray  # (F, 2) canvas corner x0, y0 (render_frame's canvas, margin included)
    hi: np.ndarray  # (F, 2) x1, y1, exclusive
    k: np.ndarray  # (F,) perturbation steps
    dilate: np.ndarray  # (F,) whether a perturbation dilates (else erodes)

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
    sx, sy = W / W0, H / H0
    scale = params.d_min / np.concatenate([s.z[frames] for s in specs])
    half = scale * np.repeat([s.size for s in specs], n) / 2
    lengths = np.array([len(s.contour) for s in specs])
    starts = np.concatenate([[0], np.cumsum(np.repeat(lengths, n))])
    perturb = np.concatenate([s.perturb[frames] for s in specs])
    k = np.round(np.abs(perturb) * min(sx, sy)).astype(np.int64)
    contours = np.concatenate([s.contour for s in specs])
    poly, lo, hi = _placed(contours, lengths, n, scale, half, W0 / 2, H0 / 2, sx, sy, k)
    return FrameGeometry(poly, starts, lo, hi, k, perturb >= 0)


@kernel
def _placed(contours, lengths, n, scale, half, cx, cy, sx, sy, k):
    """Each example's contour placed in each of its n frames f (example-major): render_frame's
    ((c * scale + centre) - half) * s per axis, then made relative to the canvas corner lo;
    returns the vertices, lo and hi (exclusive) of every frame's canvas."""
    F = len(lengths) * n
    poly = np.empty((n * lengths.sum(), 2))
    lo, hi = np.empty((F, 2), np.int64), np.empty((F, 2), np.int64)
    row, first = 0, 0
    for e in range(len(lengths)):
        m = lengths[e]
        for f in range(e * n, e * n + n):
            for a, c, s in ((0, cx, sx), (1, cy, sy)):
                low, high = np.inf, -np.inf
                for v in range(m):
                    p = (contours[first + v, a] * scale[f] + c - half[f]) * s
                    poly[row + v, a] = p
                    low, high = min(low, p), max(high, p)
                lo[f, a] = int(np.floor(low)) - (k[f] + 1)
                hi[f, a] = int(np.ceil(high)) + k[f] + 2
                poly[row : row + m, a] -= lo[f, a]
            row += m
        first += m
    return poly, lo, hi


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
    """(examples, k, H, W) uint8 0/1: `render.reference_masks(spec, params, size)[frames]` of each
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


def _canvases(g: FrameGeometry) -> tuple[np.ndarray, np.ndarray]:
    """Every frame's canvas as render_frame draws and perturbs it, stacked top to bottom in one
    image as wide as the widest (frame f from row tops[f], column 0); returns (image, tops)."""
    size = g.hi - g.lo
    stacked, tops = stacked_canvases(size)
    g.draw(stacked, np.arange(len(size)), np.stack([np.zeros_like(tops), tops], axis=1))
    for f in np.flatnonzero(g.k):
        band = stacked[tops[f] : tops[f] + size[f, 1], : size[f, 0]]
        band[...] = (cv2.dilate if g.dilate[f] else cv2.erode)(band, CROSS, iterations=int(g.k[f]))
    return stacked, tops


@dataclass
class FrameBoxes:
    """What `render.render_frame` draws into each full-size frame of several examples
    (example-major): frame f's pixels are the box of `image` from row top[f] and column left[f],
    of size hi[f] - lo[f], placed at lo[f] (x0, y0) of the frame; an empty box at (0, 0) where
    it draws nothing."""

    image: np.ndarray  # the frames' canvases stacked, uint8 0/1
    top: np.ndarray  # (F,) int64
    left: np.ndarray  # (F,) int64
    lo: np.ndarray  # (F, 2) int64, clipped to the frame
    hi: np.ndarray  # (F, 2) int64, exclusive
    one_region: np.ndarray  # (F,) bool: the object is known to be one 8-connected region

    @property
    def drawn(self) -> np.ndarray:
        """(F,) bool: render_frame draws into the frame."""
        return np.all(self.lo < self.hi, axis=1)

    def pixels(self, f: int) -> np.ndarray:
        """Frame f's box of pixels (a view of `image`)."""
        (x0, y0), (x1, y1) = self.lo[f], self.hi[f]
        return self.image[self.top[f] : self.top[f] + y1 - y0, self.left[f] : self.left[f] + x1 - x0]


def render_boxes(specs: Sequence[ExampleSpec], params: GeneratorParams) -> FrameBoxes:
    """The pixels `render.render_frame` draws into every frame of every example, and where.

    `one_region` holds where the object is a silhouette, one 8-connected region (its contour
    pixels are a closed chain, the rest enclosed by it): not eroded nor cut by the image border.
    """
    H, W = params.image_size
    g = frame_geometry(specs, params, _frames(specs, None), (H, W))
    stacked, tops = _canvases(g)
    lo, hi = np.maximum(g.lo, 0), np.minimum(g.hi, [W, H])
    whole = (lo == g.lo).all(axis=1) & (hi == g.hi).all(axis=1) & (g.dilate | (g.k == 0))
    top, left = tops + lo[:, 1] - g.lo[:, 1], lo[:, 0] - g.lo[:, 0]
    outside = (lo >= hi).any(axis=1)  # wholly outside the frame: an empty box at (0, 0)
    lo[outside] = hi[outside] = 0
    return FrameBoxes(stacked, top, left, lo, hi, whole)


def render_shrunk(
    specs: Sequence[ExampleSpec],
    params: GeneratorParams,
    size: tuple[int, int],
    frames: np.ndarray | None = None,
    coverage: bool = False,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """(examples, k, h, w): `resize_masks(render.reference_masks(spec, params)[frames], size,
    coverage)` of each example, written into `out` when given.

    Each frame's canvas is drawn at full size and shrunk by shrink.shrink_canvases, which does
    cv2's arithmetic on the canvas' pixels alone. Sizes where cv2 would grow an axis, and uint8
    masks at whole-number scales (cv2's fast path rounds its own way), are drawn as full frames
    and shrunk by cv2.
    """
    H0, W0 = params.image_size
    h, w = size
    frames = _frames(specs, frames)
    dtype = np.float32 if coverage else np.uint8
    if not computes_like_cv2((H0, W0), size, coverage):
        full = render_masks(specs, params, None, frames)
        shrunk = np.stack([resize_masks(m, size, coverage) for m in full])
        if out is None:
            return shrunk
        out[...] = shrunk
        return out
    out = _out(out, (len(specs), len(frames), h, w), dtype)
    g = frame_geometry(specs, params, frames, (H0, W0))
    stacked, tops = _canvases(g)
    tables = shrink_tables((H0, W0), size)
    shrink_canvases(stacked, tops, g.lo, g.hi, out.reshape(-1, h, w), not coverage, *tables)
    return out
