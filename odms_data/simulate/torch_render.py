"""The paper's coverage masks drawn by PyTorch, on whatever device the caller names (CPU, CUDA,
...): `render_coverage` equals `batch_render.render_shrunk(..., coverage=True)` within float32
rounding.

The CPU makes the examples' random draws and each frame's polygon (object_model,
batch_render.frame_geometry); the device does the rest,
for all frames at once, on canvases grouped by size:

- the pixels each contour passes through (the float64 operations of raster.py's marking in the
  same order, so the same pixels);
- filling what they enclose (raster.py's rule: background not
  4-connected to the canvas border). Connectivity, not crossing parity: a pocket of background
  closed off by contour pixels, or a loop of a self-crossing contour, is object under the rule
  though a scanline's crossings would call it outside. Reachability from the border spreads
  along whole runs of background, alternately along rows and columns, until nothing changes
  (a path needs one step per turn, so a few steps suffice);
- the perturbation's erosion or dilation with the 3x3 cross, k steps per frame;
- the shrink: cv2's INTER_AREA is separable with fixed weights, so each frame's coverage is
  Ay[:, rows] @ canvas @ Ax[:, cols]^T with the weight matrices taken from cv2 itself (resizing
  an identity matrix), in float32 at full precision (no TF32).

The tests run it on CPU (tests/simulate/test_torch_render.py); benchmarks/torch_render.py
measures it on any device.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from functools import lru_cache

import cv2
import numpy as np

from ..errors import InputError
from ..extras import missing
from .batch_render import frame_geometry
from .object_model import ExampleSpec
from .params import GeneratorParams

try:
    import torch
except ModuleNotFoundError as e:
    raise missing(e, "odms_data.simulate.torch_render") from None

PIXEL_BUDGET = 1 << 26  # canvas pixels drawn at once (float32 shrink temporaries: a few GB at most)
SIZE_STEP = 1.25  # canvases drawn together differ in size by less than this factor


@lru_cache(maxsize=8)
def area_matrix(full: int, small: int) -> np.ndarray:
    """(small, full) float32: cv2 INTER_AREA's weights of the `full` input pixels in each of the
    `small` output pixels along one axis, read off cv2 by shrinking an identity matrix."""
    eye = np.eye(full, dtype=np.float32)
    return cv2.resize(eye, (full, small), interpolation=cv2.INTER_AREA)


def contour_pixels(poly: torch.Tensor, starts: torch.Tensor, width: int, base: torch.Tensor) -> torch.Tensor:
    """Flat indices `y * width + x + base[j]` of the pixels (x, y) closed polygon j passes through
    (raster.py's marking, the same float64 operations in the same order, so the same pixels), on
    `poly`'s device; a pixel may appear more than once. Polygon j is rows starts[j] ..
    starts[j + 1] - 1 of poly (P, 2) float64; starts (F + 1,) and base (F,) int64."""
    P, on = len(poly), poly.device
    succ = torch.arange(1, P + 1, device=on)
    succ[starts[1:] - 1] = starts[:-1]
    nxt = poly[succ]
    a0, a1 = poly.T.reshape(-1), nxt.T.reshape(-1)  # edges 0..P-1 cross x = X, P..2P-1 y = Y
    b0 = poly.flip(1).T.reshape(-1)
    first = torch.floor(torch.minimum(a0, a1)) + 1
    count = torch.clamp(torch.floor(torch.maximum(a0, a1)) - first + 1, min=0).to(torch.int64)
    edge = torch.repeat_interleave(torch.arange(2 * P, device=on), count)
    ends = torch.cumsum(count, 0)
    line = torch.arange(len(edge), device=on) + torch.repeat_interleave(first - (ends - count), count)
    slope = (nxt.flip(1).T.reshape(-1) - b0)[edge] / (a1 - a0)[edge]
    across = torch.floor(b0[edge] + (line - a0[edge]) * slope)
    line -= (a1 < a0)[edge].to(line.dtype)
    nx = int(ends[P - 1]) if P else 0
    index = torch.cat((across[:nx] * width + line[:nx], line[nx:] * width + across[nx:]))
    start = torch.floor(poly[starts[:-1]])
    index = torch.cat((start[:, 1] * width + start[:, 0], index))
    index += torch.cat((base, base.repeat_interleave(torch.diff(starts)).repeat(2)[edge])).to(index.dtype)
    return index.to(torch.int64)


def _runs_reached(background: torch.Tensor, reached: torch.Tensor) -> torch.Tensor:
    """Background pixels in a run (along the last axis) of background holding a reached pixel."""
    start = background.clone()
    start[..., 1:] &= ~background[..., :-1]
    run = torch.cumsum(start.reshape(-1), 0, dtype=torch.int64).reshape(background.shape)
    hit = torch.zeros(run.numel() + 1, dtype=torch.bool, device=run.device)  # no sync for run.max()
    hit[run[reached]] = True
    return background & hit[run]


def fill_enclosed(canvas: torch.Tensor) -> torch.Tensor:
    """(F, H, W) bool contour pixels to silhouettes: every pixel not 4-connected through
    background to its canvas's border (the border itself must be background)."""
    background = ~canvas
    reached = torch.zeros_like(background)
    reached[:, 0], reached[:, -1], reached[:, :, 0], reached[:, :, -1] = True, True, True, True
    reached &= background
    count = -1
    while True:
        reached = _runs_reached(background, reached)
        reached = _runs_reached(background.transpose(1, 2).contiguous(),
                                reached.transpose(1, 2).contiguous()).transpose(1, 2)
        now = int(reached.sum())
        if now == count:
            return ~reached
        count = now


def perturb(canvas: torch.Tensor, k: torch.Tensor, dilate: torch.Tensor) -> torch.Tensor:
    """Dilate (where `dilate`) or erode each (H, W) frame of `canvas` (F, H, W bool) k[f] times
    with the 3x3 cross, as cv2.dilate / cv2.erode with iterations=k on a canvas with an empty
    border."""
    for step in range(int(k.max()) if k.numel() else 0):
        padded = torch.nn.functional.pad(canvas.to(torch.uint8), (1, 1, 1, 1)).bool()
        up, down = padded[:, :-2, 1:-1], padded[:, 2:, 1:-1]
        left, right = padded[:, 1:-1, :-2], padded[:, 1:-1, 2:]
        grown = canvas | up | down | left | right
        shrunk = canvas & up & down & left & right  # the border is empty, so 0 outside is as good as 1
        changed = torch.where(dilate[:, None, None], grown, shrunk)
        canvas = torch.where((k > step)[:, None, None], changed, canvas)
    return canvas


def _similar_sizes(extent: np.ndarray) -> Iterator[np.ndarray]:
    """Frames (indices into `extent`, (F, 2) canvas widths and heights) in groups drawn together:
    canvases within a factor SIZE_STEP of each other, at most PIXEL_BUDGET padded pixels a group."""
    side = extent.max(axis=1)
    bucket = np.ceil(np.log(side) / np.log(SIZE_STEP)).astype(np.int64)
    order = np.argsort(bucket, kind="stable")
    edges = np.flatnonzero(np.diff(bucket[order], prepend=-1, append=-1))
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        group = order[a:b]
        step = max(1, PIXEL_BUDGET // int(extent[group].max(axis=0).prod()))
        for c in range(0, len(group), step):
            yield group[c : c + step]


@contextmanager
def _full_precision() -> Iterator[None]:
    """float32 matrix products without TF32 or bf16 shortcuts, the previous setting restored."""
    before = torch.get_float32_matmul_precision()
    torch.set_float32_matmul_precision("highest")
    try:
        yield
    finally:
        torch.set_float32_matmul_precision(before)


def render_coverage(
    specs: Sequence[ExampleSpec],
    params: GeneratorParams,
    size: tuple[int, int] = (112, 112),
    frames: np.ndarray | None = None,
    device: str | torch.device = "cpu",
) -> torch.Tensor:
    """(examples, k, h, w) float32 on `device`: the fraction of each pixel of `size` each frame
    in `frames` (default: all) of each example covers, as render_shrunk(specs, params, size,
    frames, coverage=True)."""
    if not specs:
        raise InputError("no examples to draw")
    H0, W0 = params.image_size
    h, w = size
    if not (0 < h <= H0 and 0 < w <= W0):
        raise InputError(f"size must be at most the generator's {params.image_size}, got {size}")
    frames = np.arange(len(specs[0].z)) if frames is None else np.asarray(frames)
    g = frame_geometry(specs, params, frames, (H0, W0))
    extent = g.hi - g.lo
    pad_x, pad_y = (int(v) for v in extent.max(axis=0))  # canvases overlap the image
    ay, ax = np.zeros((h, H0 + 2 * pad_y), np.float32), np.zeros((w, W0 + 2 * pad_x), np.float32)
    ay[:, pad_y : pad_y + H0], ax[:, pad_x : pad_x + W0] = area_matrix(H0, h), area_matrix(W0, w)
    ay_t, ax_t = torch.from_numpy(ay).to(device), torch.from_numpy(ax).to(device)
    total = len(g.k)
    out = torch.empty((total, h, w), dtype=torch.float32, device=device)
    for part in _similar_sizes(extent):
        ch, cw = (int(v) for v in extent[part].max(axis=0)[::-1])
        poly, starts = (torch.from_numpy(a).to(device) for a in g.gather(part))
        base = torch.arange(len(part), device=device) * (ch * cw)
        canvas = torch.zeros(len(part) * ch * cw, dtype=torch.bool, device=device)
        canvas[contour_pixels(poly, starts, cw, base)] = True
        masks = fill_enclosed(canvas.reshape(len(part), ch, cw))
        if g.k[part].any():
            masks = perturb(masks, torch.from_numpy(g.k[part]).to(device),
                            torch.from_numpy(g.dilate[part]).to(device))
        lo = torch.from_numpy(g.lo[part]).to(device)
        rows = lo[:, 1:2] + pad_y + torch.arange(ch, device=device)  # image rows, shifted by pad_y
        cols = lo[:, 0:1] + pad_x + torch.arange(cw, device=device)
        with _full_precision():
            shrunk = torch.bmm(torch.bmm(ay_t[:, rows].transpose(0, 1), masks.float()),
                               ax_t[:, cols].permute(1, 2, 0))
        out[torch.from_numpy(part).to(device)] = shrunk
    return out.reshape(len(specs), len(frames), h, w)
